"""The servo's parameters under MoveIt Servo's names: a Servo file loads unchanged; joystick mappings; bad values."""

from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import Any

import pytest
import yaml

from pfield.errors import InvalidInput
from pfield.node._base import Bus
from pfield.node.manager import ManagerNode
from pfield.node.servo_node import ServoNode, load_servo_file, servo_from_parameters
from pfield.shared_control.servo_config import ServoConfig, joy_twist, servo_config_from_mapping

SERVO_FILE = Path(__file__).with_name("data") / "servo_panda.yaml"
SHARED = {  # every parameter of the file that pfield uses, with the file's value
    "publish_period": 0.01, "command_in_type": "speed_units", "scale_linear": 0.2, "scale_rotational": 0.8,
    "command_out_type": "trajectory_msgs/JointTrajectory", "publish_joint_positions": True,
    "publish_joint_velocities": True, "publish_joint_accelerations": False, "move_group_name": "panda_arm",
    "lower_singularity_threshold": 10.0, "hard_stop_singularity_threshold": 30.0,
    "leaving_singularity_threshold_multiplier": 2.0, "joint_limit_margins": (0.12,),
    "cartesian_command_in_topic": "~/delta_twist_cmds", "joint_command_in_topic": "~/delta_joint_cmds",
    "scale_joint": 0.5, "joint_topic": "/joint_states", "status_topic": "~/status",
    "command_out_topic": "/panda_arm_controller/joint_trajectory", "check_collisions": True,
    "self_collision_proximity_threshold": 0.01, "scene_collision_proximity_threshold": 0.02,
}
IGNORED = ["check_octomap_collisions", "collision_check_rate", "is_primary_planning_scene_monitor",
           "max_expected_latency", "smoothing_filter_plugin_name", "use_smoothing"]


def _check_shared(config: ServoConfig) -> None:
    for name, value in SHARED.items():
        assert getattr(config, name) == value, name


def test_a_servo_file_loads_unchanged() -> None:
    config, ignored = load_servo_file(SERVO_FILE)
    _check_shared(config)
    assert ignored == IGNORED


@pytest.mark.parametrize("wrap", ["moveit_servo", "ros_parameters"])
def test_the_wrapped_forms_load_the_same(tmp_path: Path, wrap: str) -> None:
    """Servo's launch files load the file as ``moveit_servo``; a ROS parameters file names the node."""
    data = yaml.safe_load(SERVO_FILE.read_text())
    wrapped: dict[str, Any] = {"moveit_servo": data}
    if wrap == "ros_parameters":
        wrapped = {"servo_node": {"ros__parameters": wrapped}}
    path = tmp_path / "servo.yaml"
    path.write_text(yaml.safe_dump(wrapped))
    config, ignored = load_servo_file(path)
    _check_shared(config)
    assert ignored == sorted(f"moveit_servo.{name}" for name in IGNORED)


def test_params_section_builds_the_servo_node_and_logs_what_it_ignores(caplog: pytest.LogCaptureFixture) -> None:
    from pfield.robot import RobotModel

    manager = ManagerNode(Bus(), RobotModel.builtin("panda"))
    section = {"moveit_servo": yaml.safe_load(SERVO_FILE.read_text()) | {"my_own_setting": 3,
                                                                         "incoming_command_timout": 0.5}}
    with caplog.at_level(logging.INFO, logger="pfield.node.servo_node"):
        node = servo_from_parameters(manager, {"/servo_node": section})
    assert isinstance(node, ServoNode)
    _check_shared(node.config)
    assert node.topics["cartesian_command_in_topic"] == "/pfield_servo/delta_twist_cmds"
    assert node.topics["command_out_topic"] == "/panda_arm_controller/joint_trajectory"
    line = next(r.getMessage() for r in caplog.records if "MoveIt Servo parameters" in r.getMessage())
    assert "moveit_servo.use_smoothing" in line and "my_own_setting" not in line
    # neither pfield's nor MoveIt Servo's: a warning each, with the near name of a misspelling
    unknown = sorted(r.getMessage() for r in caplog.records if r.levelno == logging.WARNING)
    assert unknown == ["servo configuration: unknown parameter moveit_servo.incoming_command_timout ignored (did you "
                       "mean incoming_command_timeout?)",
                       "servo configuration: unknown parameter moveit_servo.my_own_setting ignored"]
    assert node.config.incoming_command_timeout != 0.5
    assert servo_from_parameters(manager, {"/pfield_manager": {}}) is None
    parameters = node.get_parameters()
    assert parameters["scale.linear"] == 0.2 and parameters["joint_limit_margins"] == [0.12]
    node.set_parameters({"incoming_command_timeout": 0.25})
    assert node.config.incoming_command_timeout == 0.25
    for bad, field in (({"publish_period": 0.02}, "publish_period"),  # read-only: it shapes the loop
                       ({"incoming_command_timeout": -1.0}, "incoming_command_timeout")):
        with pytest.raises(InvalidInput, match=field):
            node.set_parameters(bad)
    assert node.config.incoming_command_timeout == 0.25


@pytest.mark.parametrize(("values", "field"), [
    ({"publish_period": -0.01}, "publish_period"),
    ({"publish_period": math.nan}, "publish_period"),
    ({"publish_period": 5.0}, "publish_period"),
    ({"incoming_command_timeout": 0}, "incoming_command_timeout"),
    ({"command_out_type": "control_msgs/JointJog"}, "command_out_type"),
    ({"command_in_type": "volts"}, "command_in_type"),
    ({"lower_singularity_threshold": 40.0}, "hard_stop_singularity_threshold"),
    ({"joint_limit_margins": [0.1, -0.2]}, r"joint_limit_margins\[1\]"),
    ({"joint_limit_margins": "wide"}, "joint_limit_margins"),
    ({"status_topic": "a topic"}, "status_topic"),
    ({"publish_joint_positions": False, "publish_joint_velocities": False}, "publish_joint_positions"),
    ({"publish_joint_velocities": "yes"}, "publish_joint_velocities"),
    ({"joy_device": "wiimote"}, "joy_device"),
    ({"joy_deadzone": 1.5}, "joy_deadzone"),
    ({"override_velocity_scaling_factor": 2.0}, "override_velocity_scaling_factor"),
    ({"scale": {"joint": -1.0}}, "scale_joint"),
    ({"joint_command_in_topic": "delta joint cmds"}, "joint_command_in_topic"),
    ({"halt_all_joints_in_joint_mode": "yes"}, "halt_all_joints_in_joint_mode"),
    ({"publish_period": 0.01, "moveit_servo": {"publish_period": 0.02}}, "publish_period"),
    ({"publish_period": 1e-6}, r"publish_period=1e-06: must be in \[0.001, 1\] s"),  # an idle loop burnt a core
    ({"publish_period": 2.0}, "publish_period"),
])
def test_bad_values_are_refused_by_name(values: dict[str, Any], field: str) -> None:
    with pytest.raises(InvalidInput, match=field):
        servo_config_from_mapping(values)


def test_bad_files_and_node_settings(tmp_path: Path) -> None:
    from pfield.robot import RobotModel

    listed = tmp_path / "list.yaml"
    listed.write_text("[1, 2]\n")
    with pytest.raises(InvalidInput, match="mapping"):
        load_servo_file(listed)
    with pytest.raises(InvalidInput, match="servo parameters"):
        servo_config_from_mapping([("publish_period", 0.01)])  # type: ignore[arg-type]
    manager = ManagerNode(Bus(), RobotModel.builtin("panda"))
    with pytest.raises(InvalidInput, match="planning_frame"):
        ServoNode(manager.bus, manager, ServoConfig(planning_frame="base_link"))
    with pytest.raises(InvalidInput, match="ee_frame"):
        ServoNode(manager.bus, manager, ServoConfig(ee_frame="tool0"))
    with pytest.raises(InvalidInput, match="joint_limit_margins"):
        ServoNode(manager.bus, manager, ServoConfig(joint_limit_margins=(0.1, 0.1)))
    with pytest.raises(InvalidInput, match="one section"):
        servo_from_parameters(manager, {"/servo_node": {}, "/pfield_servo": {}})


def test_spacemouse_and_gamepad_mappings() -> None:
    mouse = ServoConfig(joy_device="spacemouse", scale_linear=0.1, scale_rotational=0.5)
    twist = joy_twist([0.5, -1.0, 0.02, 0.2, 0.0, -0.4], [0, 0], mouse)
    assert twist.linear.tolist() == pytest.approx([0.05, -0.1, 0.0])  # 0.02 is within the deadzone
    assert twist.angular.tolist() == pytest.approx([0.1, 0.0, -0.2])
    pad = ServoConfig(joy_device="gamepad", scale_linear=0.1, scale_rotational=0.5)
    axes = [0.3, 0.6, 0.0, -0.8, 1.0, 0.0, 0.0, 0.0]  # left x, left y, LT, right x, right y, RT, d-pad
    buttons = [0] * 11
    buttons[5] = 1
    twist = joy_twist(axes, buttons, pad)
    assert twist.linear.tolist() == pytest.approx([0.06, 0.03, 0.1])
    assert twist.angular.tolist() == pytest.approx([0.5, 0.0, -0.4])
    assert joy_twist([2.0] * 6, [], mouse).linear.tolist() == pytest.approx([0.1] * 3)  # axes clipped to [-1, 1]


def test_deadman_button_and_bad_joystick_input() -> None:
    config = ServoConfig(joy_deadman_button=0)
    assert not joy_twist([1.0] * 6, [0, 1], config).linear.any()
    assert not joy_twist([1.0] * 6, [], config).linear.any()
    assert joy_twist([1.0] * 6, [1, 0], config).linear.tolist() == pytest.approx([0.4] * 3)
    with pytest.raises(InvalidInput, match="6 axes"):
        joy_twist([0.0] * 3, [], ServoConfig())
    with pytest.raises(InvalidInput, match="5 axes"):
        joy_twist([0.0] * 4, [], ServoConfig(joy_device="gamepad"))
    with pytest.raises(InvalidInput, match=r"axes\[2\]"):
        joy_twist([0.0, 0.0, math.nan, 0.0, 0.0, 0.0], [], ServoConfig())
