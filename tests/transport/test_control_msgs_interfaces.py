"""The built ``control_msgs`` subset (ros/control_msgs, ``make ros2-interfaces``) equals its definition files:
every field's name and type and every constant of FollowJointTrajectory's goal, result and feedback, of the
tolerance messages and of JointJog, read from the generated Python classes; JointJog's type hash is the one a
Jazzy control_msgs publisher announces; and pfield's :class:`TrajectoryErrorCode` equals the Result's constants."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from ros2_helpers.support import missing

from pfield.interfaces._idl import interface_file, parse_definition

pytestmark = pytest.mark.ros2

PACKAGE = Path(__file__).resolve().parents[2] / "ros" / "control_msgs"
_IDL_TYPES = {"float64": "double", "float32": "float", "byte": "octet", "char": "uint8"}


def _generated_type(ros_type: str) -> str:
    """A .msg field type as rosidl's ``get_fields_and_field_types()`` writes it."""
    base, is_sequence = (ros_type[:-2], True) if ros_type.endswith("[]") else (ros_type, False)
    base = _IDL_TYPES.get(base, base)
    return f"sequence<{base}>" if is_sequence else base


def _sections(path: Path) -> list[str]:
    text, sections, current = path.read_text(), [], []
    for line in text.splitlines():
        if line.strip() == "---":
            sections.append("\n".join(current))
            current = []
        else:
            current.append(line)
    return [*sections, "\n".join(current)]


def _generated(name: str) -> object:
    try:
        import control_msgs.action
        import control_msgs.msg
    except ImportError:
        missing("control_msgs is not built: run `make ros2-interfaces`")
    module = control_msgs.action if name == "FollowJointTrajectory" else control_msgs.msg
    return getattr(module, name)


def _check(text: str, generated: type) -> None:
    definition = parse_definition(text, "control_msgs")
    expected = {field.name: _generated_type(field.type) for field in definition.fields}
    assert generated.get_fields_and_field_types() == expected  # type: ignore[attr-defined]
    for constant in definition.constants:
        assert getattr(generated, constant.name) == constant.value, constant.name
    assert len(definition.fields) > 0


@pytest.mark.parametrize("name", ["JointTolerance", "JointComponentTolerance", "JointJog"])
def test_messages_equal_their_files(name: str) -> None:
    _check((PACKAGE / "msg" / f"{name}.msg").read_text(), _generated(name))  # type: ignore[arg-type]


JOINT_JOG_HASH = "RIHS01_ba249455a20f70168a1acb7bf43b776b72ff1f7eb5fc4cfea443f749e963c6e7"
"""control_msgs/msg/JointJog's type hash as rosidl's C generator of an Iron/Jazzy-era build wrote it into another
project's generated ``control_msgs__msg__JointJog__TYPE_HASH`` (found in published generated headers, not computed
from this build): a subscription matches a publisher only when the hashes agree."""


def test_joint_jog_has_the_distributions_type_hash() -> None:
    _generated("JointJog")
    built = interface_file("control_msgs/msg/JointJog")
    assert built is not None and built.parent.parent.parent.name == "share"  # the installed one, not ros/
    description = json.loads(built.with_suffix(".json").read_text())
    hashes = {entry["type_name"]: entry["hash_string"] for entry in description["type_hashes"]}
    assert hashes["control_msgs/msg/JointJog"] == JOINT_JOG_HASH


def test_follow_joint_trajectory_equals_its_file() -> None:
    action = _generated("FollowJointTrajectory")
    goal, result, feedback = _sections(PACKAGE / "action" / "FollowJointTrajectory.action")
    _check(goal, action.Goal)  # type: ignore[attr-defined]
    _check(result, action.Result)  # type: ignore[attr-defined]
    _check(feedback, action.Feedback)  # type: ignore[attr-defined]
    # the fields a joint_trajectory_controller reads, spelled out (Jazzy: no feedback index fields)
    assert action.Goal.get_fields_and_field_types()["trajectory"] == "trajectory_msgs/JointTrajectory"  # type: ignore[attr-defined]
    assert action.Goal.get_fields_and_field_types()["goal_time_tolerance"] == "builtin_interfaces/Duration"  # type: ignore[attr-defined]
    assert "index" not in action.Feedback.get_fields_and_field_types()  # type: ignore[attr-defined]


def test_result_codes_and_pfield_enum() -> None:
    from pfield.transport.trajectory_client import TrajectoryErrorCode

    result = _generated("FollowJointTrajectory").Result  # type: ignore[attr-defined]
    expected = {"SUCCESSFUL": 0, "INVALID_GOAL": -1, "INVALID_JOINTS": -2, "OLD_HEADER_TIMESTAMP": -3,
                "PATH_TOLERANCE_VIOLATED": -4, "GOAL_TOLERANCE_VIOLATED": -5}
    assert {name: getattr(result, name) for name in expected} == expected
    assert {member.name: member.value for member in TrajectoryErrorCode} == expected
    assert _generated("JointComponentTolerance").ROTATION == 5  # type: ignore[attr-defined]


def test_notice_names_the_source_commit() -> None:
    notice = (PACKAGE / "NOTICE.md").read_text()
    assert "f901df2662f22a39a06aa04a85a34602c47e3cc0" in notice
    assert "BSD" in (PACKAGE / "LICENSE").read_text() or "Redistribution" in (PACKAGE / "LICENSE").read_text()
