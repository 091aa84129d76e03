"""Client of the rclpy test of ``/pfield/compute_assistance`` (``tests/node/test_assistance_node.py``).

Publishes a sphere and a goal to the real ``pfield ros2 node``, sets an explicit obstacle velocity, calls the
service (and once with bad input), and writes what it saw to ``$ROS2_TEST_OUT/results.json``.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "transport"))  # ros2_helpers

from ros2_helpers.client import BlockingClient
from ros2_helpers.scenario import OBSTACLES, run_phases

SERVICE = ("/pfield/compute_assistance", "potential_fields_interfaces/srv/ComputeAssistance")
BALL = {"frame_id": "ball", "type": "Sphere", "group": "Static", "radius": 0.05,
        "pose": {"position": {"x": 0.5, "y": 0.0, "z": 0.3}}}
REQUEST = {"query_pose": {"header": {"frame_id": "world"}, "pose": {"position": {"x": 0.4, "y": 0.0, "z": 0.3}}},
           "user_command": {"twist": {"linear": {"x": 0.02}}}, "arbitration": "linear"}


def until(client: BlockingClient, check: Any, timeout: float = 30.0) -> dict[str, Any]:
    deadline = time.monotonic() + timeout
    while True:
        answer = client.call(*SERVICE, REQUEST)
        if check(answer) or time.monotonic() > deadline:
            return answer
        time.sleep(0.1)


def assistance(client: BlockingClient, results: dict[str, Any]) -> None:
    client.publish("/pfield/obstacles", OBSTACLES, {"header": {"frame_id": "world"}, "obstacles": [BALL]})
    client.publish("/pfield/planning_goal_pose", "geometry_msgs/msg/PoseStamped",
                   {"header": {"frame_id": "world"}, "pose": {"position": {"x": 0.8, "y": 0.0, "z": 0.3}}})
    results["static"] = until(client, lambda a: a["nearest_obstacle_id"] == "ball" and not a["flags"] & 128)
    client.publish("/pfield/obstacle_velocities", "potential_fields_interfaces/msg/ObstacleVelocityArray",
                   {"velocities": [{"frame_id": "ball", "linear": {"x": -0.03}}]})
    results["moving"] = until(client, lambda a: a["time_to_collision"] < 2.0)
    results["refused"] = client.call(*SERVICE, REQUEST | {"arbitration": "boss"})
    samples = []
    for _ in range(200):
        start = time.perf_counter()
        client.call(*SERVICE, REQUEST)
        samples.append(time.perf_counter() - start)
    results["round_trip_p50_ms"] = sorted(samples)[len(samples) // 2] * 1e3


if __name__ == "__main__":
    run_phases([assistance])
