"""FindValidPose with the library API on the shipped example map, with a circular and a rectangular robot.

Run: ``python examples/costmap/find_valid_pose.py [--output-dir DIR]``. What to look at: the printed table
(state, cost, how far the answer moved and turned) and the two PNGs — the dots are the candidate positions
tried, coloured by the best state found there. The request sits on the table's corner: the round robot
(r 0.25 m) gets off it 0.35 m away, the 0.8 × 0.5 m rectangle 0.40 m away, both INSCRIBED (touching the
inflated zone next to the table, which is the closest valid place).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from pfield.costmap import CostmapParams, build_costmap, example_map_path, find_valid_pose, load_map
from pfield.spatial import Pose
from pfield.viz.costmap_plots import plot_find_valid_pose

ROBOTS = {
    "round": CostmapParams(robot_radius=0.25),
    "rectangle": CostmapParams(footprint="[[0.4, 0.25], [-0.4, 0.25], [-0.4, -0.25], [0.4, -0.25]]"),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output-dir", type=Path, default=Path("demo_output") / "examples")
    args = parser.parse_args()
    occupancy = load_map(example_map_path())
    request = Pose.planar(-1.2, -1.3, 0.4)  # on the table's top-left corner
    for name, params in ROBOTS.items():
        costmap = build_costmap(occupancy, params)  # inflated for this robot's padded inscribed radius
        footprint = params.robot_footprint()
        result = find_valid_pose(costmap, footprint, request, dist_tolerance=1.0, angle_tolerance=math.pi / 2)
        png = plot_find_valid_pose(costmap, footprint, request, result, args.output_dir / f"fvp_{name}.png",
                                   title=f"{name} robot")
        moved = "no pose" if result.distance is None else f"moved {result.distance:.2f} m"
        print(f"{name:10s} {result.state.name:10s} cost {result.cost:6d}  {moved}  -> {png}")


if __name__ == "__main__":
    main()
