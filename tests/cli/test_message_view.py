"""``--field``, ``--no-arr`` and the outcome line of ``topic echo`` / ``service call`` (no server needed)."""

from __future__ import annotations

import json

import pytest
import yaml

from pfield.cli._message_view import MessageView, format_yaml, outcome_line
from pfield.errors import InvalidInput

PLAN = {"success": False,
        "end_effector_path": {"header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": "world"},
                              "poses": [{"header": {}, "pose": {"position": {"x": 0.1, "y": 0.2, "z": 0.3}}}] * 3},
        "joint_trajectory": {"header": {}, "joint_names": ["j1", "j2"], "points": []},
        "end_effector_velocity_trajectory": [{}] * 3,
        "error_message": "stagnation: no progress"}
VIEW = MessageView("potential_fields_interfaces/srv/PlanPath_Response")


def test_no_arr_summarises_every_array_in_ros2_words() -> None:
    shown = VIEW.show(PLAN, no_arr=True)
    assert shown["end_effector_path"]["poses"] == "<sequence type: geometry_msgs/msg/PoseStamped, length: 3>"
    assert shown["joint_trajectory"]["joint_names"] == "<sequence type: string, length: 2>"
    assert shown["end_effector_velocity_trajectory"] == \
        "<sequence type: geometry_msgs/msg/TwistStamped, length: 3>"
    assert shown["success"] is False and shown["error_message"] == "stagnation: no progress"
    odometry = MessageView("nav_msgs/msg/Odometry").show({"pose": {"covariance": [0.0] * 36}}, no_arr=True)
    assert odometry == {"pose": {"covariance": "<array type: double[36]>"}}
    point = MessageView("trajectory_msgs/msg/JointTrajectoryPoint").show({"positions": [1.0]}, no_arr=True)
    assert point == {"positions": "<sequence type: double, length: 1>"}


def test_field_selects_a_dotted_path_and_indexes_arrays() -> None:
    assert VIEW.show(PLAN, "success") is False
    assert VIEW.show(PLAN, "end_effector_path.poses.2.pose.position") == {"x": 0.1, "y": 0.2, "z": 0.3}
    assert VIEW.show(PLAN, "end_effector_path.poses", no_arr=True) == \
        "<sequence type: geometry_msgs/msg/PoseStamped, length: 3>"
    assert format_yaml(VIEW.show(PLAN, "error_message")) == "stagnation: no progress"
    assert format_yaml(VIEW.show(PLAN, "success")) == "false"


@pytest.mark.parametrize(("path", "says"), [
    ("sucess", "known: success, end_effector_path"),
    ("end_effector_path.pose", "known: header, poses"),
    ("end_effector_path.poses.7", "give an index 0..2"),
    ("success.x", "has no fields"),
])
def test_field_refuses_unknown_parts_naming_what_is_there(path: str, says: str) -> None:
    with pytest.raises(InvalidInput, match=says) as info:
        VIEW.show(PLAN, path)
    assert info.value.field == "--field"


def test_outcome_line() -> None:
    assert outcome_line(PLAN) == "success: false (error_message: stagnation: no progress)"
    assert outcome_line({"success": True, "error_message": ""}) == "success: true"
    assert outcome_line({"success": True, "message": "removed 2"}) == "success: true (message: removed 2)"
    assert outcome_line({"autonomy_vector": {}}) is None


def test_long_strings_stay_on_one_line() -> None:
    text = format_yaml({"error_message": "x " * 100})
    assert len(text.splitlines()) == 1


def test_an_integer_that_stands_for_a_constant_shows_its_name_and_stays_the_number() -> None:
    """Issue 33 item 1: FindValidPose's ``state: 1`` said nothing to a user who expects INSCRIBED."""
    view = MessageView("potential_fields_interfaces/srv/FindValidPose_Response")
    response = {"state": 1, "cost": 5, "pose": {"header": {"frame_id": "map"}}}
    text = format_yaml(view.show(response))
    assert text.splitlines()[0] == "state: 1  # INSCRIBED" and "cost: 5\n" in text
    assert yaml.safe_load(text) == response  # a YAML reader sees the number
    assert format_yaml(view.show(response, "state")) == "1  # INSCRIBED"
    assert view.show(response, "state") == 1 and json.dumps(view.show(response)["state"]) == "1"
    assert format_yaml(view.show({"state": 9}, "state")) == "9"  # no such constant: the number alone
    flags = MessageView("potential_fields_interfaces/srv/ComputeAssistance_Response")
    assert format_yaml(flags.show({"flags": 6}, "flags")) == "6  # FLAG_NEAR_OBSTACLE|FLAG_AT_GOAL"
    assert format_yaml(flags.show({"flags": 4096}, "flags")) == "4096"
    # Marker's id, type and action are all int32: nothing says which field ARROW, CUBE … belong to
    markers = MessageView("visualization_msgs/msg/MarkerArray").show({"markers": [{"id": 1, "type": 2}]})
    assert format_yaml(markers) == "markers:\n- id: 1\n  type: 2"
