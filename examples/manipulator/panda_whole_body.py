"""Whole-body planning with the Franka Panda around a table and a pitcher, checked with coal.

Run: ``python examples/manipulator/panda_whole_body.py [--output-dir DIR]``. What to look at: the printed
table — the end effector goes from one side of the pitcher to the other while *every link* keeps its
distance (the clearance column is the smallest link-capsule clearance, never below ``safety_distance``
= 1 cm); the joint columns stay inside the Panda's limits. The exact check at the end measures the
robot's own collision meshes (convex hulls, coal) against the obstacles at every waypoint. The PNG
(``example_panda_whole_body.png``) shows the link capsules at five waypoints and the end-effector path.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from pfield import RobotModel
from pfield.demo.whole_body import PANDA_GOAL, PANDA_OBSTACLES, plan_panda_demo
from pfield.robot.collision import CollisionChecker
from pfield.viz import save_arm_plot


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--output-dir", type=Path, default=Path("demo_output") / "examples")
    args = parser.parse_args()
    robot = RobotModel.builtin("panda")
    path, start = plan_panda_demo(robot)
    assert path.joint_positions is not None
    print(f"joints: {', '.join(robot.joint_names)}; start (IK) {np.round(start, 3).tolist()}")
    print(f"{'t (s)':>6} {'x':>7} {'y':>7} {'z':>7} {'clearance':>10}  joint angles (rad)")
    for i in np.linspace(0, len(path) - 1, 8).round().astype(int):
        x, y, z = path.positions[i]
        print(f"{path.times[i]:6.2f} {x:7.3f} {y:7.3f} {z:7.3f} {path.clearances[i]:10.3f}  "
              f"{np.round(path.joint_positions[i], 2).tolist()}")
    error = np.linalg.norm(path.positions[-1] - PANDA_GOAL.position)
    print(f"success={path.success} {path.failure_reason} after {path.iterations} steps, final error {error:.4f} m")
    checker = CollisionChecker(robot, PANDA_OBSTACLES)
    exact = min(checker.distances(q)[0] for q in path.joint_positions)
    print(f"exact minimum distance of the robot's meshes to the obstacles along the plan: {exact:.4f} m")
    args.output_dir.mkdir(parents=True, exist_ok=True)
    target = save_arm_plot(path, robot, PANDA_OBSTACLES, args.output_dir / "example_panda_whole_body.png",
                           "Panda whole-body plan around a pitcher")
    print(f"wrote {target}")


if __name__ == "__main__":
    main()
