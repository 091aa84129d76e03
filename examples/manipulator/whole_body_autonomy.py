"""The whole-body autonomy vector in a shared-control loop (xArm7, the seed's six obstacles).

Run: ``python examples/manipulator/whole_body_autonomy.py [--steps N]``. What to look at: at every cycle the
robot reports its joint angles; ``whole_body_autonomy`` answers with the joint velocities the whole-body
field recommends and the end-effector twist they produce (the ComputeAutonomyVector answer). The loop
integrates those joint velocities, passing the previous ones back so the joint acceleration limit applies
(|Δq̇| ≤ max_angular_acceleration · dt per joint, printed as "max |Δq̇|/dt"). The end effector converges on
the seed's goal while the smallest link clearance stays above the 1 cm safety distance. A query pose that
disagrees with the joints (here: the task-space start pose fed at cycle 0) is flagged.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from pfield import FieldConfig, PotentialField, RobotModel
from pfield.planning.scenes import SEED_GOAL, seed_obstacles
from pfield.shared_control.autonomy import whole_body_autonomy
from pfield.spatial import Pose


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--steps", type=int, default=600)
    args = parser.parse_args()
    robot = RobotModel.builtin("xarm7")
    config = FieldConfig()
    with tempfile.TemporaryDirectory() as directory:
        field = PotentialField(config, SEED_GOAL, seed_obstacles(Path(directory)))
        q, previous, dt = np.array([0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0]), np.zeros(7), 0.02
        wrong = Pose((0.3, 0.1, 0.35), (0.707, 0.0, 0.707, 0.0))
        print(f"{'cycle':>5} {'x':>7} {'y':>7} {'z':>7} {'|v| (m/s)':>10} {'clearance':>10} {'max |Δq̇|/dt':>13}")
        for cycle in range(args.steps):
            result = whole_body_autonomy(field, robot, q, previous, dt, query_pose=wrong if cycle == 0 else None)
            if cycle == 0:
                print(f"query pose flagged as disagreeing with the joints: {result.pose_mismatch}")
            change = float(np.max(np.abs(result.joint_velocities - previous))) / dt
            if cycle % (args.steps // 10 or 1) == 0:
                x, y, z = result.pose.position
                print(f"{cycle:5d} {x:7.3f} {y:7.3f} {z:7.3f} {np.linalg.norm(result.twist.linear):10.4f} "
                      f"{result.clearance:10.3f} {change:13.3f}")
            previous = result.joint_velocities
            q = np.clip(q + previous * dt, robot.lower_limits, robot.upper_limits)
        error = np.linalg.norm(robot.forward_kinematics(q).position - SEED_GOAL.position)
        print(f"after {args.steps} cycles: {error * 100:.2f} cm from the goal "
              f"(acceleration limit {config.max_angular_acceleration} rad/s²)")


if __name__ == "__main__":
    main()
