"""Issue 31's reproductions F1 and F2 against a real HTTP server: the node's commands are finite and within the
limits (:mod:`pfield.safety`), and absurd obstacle speeds are refused naming the field, changing nothing."""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import httpx
import numpy as np
import pytest

from pfield.interfaces import message_from_yaml
from pfield.interfaces import potential_fields_interfaces as pfi
from pfield.interfaces.geometry_msgs import PoseStamped
from pfield.node._base import Bus
from pfield.node.manager import ManagerNode
from pfield.robot import RobotModel
from pfield.transport.http import ServerThread, create_app

BALL = "{obstacles: [{frame_id: 'ball', type: 'Sphere', group: 'Dynamic', radius: 0.05, " \
       "pose: {position: {x: 0.5, y: 0.0, z: 0.3}}}]}"
Q = [0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0]
"""The joint angles of the reproductions (the xArm7's seed start)."""
MAX_LINEAR, MAX_ANGULAR = 0.05, 0.4  # the node's defaults (FieldConfig)


@pytest.fixture(scope="module")
def served() -> Iterator[tuple[ManagerNode, str, RobotModel]]:
    robot = RobotModel.builtin("xarm7")
    manager = ManagerNode(Bus(), robot)
    manager.on_obstacles(message_from_yaml(pfi.ObstacleArray, BALL))
    manager.on_goal(message_from_yaml(PoseStamped, "{pose: {position: {x: 0.8, y: 0.0, z: 0.3}}}"))
    with ServerThread(create_app([manager])) as server:
        yield manager, server.url, robot


def assert_twist_within(twist: dict[str, Any]) -> None:
    linear = [twist["linear"][k] for k in "xyz"]
    angular = [twist["angular"][k] for k in "xyz"]
    assert all(map(math.isfinite, linear + angular)), twist
    assert math.hypot(*linear) <= MAX_LINEAR * (1 + 1e-9) and math.hypot(*angular) <= MAX_ANGULAR * (1 + 1e-9), twist


def test_f1_whole_body_assistance_with_an_operator_command_of_1e308(served: tuple[ManagerNode, str, Any]) -> None:
    """F1: every ``joint_velocities`` entry and the blend were NaN, no flag set."""
    _, url, robot = served
    request = {"joint_angles": Q, "planning_method": "whole_body", "user_command": {"twist": {"linear": {"x": 1e308}}}}
    answer = httpx.post(f"{url}/srv/pfield/compute_assistance", json=request)
    assert answer.status_code == 200, answer.text
    body = answer.json()
    velocities = np.array(body["joint_velocities"])
    assert np.isfinite(velocities).all() and (np.abs(velocities) <= robot.velocity_limits).all(), velocities
    assert_twist_within(body["blended_command"]["twist"])
    assert_twist_within(body["autonomy_vector"]["twist"])
    assert body["flags"] & pfi.ComputeAssistance_Response.FLAG_VELOCITY_LIMITED
    assert "velocity limited" in body["message"]


@pytest.mark.parametrize("velocity", [(-1.7e308, -1.7e308, 0.0), (-1e6, 0.0, 0.0)])
def test_f1_f2_absurd_obstacle_speeds_are_refused_and_the_assistance_stays_bounded(
        served: tuple[ManagerNode, str, Any], velocity: tuple[float, float, float]) -> None:
    """F1: (−1.7e308, −1.7e308, 0) made the next blend NaN; F2: −1e6 m/s made it −500 000 m/s."""
    manager, url, _ = served
    before = manager.state
    message = {"velocities": [{"frame_id": "ball", "linear": dict(zip("xyz", velocity, strict=True))}]}
    refused = httpx.post(f"{url}/topic/pfield/obstacle_velocities", json=message)
    assert refused.status_code == 400, refused.text
    assert refused.json()["field"] == "velocities[0].linear" and "10 m/s" in refused.json()["error"]
    assert manager.state is before  # nothing changed
    query = {"query_pose": {"pose": {"position": {"x": 0.4, "y": 0.0, "z": 0.3}}},
             "user_command": {"twist": {"linear": {"x": 0.02}}}}
    answer = httpx.post(f"{url}/srv/pfield/compute_assistance", json=query)
    assert answer.status_code == 200
    assert_twist_within(answer.json()["blended_command"]["twist"])


@pytest.mark.parametrize("previous", [10.0, 1e38, -1e38])
def test_f2_whole_body_autonomy_with_previous_velocities_beyond_the_limits(served: tuple[ManagerNode, str, Any],
                                                                           previous: float) -> None:
    """F2: ``prev_joint_velocities`` of 10 rad/s answered 5.35 m/s (17 rad/s in the joints); 1e38: 3.7e37 m/s."""
    _, url, _ = served
    request = {"joint_angles": Q, "planning_method": "whole_body", "prev_joint_velocities": [previous] * 7,
               "delta_time": 0.02}
    answer = httpx.post(f"{url}/srv/pfield/compute_autonomy_vector", json=request)
    assert answer.status_code == 200, answer.text
    assert_twist_within(answer.json()["autonomy_vector"]["twist"])
