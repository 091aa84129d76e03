"""``/pfield/compute_assistance`` on the manager node, directly and over a real HTTP server; obstacle velocities."""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from typing import Any

import httpx
import pytest

from pfield import Obstacle, Pose, Sphere
from pfield.errors import InvalidInput, UnknownFrame
from pfield.interfaces import message_from_yaml
from pfield.interfaces import potential_fields_interfaces as pfi
from pfield.interfaces.geometry_msgs import PoseStamped
from pfield.node._base import Bus
from pfield.node._manager_state import Held
from pfield.node.manager import ManagerNode
from pfield.node.obstacle_motion import MAX_OBSTACLE_JUMP, MIN_UPDATE_INTERVAL, VELOCITY_SMOOTHING, updated_held
from pfield.transport.http import ServerThread, create_app

BALL = "{frame_id: 'ball', type: 'Sphere', group: 'Dynamic', pose: {position: {x: %s, y: 0.0, z: 0.3}}, radius: 0.05}"
QUERY = {"query_pose": {"header": {"frame_id": "world"}, "pose": {"position": {"x": 0.4, "y": 0.0, "z": 0.3}}},
         "user_command": {"twist": {"linear": {"x": 0.02}}}}


@pytest.fixture(scope="module")
def robot() -> Any:
    from pfield.robot import RobotModel

    return RobotModel.builtin("xarm7")


def publish_ball(node: ManagerNode, x: float = 0.5) -> None:
    node.on_obstacles(message_from_yaml(pfi.ObstacleArray, f"{{obstacles: [{BALL % x}]}}"))


@pytest.fixture
def node(robot: Any) -> ManagerNode:
    manager = ManagerNode(Bus(), robot)
    publish_ball(manager)
    manager.on_goal(message_from_yaml(PoseStamped, "{pose: {position: {x: 0.8, y: 0.0, z: 0.3}}}"))
    return manager


def request(**changes: Any) -> pfi.ComputeAssistance_Request:
    return pfi.ComputeAssistance_Request.model_validate(QUERY | changes)


def test_task_space_answer_has_the_exact_geometry(node: ManagerNode) -> None:
    answer = node.compute_assistance(request())
    assert answer.nearest_obstacle_id == "ball"
    assert answer.nearest_distance == pytest.approx(0.05, abs=1e-7)
    assert (answer.nearest_normal.x, answer.nearest_normal.y, answer.nearest_normal.z) == pytest.approx((-1, 0, 0))
    assert (answer.obstacle_point.x, answer.robot_point.x) == pytest.approx((0.45, 0.4))
    assert answer.time_to_collision == pytest.approx(2.5, rel=1e-6)
    assert answer.alpha == pytest.approx(0.05 / 0.09, rel=1e-6)
    assert answer.flags & pfi.ComputeAssistance_Response.FLAG_NEAR_OBSTACLE
    assert answer.blended_command.header.frame_id == "world" and answer.joint_velocities == []


def test_whole_body_answer(node: ManagerNode) -> None:
    answer = node.compute_assistance(request(planning_method="whole_body", joint_angles=[0, -0.3, 0, 0.6, 0, 0.9, 0],
                                             query_pose={}))
    assert len(answer.joint_velocities) == 7 and answer.nearest_obstacle_id == "ball"
    assert math.isfinite(answer.nearest_distance)


def test_no_goal_is_safety_only(robot: Any) -> None:
    manager = ManagerNode(Bus(), robot)
    publish_ball(manager)
    answer = manager.compute_assistance(request(arbitration="linear"))
    assert answer.flags & pfi.ComputeAssistance_Response.FLAG_NO_GOAL and answer.alpha == 0.0
    assert answer.blended_command.twist.linear.x == pytest.approx(0.02)


def test_bad_input_is_refused_and_changes_nothing(node: ManagerNode) -> None:
    before = node.state
    cases: list[tuple[dict[str, Any], str]] = [
        ({"arbitration": "boss"}, "arbitration"),
        ({"planning_method": "joint_space"}, "planning_method"),
        ({"planning_method": "whole_body", "joint_angles": [0.0, 1.0]}, "joint_angles"),
        ({"delta_time": -1.0}, "delta_time"),
        ({"user_command": {"header": {"frame_id": "mars"}}}, "user_command.header.frame_id"),
        ({"user_command": {"twist": {"linear": {"x": math.nan}}}}, "user_command.twist.linear.x"),
    ]
    for changes, field in cases:
        with pytest.raises((InvalidInput, UnknownFrame), match=field.split(".")[0]):
            node.compute_assistance(request(**changes))
    assert node.state is before


def test_velocity_filter_estimates_and_resets_on_a_jump() -> None:
    ball = Obstacle("ball", Sphere(radius=0.05), Pose(position=(0.5, 0.0, 0.3)), group="Dynamic")
    moved = Obstacle("ball", Sphere(radius=0.05), Pose(position=(0.52, 0.0, 0.3)), group="Dynamic")
    first = updated_held(None, ball, 10.0, 2.0)
    assert first.velocity == (0.0, 0.0, 0.0)
    second = updated_held(first, moved, 10.1, 2.0)
    assert second.velocity == pytest.approx((VELOCITY_SMOOTHING * 0.2, 0.0, 0.0))
    jumped = Obstacle("ball", Sphere(radius=0.05), Pose(position=(0.52 + 2 * MAX_OBSTACLE_JUMP, 0, 0.3)),
                      group="Dynamic")
    assert updated_held(second, jumped, 10.2, 2.0).velocity == (0.0, 0.0, 0.0)
    assert updated_held(second, moved, 13.0, 2.0).velocity == (0.0, 0.0, 0.0)  # older than the timeout
    assert updated_held(second, jumped, 10.1 + MIN_UPDATE_INTERVAL / 2, 2.0).velocity == (0.0, 0.0, 0.0)
    assert updated_held(second, moved, 10.1 + MIN_UPDATE_INTERVAL / 2, 2.0).velocity == second.velocity
    static = Obstacle("ball", Sphere(radius=0.05), Pose(position=(0.6, 0.0, 0.3)), group="Static")
    assert updated_held(Held(ball, 10.0), static, 10.1, 2.0).velocity == (0.0, 0.0, 0.0)


def test_node_estimates_dynamic_velocity_from_successive_poses(node: ManagerNode) -> None:
    time.sleep(2 * MIN_UPDATE_INTERVAL)  # successive updates must be further apart than this to count
    publish_ball(node, 0.49)  # the ball moves toward the end effector
    held = node.state.obstacles["ball"]
    assert held.velocity[0] < 0.0 and held.velocity[1:] == (0.0, 0.0)
    publish_ball(node, 3.0)  # a jump (even within MIN_UPDATE_INTERVAL): the estimate starts again
    assert node.state.obstacles["ball"].velocity == (0.0, 0.0, 0.0)


def test_explicit_velocities_feed_the_time_to_collision(node: ManagerNode) -> None:
    velocities = pfi.ObstacleVelocityArray.model_validate({"velocities": [{"frame_id": "ball",
                                                                           "linear": {"x": -0.03}}]})
    node.on_obstacle_velocities(velocities)
    assert node.state.obstacles["ball"].velocity == (-0.03, 0.0, 0.0)
    assert node.compute_assistance(request()).time_to_collision == pytest.approx(1.0, rel=1e-6)
    publish_ball(node, 0.5)  # a new pose keeps the explicit velocity
    assert node.state.obstacles["ball"].velocity == (-0.03, 0.0, 0.0)
    before = node.state
    for bad, field in (({"frame_id": "ghost"}, "frame_id"), ({"frame_id": "ball", "linear": {"y": math.inf}},
                                                              "linear.y")):
        with pytest.raises(InvalidInput, match=field):
            node.on_obstacle_velocities(pfi.ObstacleVelocityArray.model_validate({"velocities": [bad]}))
    assert node.state is before


def test_the_default_arbitration_is_the_assistance_arbitration_parameter(node: ManagerNode) -> None:
    """Issue 33: ComputeAssistance.srv names the parameter assistance_arbitration; it exists."""
    assert node.get_parameters()["assistance_arbitration"] == "linear"
    assert node.compute_assistance(request()).alpha > 0.0  # linear: the field shares the command near the ball
    node.set_parameters({"assistance_arbitration": "safety_only"})
    assert node.compute_assistance(request()).alpha == 0.0
    assert node.compute_assistance(request(arbitration="linear")).alpha > 0.0  # a request's own choice wins
    with pytest.raises(InvalidInput, match="assistance_arbitration"):
        node.set_parameters({"assistance_arbitration": "boss"})
    assert node.get_parameters()["assistance_arbitration"] == "safety_only"


@pytest.fixture(scope="module")
def served(robot: Any) -> Iterator[tuple[ManagerNode, str]]:
    manager = ManagerNode(Bus(), robot)
    publish_ball(manager)
    manager.on_goal(message_from_yaml(PoseStamped, "{pose: {position: {x: 0.8, y: 0.0, z: 0.3}}}"))
    with ServerThread(create_app([manager])) as server:
        yield manager, server.url


def test_http_route_answers_and_refuses(served: tuple[ManagerNode, str]) -> None:
    manager, url = served
    answer = httpx.post(f"{url}/srv/pfield/compute_assistance", json=QUERY).json()
    assert answer["nearest_obstacle_id"] == "ball" and answer["time_to_collision"] == pytest.approx(2.5, rel=1e-6)
    assert answer["nearest_distance"] == pytest.approx(0.05, abs=1e-7)
    before = manager.state
    refused = httpx.post(f"{url}/srv/pfield/compute_assistance", json=QUERY | {"arbitration": "boss"})
    assert refused.status_code == 400 and refused.json()["field"] == "arbitration"
    far = httpx.post(f"{url}/srv/pfield/compute_assistance",
                     json={"query_pose": {"pose": {"position": {"x": 0.0, "y": 1.0, "z": 0.3}}}}).json()
    assert far["time_to_collision"] == math.inf and far["speed_scale"] == 1.0
    assert manager.state is before


@pytest.mark.ros2
@pytest.mark.slow
def test_rclpy_node_answers_compute_assistance(tmp_path: Any) -> None:
    import json
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "transport"))
    from ros2_helpers.support import missing, require_netns, require_ros2_python, run_session

    require_ros2_python()
    require_netns()
    import potential_fields_interfaces.srv as built

    if not hasattr(built, "ComputeAssistance"):
        missing("the installed potential_fields_interfaces predates ComputeAssistance: run `make ros2-interfaces`")
    node = [str(Path(sys.executable).with_name("pfield")), "ros2", "node", "--robot", "xarm7"]
    client = [sys.executable, str(Path(__file__).with_name("assistance_ros2_client.py"))]
    process = run_session(node, client, tmp_path, timeout=600)
    assert process.returncode == 0, process.stderr
    results = json.loads((tmp_path / "results.json").read_text())
    assert "error" not in results, results["error"] + (tmp_path / "node.log").read_text()
    static, moving, refused = results["static"], results["moving"], results["refused"]
    assert static["nearest_obstacle_id"] == "ball"
    assert static["nearest_distance"] == pytest.approx(0.05, abs=1e-6)
    assert static["time_to_collision"] == pytest.approx(2.5, rel=1e-5)
    assert static["obstacle_point"]["x"] == pytest.approx(0.45, abs=1e-6)
    assert moving["time_to_collision"] == pytest.approx(1.0, rel=1e-5)
    assert "arbitration" in refused["message"] and refused["nearest_obstacle_id"] == ""
