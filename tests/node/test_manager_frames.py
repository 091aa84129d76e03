"""``/pfield_manager`` static transforms: messages in a configured frame are moved into the fixed frame."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from pfield.errors import InvalidInput, UnknownFrame
from pfield.interfaces import message_from_yaml
from pfield.interfaces import potential_fields_interfaces as pfi
from pfield.interfaces.geometry_msgs import PoseStamped
from pfield.node._base import Bus
from pfield.node._frames import parse_transform_option
from pfield.node.manager import ManagerNode, ManagerParameters

S = math.sqrt(0.5)
# camera sits at (1, 2, 3) in world, turned +90° about z: its x axis is world's y axis.
CAMERA = {"translation": [1.0, 2.0, 3.0], "rotation": [0.0, 0.0, S, S]}
BALL = "{frame_id: 'ball', type: 'Sphere', group: 'Static', pose: {position: {x: 0.4, y: 0.0, z: 0.1}, " \
       "orientation: {w: 1.0}}, radius: 0.1}"


@pytest.fixture(scope="module")
def robot() -> Any:
    from pfield.robot import RobotModel

    return RobotModel.builtin("xarm7")


@pytest.fixture
def node(robot: Any) -> ManagerNode:
    return ManagerNode(Bus(), robot, parameters=ManagerParameters(static_transforms={"camera": CAMERA}))


def stamped(frame: str, x: float, y: float, z: float) -> PoseStamped:
    return message_from_yaml(PoseStamped, f"{{header: {{frame_id: '{frame}'}}, pose: {{position: "
                                          f"{{x: {x}, y: {y}, z: {z}}}, orientation: {{w: 1.0}}}}}}")


def test_obstacle_in_camera_frame_lands_at_transformed_world_pose(node: ManagerNode) -> None:
    node.on_obstacles(message_from_yaml(pfi.ObstacleArray, f"{{header: {{frame_id: camera}}, obstacles: [{BALL}]}}"))
    ball = node.obstacles()[0]
    # R_z(90°) (0.4, 0, 0.1) + (1, 2, 3) = (1.0, 2.4, 3.1); orientation composed: identity -> R_z(90°)
    np.testing.assert_allclose(ball.pose.position, [1.0, 2.4, 3.1], atol=1e-12)
    np.testing.assert_allclose(ball.pose.orientation, [0.0, 0.0, S, S], atol=1e-12)
    assert ball.shape.radius == pytest.approx(0.1)


def test_goal_and_query_in_camera_frame_are_transformed(node: ManagerNode) -> None:
    node.on_goal(stamped("camera", 0.1, 0.2, 0.3))
    assert node.goal is not None
    # R_z(90°) (0.1, 0.2, 0.3) = (-0.2, 0.1, 0.3); plus (1, 2, 3)
    np.testing.assert_allclose(node.goal.position, [0.8, 2.1, 3.3], atol=1e-12)
    np.testing.assert_allclose(node.goal.orientation, [0.0, 0.0, S, S], atol=1e-12)
    in_camera = node.compute_autonomy_vector(pfi.ComputeAutonomyVector_Request(query_pose=stamped("camera", 0, 0, 0)))
    world_query = message_from_yaml(PoseStamped, "{header: {frame_id: world}, pose: {position: {x: 1, y: 2, z: 3}, "
                                                 f"orientation: {{z: {S}, w: {S}}}}}}}")
    in_world = node.compute_autonomy_vector(pfi.ComputeAutonomyVector_Request(query_pose=world_query))
    assert in_camera.autonomy_vector.header.frame_id == "world"
    linear = in_camera.autonomy_vector.twist.linear
    expected = in_world.autonomy_vector.twist.linear
    assert (linear.x, linear.y, linear.z) == pytest.approx((expected.x, expected.y, expected.z), abs=1e-12)
    assert math.hypot(linear.x, linear.y, linear.z) > 0  # the goal is 0.36 m away: the field pulls
    node.on_query_pose(stamped("camera", 0, 0, 0))
    assert node.bus.latest("/pfield/autonomy_vector").twist.linear.x == pytest.approx(linear.x)


def test_parameter_round_trip_and_runtime_change(node: ManagerNode) -> None:
    got = node.get_parameters()["static_transforms"]
    assert got == {"camera": {"translation": [1.0, 2.0, 3.0], "rotation": [0.0, 0.0, S, S]}}
    node.set_parameters({"static_transforms": {"lidar": {"translation": [0, 0, 1]}}})
    assert node.get_parameters()["static_transforms"] == {"lidar": {"translation": [0.0, 0.0, 1.0],
                                                                    "rotation": [0.0, 0.0, 0.0, 1.0]}}
    node.on_goal(stamped("lidar", 0.5, 0, 0))
    assert node.goal is not None
    np.testing.assert_allclose(node.goal.position, [0.5, 0.0, 1.0])
    with pytest.raises(UnknownFrame):
        node.on_goal(stamped("camera", 0, 0, 0))


@pytest.mark.parametrize(("value", "field"), [
    ({"camera": {"translation": [0, 0, float("nan")]}}, "static_transforms.camera.translation"),
    ({"camera": {"translation": [0, 0, 0], "rotation": [0, 0, 0, 0]}}, "static_transforms.camera.rotation"),
    ({"camera": {"translation": [0, 0, 0], "rotation": [0, 0, float("inf"), 1]}}, "static_transforms.camera.rotation"),
    ({"camera": {"translation": [0, 0]}}, "static_transforms.camera.translation"),
    ({"camera": {"translation": [0, 0, 0], "rotation": [0, 0, 1]}}, "static_transforms.camera.rotation"),
    ({"camera": {"translation": ["a", 0, 0]}}, "static_transforms.camera.translation"),
    ({"camera": {"position": [0, 0, 0]}}, "static_transforms.camera"),
    ({"camera": [1, 2, 3]}, "static_transforms.camera"),
    ({"world": {"translation": [0, 0, 0]}}, "static_transforms.world"),
    ([1, 2, 3], "static_transforms"),
])
def test_bad_transform_parameter_is_refused_and_changes_nothing(node: ManagerNode, value: Any, field: str) -> None:
    before = node.get_parameters()
    with pytest.raises(InvalidInput) as info:
        node.set_parameters({"static_transforms": value, "attractive_gain": 7.0})
    assert info.value.field == field
    assert node.get_parameters() == before


def test_unconfigured_frame_is_still_rejected(node: ManagerNode) -> None:
    node.on_obstacles(message_from_yaml(pfi.ObstacleArray, f"{{header: {{frame_id: ''}}, obstacles: [{BALL}]}}"))
    np.testing.assert_allclose(node.obstacles()[0].pose.position, [0.4, 0.0, 0.1])  # empty frame = fixed frame
    array = message_from_yaml(pfi.ObstacleArray, f"{{header: {{frame_id: base}}, obstacles: [{BALL}]}}")
    for call, field in ((lambda: node.on_obstacles(array), "header.frame_id"),
                        (lambda: node.on_goal(stamped("base", 0, 0, 0)), "header.frame_id"),
                        (lambda: node.compute_autonomy_vector(pfi.ComputeAutonomyVector_Request(
                            query_pose=stamped("base", 0, 0, 0))), "query_pose.header.frame_id")):
        with pytest.raises(UnknownFrame) as info:
            call()
        assert info.value.field == field and "static_transforms" in info.value.reason
        assert "camera" in info.value.reason
    np.testing.assert_allclose(node.obstacles()[0].pose.position, [0.4, 0.0, 0.1])
    assert node.goal is None


def test_command_line_form() -> None:
    assert parse_transform_option("camera=1,2,3") == ("camera", {"translation": [1.0, 2.0, 3.0],
                                                                 "rotation": [0.0, 0.0, 0.0, 1.0]})
    assert parse_transform_option("cam=1,2,3,0,0,1,1")[1]["rotation"] == [0.0, 0.0, 1.0, 1.0]
    for bad in ("camera", "=1,2,3", "camera=1,2", "camera=1,2,3,0,0,0", "camera=a,b,c", "camera=1,2,3,0,0,0,0",
                "camera=1,2,nan"):
        with pytest.raises(InvalidInput) as info:
            parse_transform_option(bad)
        assert info.value.field == "--static-transform"
