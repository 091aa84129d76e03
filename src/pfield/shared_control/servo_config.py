"""The servo loop's parameters, under MoveIt Servo's names, and the joystick mappings.

:class:`ServoConfig` carries every parameter pfield's servo loop (:mod:`pfield.shared_control.servo`) uses. Where
MoveIt Servo has a parameter of the same meaning, the field has its name and unit (moveit_servo's
``config/servo_parameters.yaml``; older releases' ``planning_frame``, ``ee_frame_name``/``ee_frame`` and
``robot_link_command_frame`` too), so the shared part of a Servo configuration loads unchanged
(:func:`servo_config_from_mapping`). Defaults are Servo's, except ``command_in_type`` (pfield's twists are in
m/s and rad/s everywhere, so ``speed_units``) and the topic names (pfield's node is ``/pfield_servo``).
Parameters Servo has and pfield does not use (its planning-scene monitor, smoothing plugins, thread priority …)
are accepted and reported as ignored, never refused: a Servo user's file still loads.

Joystick mappings (``sensor_msgs/Joy``, axes unitless in [-1, 1], scaled by ``scale.linear`` m/s and
``scale.rotational`` rad/s as Servo's ``unitless`` commands; an axis within ``joy_deadzone`` of 0 counts as 0):

* ``spacemouse`` (``spacenav_node``'s ``/spacenav/joy``): axes 0–5 = linear x, y, z, angular x, y, z;
* ``gamepad`` (``joy_node`` with an Xbox-layout pad): left stick up (axis 1) = +x, left stick left (axis 0) = +y,
  right stick up (axis 4) = +z, right stick left (axis 3) = +yaw (angular z), left/right bumper (buttons 4/5) =
  −/+ roll (angular x).

With ``joy_deadman_button`` ≥ 0 the joystick commands only while that button is held (a dead-man switch);
releasing it is a zero command. Joystick twists are in ``joy_frame`` (empty: ``robot_link_command_frame``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pfield import _validation
from pfield.errors import InvalidInput
from pfield.spatial import Twist

__all__ = ["COMMAND_OUT_TYPES", "JOY_DEVICES", "SERVO_NAMES", "SERVO_ONLY_PARAMETERS", "ServoConfig", "joy_twist",
           "nearest_parameter", "servo_config_from_mapping", "unitless_scaled", "unitless_scaled_joints"]

COMMAND_OUT_TYPES = ("trajectory_msgs/JointTrajectory", "std_msgs/Float64MultiArray")
JOY_DEVICES = ("spacemouse", "gamepad")
SERVO_ONLY_PARAMETERS = frozenset({
    "thread_priority", "max_expected_latency", "active_subgroup", "pose_command_in_topic",
    "apply_twist_commands_about_ee_frame", "pose_tracking.linear_tolerance", "pose_tracking.angular_tolerance",
    "monitored_planning_scene_topic", "check_octomap_collisions", "is_primary_planning_scene_monitor",
    "use_smoothing", "smoothing_filter_plugin_name", "collision_check_rate", "singularity_step_scale",
    "use_gazebo", "low_pass_filter_coeff",
    "num_outgoing_halt_msgs_to_publish", "publish_delta_joint_state",
    "command_in_type_joint", "gripper_move_group_name", "use_intra_process_comms", "joint_limit_margin",
})
"""MoveIt Servo parameters pfield accepts and does not use (each reported as ignored when a file sets it)."""
_PREFIXES = ("moveit_servo.", "servo.")
"""A Servo file's parameters may sit under these namespaces (Servo's launch files load them as ``moveit_servo``)."""


MIN_PUBLISH_PERIOD = 0.001
"""s: the shortest servo period (1 kHz, the fastest update rate ros2_control controllers are run at). Shorter, the
loop only burns a core: at 1 µs an idle node took two thirds of one."""


@dataclass(frozen=True)
class ServoConfig:
    """The servo loop's parameters (module docstring; units in each field's documentation)."""

    publish_period: float = 0.01
    """s: 1 / the rate joint commands are published at."""
    incoming_command_timeout: float = 0.1
    """s: a command older than this is stale: the loop decelerates to a stop (status ``COMMAND_TIMEOUT``)."""
    command_in_type: str = "speed_units"
    """``speed_units`` (twists in m/s, rad/s) or ``unitless`` (in [-1, 1], scaled by ``scale_linear`` and
    ``scale_rotational``)."""
    scale_linear: float = 0.4
    """m/s of a unitless command of 1 (Servo's ``scale.linear``); joysticks are always unitless."""
    scale_rotational: float = 0.8
    """rad/s of a unitless command of 1 (Servo's ``scale.rotational``)."""
    scale_joint: float = 0.5
    """rad/s (m/s) of a unitless joint jog of 1 (Servo's ``scale.joint``)."""
    command_out_type: str = "trajectory_msgs/JointTrajectory"
    """``trajectory_msgs/JointTrajectory`` or ``std_msgs/Float64MultiArray``."""
    command_out_topic: str = "/joint_trajectory_controller/joint_trajectory"
    """Where joint commands are published."""
    publish_joint_positions: bool = True
    """Commands carry positions (a Float64MultiArray carries positions when this is set, else velocities)."""
    publish_joint_velocities: bool = True
    """Commands carry velocities."""
    publish_joint_accelerations: bool = False
    """JointTrajectory commands carry accelerations."""
    cartesian_command_in_topic: str = "~/delta_twist_cmds"
    """geometry_msgs/TwistStamped operator commands (``~/`` is the node's namespace: ``/pfield_servo/``)."""
    joint_command_in_topic: str = "~/delta_joint_cmds"
    """control_msgs/JointJog operator commands (joint velocities by joint name)."""
    joint_topic: str = "/joint_states"
    """sensor_msgs/JointState of the robot."""
    status_topic: str = "~/status"
    """std_msgs/Int8 status code (:class:`~pfield.shared_control.servo.ServoStatus`); its words on ``<topic>_text``."""
    move_group_name: str = ""
    """Informative: the MoveIt group the robot model stands for (pfield's robot is the node's ``--robot``)."""
    planning_frame: str = ""
    """The frame commands are computed in; empty or the manager's ``fixed_frame``."""
    ee_frame: str = ""
    """The end-effector link (empty: the robot model's); twists in this frame are rotated by the current FK."""
    robot_link_command_frame: str = ""
    """The frame of a twist whose ``header.frame_id`` is empty (empty: the fixed frame)."""
    lower_singularity_threshold: float = 17.0
    """Condition number of the end-effector Jacobian where deceleration starts."""
    hard_stop_singularity_threshold: float = 30.0
    """Condition number where motion toward the singularity stops."""
    leaving_singularity_threshold_multiplier: float = 2.0
    """Moving away from a singularity decelerates over this many times the approaching range."""
    joint_limit_margins: tuple[float, ...] = (0.1,)
    """rad (m): margins inside each position limit the command never crosses (one value for all joints, or one per
    joint)."""
    halt_all_joints_in_cartesian_mode: bool = True
    """At a joint margin, under a twist: scale every joint (keeps the direction of motion) instead of stopping only
    that joint."""
    halt_all_joints_in_joint_mode: bool = True
    """The same under a joint jog."""
    check_collisions: bool = True
    """Steer and limit the approach to obstacles (False: the operator's command with the joint limits only)."""
    scene_collision_proximity_threshold: float = 0.02
    """m: the Servo collision velocity scale's threshold, reported as ``speed_scale``."""
    self_collision_proximity_threshold: float = 0.01
    """m: the same for self collisions."""
    override_velocity_scaling_factor: float = 0.0
    """When > 0, the speed scale used while decelerating for a singularity instead of the computed one."""
    arbitration: str = ""
    """The assistance's arbitration (docs/assistance.md); empty: the manager's ``assistance_arbitration``."""
    joy_topic: str = "~/joy"
    """sensor_msgs/Joy input."""
    joy_device: str = "spacemouse"
    """``spacemouse`` or ``gamepad`` (the axis mapping in the module docstring)."""
    joy_deadzone: float = 0.05
    """|axis| at or below this counts as 0."""
    joy_deadman_button: int = -1
    """Index of the button that must be held for the joystick to command (-1: none)."""
    joy_frame: str = ""
    """The frame of joystick twists (empty: ``robot_link_command_frame``)."""

    def __post_init__(self) -> None:
        for name in ("publish_period", "incoming_command_timeout", "scale_linear", "scale_rotational", "scale_joint",
                     "lower_singularity_threshold", "hard_stop_singularity_threshold",
                     "leaving_singularity_threshold_multiplier", "scene_collision_proximity_threshold",
                     "self_collision_proximity_threshold"):
            object.__setattr__(self, name, _validation.positive(name, getattr(self, name)))
        if not MIN_PUBLISH_PERIOD <= self.publish_period <= 1.0:
            raise InvalidInput("publish_period", self.publish_period, f"must be in [{MIN_PUBLISH_PERIOD:g}, 1] s (a "
                               "servo loop of 1 Hz to 1 kHz, the fastest rate ros2_control controllers run at)")
        if self.hard_stop_singularity_threshold <= self.lower_singularity_threshold:
            raise InvalidInput("hard_stop_singularity_threshold", self.hard_stop_singularity_threshold,
                               f"must be > lower_singularity_threshold ({self.lower_singularity_threshold:g})")
        override = _validation.in_range("override_velocity_scaling_factor", self.override_velocity_scaling_factor,
                                        0.0, 1.0)
        object.__setattr__(self, "override_velocity_scaling_factor", override)
        object.__setattr__(self, "joy_deadzone", _validation.in_range("joy_deadzone", self.joy_deadzone, 0.0, 0.99))
        object.__setattr__(self, "joy_deadman_button", _validation.integer("joy_deadman_button",
                                                                           self.joy_deadman_button))
        _choice("command_in_type", self.command_in_type, ("speed_units", "unitless"))
        _choice("command_out_type", self.command_out_type, COMMAND_OUT_TYPES)
        _choice("joy_device", self.joy_device, JOY_DEVICES)
        for name in ("publish_joint_positions", "publish_joint_velocities", "publish_joint_accelerations",
                     "halt_all_joints_in_cartesian_mode", "halt_all_joints_in_joint_mode", "check_collisions"):
            object.__setattr__(self, name, _validation.boolean(name, getattr(self, name)))
        if not (self.publish_joint_positions or self.publish_joint_velocities):
            raise InvalidInput("publish_joint_positions", False, "a command needs positions or velocities: set "
                               "publish_joint_positions or publish_joint_velocities")
        for name in ("command_out_topic", "cartesian_command_in_topic", "joint_command_in_topic", "joint_topic",
                     "status_topic", "joy_topic"):
            _topic(name, getattr(self, name))
        for name in ("move_group_name", "planning_frame", "ee_frame", "robot_link_command_frame", "arbitration",
                     "joy_frame"):
            _validation.text(name, getattr(self, name))
        margins = self.joint_limit_margins
        if isinstance(margins, int | float) and not isinstance(margins, bool):
            margins = (margins,)
        if not isinstance(margins, Sequence) or isinstance(margins, str) or not margins:
            raise InvalidInput("joint_limit_margins", margins, "expected a list of margins >= 0 (rad or m)")
        object.__setattr__(self, "joint_limit_margins", tuple(
            _validation.nonnegative(f"joint_limit_margins[{i}]", m) for i, m in enumerate(margins)))

    def margins(self, n_joints: int) -> NDArray[np.float64]:
        """(n,) joint limit margins: one value broadcast, else one per joint (``InvalidInput`` otherwise)."""
        margins = self.joint_limit_margins
        if len(margins) not in (1, n_joints):
            raise InvalidInput("joint_limit_margins", list(margins), f"expected 1 or {n_joints} values (one per joint)")
        return np.broadcast_to(np.asarray(margins, dtype=np.float64), (n_joints,)).copy()

    def as_parameters(self) -> dict[str, Any]:
        """The parameters under their Servo names (``scale.linear`` …), JSON-compatible."""
        values = dataclasses.asdict(self)
        values["joint_limit_margins"] = list(self.joint_limit_margins)
        return {SERVO_NAMES.get(name, name): value for name, value in values.items()}


def _choice(name: str, value: Any, choices: Sequence[str]) -> None:
    if value not in choices:
        raise InvalidInput(name, value, f"must be one of {', '.join(choices)}")


def _topic(name: str, value: Any) -> None:
    topic = _validation.text(name, value)
    if not topic or any(c.isspace() for c in topic):
        raise InvalidInput(name, value, "must be a topic name such as /robot/commands or ~/status")


SERVO_NAMES = {"scale_linear": "scale.linear", "scale_rotational": "scale.rotational", "scale_joint": "scale.joint"}
"""Servo's parameter name of each :class:`ServoConfig` field whose name differs (a dotted ROS name)."""
_ALIASES = {servo: field for field, servo in SERVO_NAMES.items()} | {"ee_frame_name": "ee_frame"}
"""A Servo file's names that are not a field's: the dotted ones, and older releases' ``ee_frame_name``."""
_FIELDS = frozenset(f.name for f in dataclasses.fields(ServoConfig))


def nearest_parameter(name: str) -> str | None:
    """The Servo parameter pfield uses whose name is nearest ``name`` (a misspelling's likely meaning), or None when
    none is near (:func:`pfield._validation.nearest_name`)."""
    short = name
    for prefix in _PREFIXES:
        short = short.removeprefix(prefix)
    return _validation.nearest_name(short, sorted(_FIELDS - set(SERVO_NAMES)) + sorted(SERVO_NAMES.values()))


def _flatten(values: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{"scale": {"linear": 0.4}}`` → ``{"scale.linear": 0.4}`` (ROS parameter names of nested YAML)."""
    flat: dict[str, Any] = {}
    for key, value in values.items():
        name = f"{prefix}{_validation.text('parameter name', key)}"
        if isinstance(value, Mapping):
            flat |= _flatten(value, name + ".")
        else:
            flat[name] = value
    return flat


def servo_config_from_mapping(values: Mapping[str, Any], base: ServoConfig | None = None
                              ) -> tuple[ServoConfig, list[str]]:
    """A :class:`ServoConfig` from a MoveIt Servo parameter mapping, and the names it ignored (sorted).

    ``values``: a Servo YAML file's content — flat (``publish_period: 0.01``), nested (``scale: {linear: …}``), under
    ``moveit_servo:`` as Servo's launch files load it, or a ROS parameters file's ``ros__parameters`` section of
    it. Every parameter pfield uses is checked (``InvalidInput`` naming it); a name pfield does not use, Servo's
    or unknown, is ignored and listed. ``base``: the values not given (default: :class:`ServoConfig`'s).
    """
    if not isinstance(values, Mapping):
        raise InvalidInput("servo parameters", values, "expected a mapping of MoveIt Servo parameter names")
    flat = _flatten(values)
    given: dict[str, Any] = {}
    ignored: list[str] = []
    for name, value in flat.items():
        short = name
        for prefix in _PREFIXES:
            short = short.removeprefix(prefix)
        key = _ALIASES.get(short, short)
        if key in _FIELDS:
            if key in given and given[key] != value:
                raise InvalidInput(name, value, f"given twice with different values ({given[key]!r} before)")
            given[key] = tuple(value) if isinstance(value, list) else value
        else:
            ignored.append(name)
    config = dataclasses.replace(base or ServoConfig(), **given)
    return config, sorted(ignored)


def joy_twist(axes: Sequence[float], buttons: Sequence[int], config: ServoConfig) -> Twist:
    """The twist (m/s, rad/s; in ``joy_frame``) a joystick state commands (module docstring's mappings)."""
    values = [_validation.finite(f"axes[{i}]", a) for i, a in enumerate(axes)]
    if config.joy_deadman_button >= 0:
        held = config.joy_deadman_button < len(buttons) and buttons[config.joy_deadman_button] != 0
        if not held:
            return Twist()

    def axis(i: int) -> float:
        a = values[i] if i < len(values) else 0.0
        return 0.0 if abs(a) <= config.joy_deadzone else max(-1.0, min(1.0, a))

    def button(i: int) -> float:
        return 1.0 if i < len(buttons) and buttons[i] != 0 else 0.0

    if config.joy_device == "spacemouse":
        if len(values) < 6:
            raise InvalidInput("axes", list(axes), "a spacemouse sends 6 axes (x, y, z, roll, pitch, yaw)")
        linear = [axis(0), axis(1), axis(2)]
        angular = [axis(3), axis(4), axis(5)]
    else:
        if len(values) < 5:
            raise InvalidInput("axes", list(axes), "a gamepad (Xbox layout) sends at least 5 axes")
        linear = [axis(1), axis(0), axis(4)]
        angular = [button(5) - button(4), 0.0, axis(3)]
    return Twist([config.scale_linear * v for v in linear], [config.scale_rotational * w for w in angular])


def unitless_scaled_joints(velocities: NDArray[np.float64], config: ServoConfig) -> NDArray[np.float64]:
    """A ``unitless`` joint jog in rad/s (m/s) (Servo's rule: scaled by ``scale.joint``); ``speed_units`` unchanged."""
    if config.command_in_type == "speed_units":
        return velocities
    scaled = velocities * config.scale_joint
    scaled.setflags(write=False)
    return scaled


def unitless_scaled(twist: Twist, config: ServoConfig) -> Twist:
    """A ``unitless`` command in m/s and rad/s (Servo's rule: scaled by ``scale.linear``/``scale.rotational``);
    ``speed_units`` unchanged."""
    if config.command_in_type == "speed_units":
        return twist
    return Twist(np.asarray(twist.linear) * config.scale_linear, np.asarray(twist.angular) * config.scale_rotational)

