"""ROS's YAML flow rules for message arguments: defaults, unknown fields, ints for floats, bad YAML."""

from __future__ import annotations

import pytest

import pfield.interfaces.all  # noqa: F401
from pfield.errors import InvalidInput
from pfield.interfaces import lookup_service, lookup_type, message_from_yaml, message_to_data, message_to_yaml
from pfield.interfaces.potential_fields_interfaces import ObstacleArray, PlanPath_Request

SPHERE = """{
header: {frame_id: 'world'},
obstacles: [{
frame_id: 'ball', type: 'Sphere', group: 'Static',
pose: {position: {x: 0.4, y: 0.0, z: 0.1}, orientation: {w: 1.0}},
radius: 0.1
}]
}"""


def test_seed_obstacle_fills_ros_defaults() -> None:
    message = message_from_yaml(lookup_type("potential_fields_interfaces/msg/ObstacleArray"), SPHERE)
    assert isinstance(message, ObstacleArray)
    (ball,) = message.obstacles
    assert (ball.frame_id, ball.type, ball.group, ball.radius) == ("ball", "Sphere", "Static", 0.1)
    assert (ball.pose.position.x, ball.pose.orientation.x, ball.pose.orientation.w) == (0.4, 0.0, 1.0)
    assert (ball.height, ball.mesh_resource, ball.scale_x) == (0.0, "", 0.0)
    assert message.header.stamp.sec == 0


def test_integers_are_accepted_for_floats_and_json_works() -> None:
    request = message_from_yaml(PlanPath_Request, '{"goal": {"position": {"x": 1}}, "max_iterations": 7}')
    assert request.goal.position.x == 1.0 and isinstance(request.goal.position.x, float)
    assert request.max_iterations == 7
    assert message_from_yaml(PlanPath_Request, "") == PlanPath_Request()


@pytest.mark.parametrize(
    ("text", "field"),
    [
        ("{obstacles: [{radiuss: 0.1}]}", "obstacles[0].radiuss"),
        ("{header: {frame: 'world'}}", "header.frame"),
        ("{obstacles: [{radius: 'big'}]}", "obstacles[0].radius"),
        ("{obstacles: {radius: 0.1}}", "obstacles"),
        ("{obstacles: [{frame_id: 'a'}, 3]}", "obstacles[1]"),
        ("[1, 2]", "message"),
        ("{header: {frame_id: 'world'}", "yaml"),
    ],
)
def test_bad_input_names_the_field(text: str, field: str) -> None:
    with pytest.raises(InvalidInput) as info:
        message_from_yaml(ObstacleArray, text)
    assert info.value.field == field


def test_int_range_is_checked() -> None:
    with pytest.raises(InvalidInput) as info:
        message_from_yaml(PlanPath_Request, "{max_iterations: 3000000000}")
    assert info.value.field == "max_iterations"


def test_round_trip_through_yaml_text() -> None:
    message = message_from_yaml(ObstacleArray, SPHERE)
    assert message_from_yaml(ObstacleArray, message_to_yaml(message)) == message
    assert message_to_data(message)["obstacles"][0]["pose"]["orientation"] == {"x": 0.0, "y": 0.0, "z": 0.0,
                                                                                "w": 1.0}


def test_unknown_types_are_rejected() -> None:
    with pytest.raises(InvalidInput, match="unknown message type"):
        lookup_type("potential_fields_interfaces/msg/Nope")
    with pytest.raises(InvalidInput, match="unknown service type"):
        lookup_service("potential_fields_interfaces/srv/Nope")
    assert lookup_service("potential_fields_interfaces/PlanPath").request is PlanPath_Request
