"""Why the original drove through a head-on sphere, and what pfield does instead.

Run: ``python examples/manipulator/head_on_comparison.py [--output-dir DIR]``. What to look at: the printed
table compares, along the straight start–goal line through a sphere, the raw wrench (attraction +
bounded Khatib repulsion) with the constrained twist. The original removed the repulsion component that
opposes the attraction, so its command kept pointing through the sphere; pfield's velocity damper lets the
approach speed fall to zero at the safety distance and turns the rest into motion around the sphere
(``approach`` column → 0, ``tangential`` column grows). The PNG shows the planned path going over the top
with positive clearance everywhere.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from pfield import FieldConfig, Obstacle, PotentialField, Sphere
from pfield.spatial import Pose
from pfield.viz.plots import save_path_plot


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--output-dir", type=Path, default=Path("demo_output") / "examples")
    args = parser.parse_args()
    ball = Obstacle("ball", Sphere(radius=0.1), Pose((0.5, 0.0, 0.3)))
    goal = Pose((0.8, 0.0, 0.3))
    field = PotentialField(FieldConfig(), goal, [ball])
    print(f"{'x (m)':>7} {'clearance':>10} {'wrench x (N)':>13} {'approach (m/s)':>15} {'tangential (m/s)':>17}")
    for x in (0.2, 0.3, 0.33, 0.36, 0.38, 0.39):
        pose = Pose((x, 0.0, 0.3))
        wrench, twist = field.wrench(pose), field.twist(pose)
        tangential = float(np.linalg.norm(twist.linear[1:]))
        clearance = float(field.clearances([pose.position])[0])
        print(f"{x:7.2f} {clearance:10.3f} {wrench.force[0]:13.3f} {twist.linear[0]:15.4f} {tangential:17.4f}")
    path = field.plan(Pose((0.2, 0.0, 0.3)))
    print(f"plan: success={path.success}, {len(path)} waypoints, min clearance {path.min_clearance:.4f} m")
    target = save_path_plot(path, args.output_dir / "example_head_on.png", [ball], goal)
    print(f"wrote {target}")


if __name__ == "__main__":
    main()
