"""Client of the rclpy test of ``pfield ros2 node --robot ur5.urdf …`` (``tests/cli/test_robot_flags.py``).

Asks the real node for a whole-body plan of the UR5 (six joint angles in, its joint trajectory out) and writes
the answer to ``$ROS2_TEST_OUT/results.json``.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "transport"))  # ros2_helpers

from ros2_helpers.client import BlockingClient
from ros2_helpers.scenario import run_phases

START = [0.0, -1.2, 1.6, -1.97, -1.57, 0.0]
"""rad: the UR5's start (the issue's example), its tool 1.165 m high, pointing down."""
REQUEST = {"goal": {"position": {"x": 0.35, "y": 0.55, "z": 1.165}, "orientation": {"x": 1.0, "w": 0.0}},
           "starting_joint_angles": START, "delta_time": 0.02, "goal_tolerance": 0.01, "max_iterations": 5000,
           "planning_method": "whole_body"}


def plan(client: BlockingClient, results: dict[str, Any]) -> None:
    answer = client.call("/pfield/plan_path", "potential_fields_interfaces/srv/PlanPath", REQUEST, timeout=300)
    trajectory = answer["joint_trajectory"]
    results["plan"] = {"success": answer["success"], "error_message": answer["error_message"],
                       "joint_names": trajectory["joint_names"],
                       "first": trajectory["points"][0]["positions"] if trajectory["points"] else []}


if __name__ == "__main__":
    run_phases([plan])
