"""``/pfield_servo``: the servo loop (:mod:`pfield.shared_control.servo`) as a transport-free node.

Hosted beside ``/pfield_manager`` (whose obstacles, goal, field parameters, static frames and ``/joint_states`` it
uses), by ``pfield serve`` and ``pfield ros2 node`` when the ``--params`` file has a ``pfield_servo`` or
``servo_node`` section (MoveIt Servo's node name; its parameters flat or under ``moveit_servo:`` as Servo's launch
files give them), or from Python: ``ServoNode(bus, manager, config)``.

Topics in: ``cartesian_command_in_topic`` (geometry_msgs/TwistStamped: ``header.frame_id`` empty means
``robot_link_command_frame``; the fixed frame, a static frame, or the end-effector link, which turns with the tool),
``joint_command_in_topic`` (control_msgs/JointJog: ``velocities`` of the joints in ``joint_names``, the others
still, an empty jog all still; ``displacements`` and ``duration`` are not used, and a jog with names but only
displacements is refused, as is an unknown or repeated joint name),
``joy_topic`` (sensor_msgs/Joy, mapped by ``joy_device``), ``joint_topic`` (sensor_msgs/JointState, into the
manager's joint-state cache; ``/joint_states``, the default, is then this node's subscription instead of the
manager's, so that joint states are handled on the servo's thread: :attr:`ManagerNode.joint_states_subscriber`).
A command's age, for ``incoming_command_timeout``, runs from its ``header.stamp`` when that is not zero (MoveIt Servo's
rule), else from its arrival (:meth:`ServoNode._take`).
Services: MoveIt Servo's ``~/pause_servo`` (std_srvs/SetBool) and ``~/start_servo`` / ``~/stop_servo``
(std_srvs/Trigger): paused, a moving arm gets one command holding it where it was commanded, then nothing is published
and commands are dropped until it resumes from the measured joints (:meth:`ServoNode.pause`).
Topics out: ``command_out_topic`` (``command_out_type``: a JointTrajectory of one point at
``time_from_start = publish_period`` with positions/velocities/accelerations as ``publish_joint_*`` say, or a
Float64MultiArray of positions when ``publish_joint_positions`` is set, else velocities; joints in the robot's tree
order), ``status_topic`` (std_msgs/Int8: the :class:`~pfield.shared_control.servo.ServoStatus` code, as MoveIt
Servo publishes it) and ``<status_topic>_text`` (std_msgs/String: the code's name and why). Status messages are
published when the status changes; commands every step while the robot moves, and once more when it has stopped.

Timing: a command is stepped when it arrives (command-in to command-out is one step, not up to a period); the tick
(``tick_period = publish_period``) steps when no step happened for 0.9 of a period, so commands go out at least at
``publish_period`` while the robot moves, and a stale command decelerates the robot to a stop. While commands arrive
at least every period (their mean interval, :data:`FOLLOWING`) each is stepped as it comes, and the tick
waits for 1.5 periods instead: with commands and ticks at the same rate, a tick 0.9 period after a command would step
just before the next command and hold it up for a whole step (through a whole run in some runs of
``benchmarks/bench_servo.py``: the two clocks keep their phase). The tick then steps only for a command more than
half a period late; on the tick's grid of one period the output pauses at most 2.5 periods then (1.9 otherwise).
Without a joint state (none, or older than the manager's ``joint_state_timeout`` while not streaming) nothing is
commanded and the status is ``INVALID`` with the reason. Over ROS 2 the node spins on an executor of its own and its
inputs keep only the latest message (:mod:`pfield.transport.ros2`: a node that streams commands), so a command waits
neither for other nodes' callbacks nor behind older commands.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import re
import threading
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from pfield._validation import finite
from pfield.errors import InvalidInput
from pfield.interfaces import RosMessage, control_msgs, load_yaml_file, sensor_msgs, std_msgs, std_srvs, trajectory_msgs
from pfield.interfaces import geometry_msgs as gm
from pfield.node._base import Bus, Node, PublicationSpec, ServiceSpec, SubscriptionSpec
from pfield.node._joint_states import JOINT_STATES_TOPIC, rotate_twist
from pfield.node._params import ParameterRow, ParameterTable, field_docs
from pfield.node.manager import ManagerNode
from pfield.shared_control.servo import STATUS_MESSAGES, Servo, ServoCommand, ServoStatus
from pfield.shared_control.servo_config import (
    COMMAND_OUT_TYPES,
    JOY_DEVICES,
    SERVO_NAMES,
    SERVO_ONLY_PARAMETERS,
    ServoConfig,
    joy_twist,
    nearest_parameter,
    servo_config_from_mapping,
)
from pfield.spatial import Twist

__all__ = ["SERVO_NODE_NAMES", "ServoNode", "load_servo_file", "servo_from_parameters"]

_log = logging.getLogger(__name__)
SERVO_NODE_NAMES = ("/pfield_servo", "/servo_node")
"""``--params`` sections that configure the servo: pfield's node name and MoveIt Servo's demo node name."""
_FIGURES = re.compile(r" at [^ ]+ m$| \([^)]*\)")
"""The figures of a status sentence (a distance, a value in brackets): not part of its words."""
PAUSED_TEXT = "PAUSED: by ~/pause_servo or ~/stop_servo; commands are dropped until it resumes"
"""``status_text`` when the servo pauses (MoveIt Servo has no status code for it)."""
_RUNTIME = frozenset({"incoming_command_timeout", "scale_linear", "scale_rotational", "scale_joint",
                      "lower_singularity_threshold",
                      "hard_stop_singularity_threshold", "leaving_singularity_threshold_multiplier",
                      "check_collisions", "override_velocity_scaling_factor", "joy_deadzone", "joy_deadman_button",
                      "halt_all_joints_in_cartesian_mode", "halt_all_joints_in_joint_mode",
                      "publish_joint_accelerations", "command_in_type"})
"""Parameters that may change while the node runs (the others shape its topics and loop: read-only)."""
STAMP_TRUSTED_AGE = 1.0
"""s: a command stamped longer than this before its arrival is dated by its arrival instead (no queue of a working
node holds a command this long, so its stamp comes from another clock); shorter, by its stamp."""
CLOCK_WARNING_PERIOD = 10.0
"""s: at most one warning this often about stamps on another clock."""
FOLLOWING = 1.2
"""Commands whose mean interval is at most this many ``publish_period`` drive the output (module docstring, Timing):
the mean is exponential, weight 0.2 on the newest interval, each counted at most 2 periods (one late command does not
end it; after a pause, eight commands at the period start it again)."""


def _row(name: str, default: Any, doc: str) -> ParameterRow:
    ros_name = SERVO_NAMES.get(name, name)
    kind = {bool: "bool", int: "integer", float: "double", str: "string"}.get(type(default), "map")
    choices = {"command_out_type": COMMAND_OUT_TYPES, "joy_device": JOY_DEVICES,
               "command_in_type": ("speed_units", "unitless")}.get(name, ())
    return ParameterRow(ros_name, kind, doc, list(default) if isinstance(default, tuple) else default,
                        choices=choices, read_only=name not in _RUNTIME)


def servo_table(name: str) -> ParameterTable:
    """The ``/pfield_servo`` parameters (MoveIt Servo's names; ranges checked by :class:`ServoConfig`)."""
    defaults, docs = ServoConfig(), field_docs(ServoConfig)
    return ParameterTable(name, [_row(f.name, getattr(defaults, f.name), docs[f.name])
                                 for f in dataclasses.fields(ServoConfig)])


def _resolve(topic: str, node: str) -> str:
    """A ROS name as the node sees it: ``~/x`` → ``/pfield_servo/x``, ``x`` → ``/x``."""
    if topic.startswith("~/"):
        return f"{node}/{topic[2:]}"
    return topic if topic.startswith("/") else f"/{topic}"


class ServoNode(Node):
    """The ``/pfield_servo`` node (module docstring). ``ignored``: Servo parameters the configuration named and pfield
    does not use (logged once here)."""

    name = "/pfield_servo"

    def __init__(self, bus: Bus, manager: ManagerNode, config: ServoConfig | None = None,
                 ignored: tuple[str, ...] | list[str] = ()) -> None:
        super().__init__(bus)
        config = config or ServoConfig()
        fixed = manager.state.params.fixed_frame
        if config.planning_frame and config.planning_frame != fixed:
            raise InvalidInput("planning_frame", config.planning_frame, f"the manager's fixed_frame is {fixed!r}: "
                               "set the same frame in both (or leave planning_frame empty)")
        self.manager = manager
        self.servo = Servo(manager.robot, config, arbitration=manager.state.params.assistance_arbitration)
        self.tick_period = config.publish_period
        self.parameter_table = servo_table(self.name)
        self.topics = {key: _resolve(getattr(config, key), self.name) for key in
                       ("cartesian_command_in_topic", "joint_command_in_topic", "joy_topic", "joint_topic",
                        "command_out_topic", "status_topic")}
        self.topics["status_text"] = self.topics["status_topic"] + "_text"
        self._lock = threading.Lock()
        self._last_step = -1e300
        self._last_command = -1e300
        self._command_interval = float("inf")  # s: the commands' mean interval (FOLLOWING)
        self._was_moving = False
        self._status: tuple[int | None, str] = (None, "")  # (code, words) last published; None: nothing yet
        self._paused = False  # by ~/pause_servo or ~/stop_servo: no steps, commands dropped
        self._clock_warned = -math.inf  # when stamps on another clock were last warned about
        if ignored:
            servo_only = [n for n in ignored if n.split(".", 1)[-1] in SERVO_ONLY_PARAMETERS
                          or n in SERVO_ONLY_PARAMETERS]
            unknown = [n for n in ignored if n not in servo_only]
            if servo_only:
                _log.info("servo configuration: ignored MoveIt Servo parameters pfield does not use: %s",
                          ", ".join(servo_only))
            for name in unknown:  # neither pfield's nor MoveIt Servo's: most likely a misspelling
                near = nearest_parameter(name)
                _log.warning("servo configuration: unknown parameter %s ignored%s", name,
                             f" (did you mean {near}?)" if near else "")
        self.ignored = tuple(ignored)
        self._header = std_msgs.Header()
        self._joint_names = list(manager.robot.joint_names)
        self._joint_index = {name: j for j, name in enumerate(self._joint_names)}  # a jog's names to joints
        if self.topics["joint_topic"] == JOINT_STATES_TOPIC:  # the joint states on this node's thread (the manager's
            manager.joint_states_subscriber = self            # joint_states_subscriber says why)

    @property
    def config(self) -> ServoConfig:
        return self.servo.config

    # ---- node contract ------------------------------------------------------------------------------
    def services(self) -> list[ServiceSpec]:
        return [ServiceSpec(f"{self.name}/pause_servo", "std_srvs/srv/SetBool", std_srvs.SetBool_Request,
                            std_srvs.SetBool_Response, self.on_pause_servo),
                ServiceSpec(f"{self.name}/start_servo", "std_srvs/srv/Trigger", std_srvs.Trigger_Request,
                            std_srvs.Trigger_Response, self.on_start_servo),
                ServiceSpec(f"{self.name}/stop_servo", "std_srvs/srv/Trigger", std_srvs.Trigger_Request,
                            std_srvs.Trigger_Response, self.on_stop_servo)]

    # ---- pause ----------------------------------------------------------------------------------------
    @property
    def paused(self) -> bool:
        return self._paused

    def pause(self) -> None:
        """Stop the loop where it stands: a moving arm gets one command holding the last commanded positions at zero
        velocity, then nothing is published and commands are dropped until :meth:`resume`."""
        with self._lock:
            if self._paused:
                return
            self._paused = True
            hold = self.servo.halt()
            if hold is not None and self._was_moving:
                self.bus.publish(self.topics["command_out_topic"], self._command_message(hold))
            self._was_moving = False
            self._status = (None, "")  # the first status after resume is published
            self.bus.publish(self.topics["status_text"], std_msgs.String(data=PAUSED_TEXT))

    def resume(self) -> None:
        """Run again from the measured joints (the loop forgot its state when it paused), without any command that
        came while it was paused."""
        with self._lock:
            if self._paused:
                self.servo.stop()
            self._paused = False

    def on_pause_servo(self, request: std_srvs.SetBool_Request) -> std_srvs.SetBool_Response:
        """MoveIt Servo's ``~/pause_servo``: ``data`` true pauses, false resumes."""
        if request.data:
            self.pause()
        else:
            self.resume()
        return std_srvs.SetBool_Response(success=True, message="paused" if request.data else "running")

    def on_start_servo(self, _request: std_srvs.Trigger_Request) -> std_srvs.Trigger_Response:
        """MoveIt Servo's older ``~/start_servo``: resumes (pfield's servo runs from the start)."""
        self.resume()
        return std_srvs.Trigger_Response(success=True, message="running")

    def on_stop_servo(self, _request: std_srvs.Trigger_Request) -> std_srvs.Trigger_Response:
        """MoveIt Servo's older ``~/stop_servo``: pauses."""
        self.pause()
        return std_srvs.Trigger_Response(success=True, message="paused")

    def subscriptions(self) -> list[SubscriptionSpec]:
        specs = [SubscriptionSpec(self.topics["cartesian_command_in_topic"], "geometry_msgs/msg/TwistStamped",
                                  gm.TwistStamped, self.on_twist),
                 SubscriptionSpec(self.topics["joint_command_in_topic"], "control_msgs/msg/JointJog",
                                  control_msgs.JointJog, self.on_joint_jog),
                 SubscriptionSpec(self.topics["joy_topic"], "sensor_msgs/msg/Joy", sensor_msgs.Joy, self.on_joy)]
        # the joint states into the manager's cache: /joint_states instead of the manager (its joint_states_subscriber),
        # another joint_topic beside the manager's /joint_states
        specs.append(SubscriptionSpec(self.topics["joint_topic"], "sensor_msgs/msg/JointState", sensor_msgs.JointState,
                                      self.manager.on_joint_states))
        return specs

    def publications(self) -> list[PublicationSpec]:
        out_model: type[RosMessage] = trajectory_msgs.JointTrajectory
        if self.config.command_out_type == "std_msgs/Float64MultiArray":
            out_model = std_msgs.Float64MultiArray
        return [PublicationSpec(self.topics["command_out_topic"], out_model.ros_type, out_model, latched=False),
                PublicationSpec(self.topics["status_topic"], "std_msgs/msg/Int8", std_msgs.Int8),
                PublicationSpec(self.topics["status_text"], "std_msgs/msg/String", std_msgs.String)]

    def get_parameters(self) -> dict[str, Any]:
        return self.config.as_parameters()

    def describe_parameters(self) -> dict[str, dict[str, Any]]:
        return self.parameter_table.describe()

    def set_parameters(self, values: Mapping[str, Any]) -> dict[str, Any]:
        checked = self.parameter_table.check(values)
        config, _ = servo_config_from_mapping(checked, self.config)
        self.servo.reconfigure(config)
        return self.get_parameters()

    # ---- input ----------------------------------------------------------------------------------------
    def on_twist(self, message: gm.TwistStamped) -> None:
        """An operator twist (module docstring); stepped at once."""
        frame = message.header.frame_id or self.config.robot_link_command_frame
        values = [finite(f"twist.{part}.{axis}", getattr(getattr(message.twist, part), axis))
                  for part in ("linear", "angular") for axis in "xyz"]
        self._command(Twist(values[:3], values[3:]), frame, "twist", message.header.stamp, unitless=True)

    def on_joint_jog(self, message: control_msgs.JointJog) -> None:
        """An operator joint jog (module docstring): velocities by joint name, the unnamed joints still; stepped at
        once."""
        names, velocities = list(message.joint_names), list(message.velocities)
        if names and not velocities:
            raise InvalidInput("joint_jog.velocities", velocities, "the servo jogs by velocity: give one velocity per "
                               "joint name (displacements are not used)" if message.displacements else
                               "give one velocity per joint name")
        if len(velocities) != len(names):
            raise InvalidInput("joint_jog.velocities", velocities, f"expected one velocity per joint name "
                               f"({len(names)} names)")
        order = self._joint_index
        values = [0.0] * len(order)
        seen: set[str] = set()
        for name, velocity in zip(names, velocities, strict=True):
            if name not in order:
                raise InvalidInput("joint_jog.joint_names", name, f"not a joint of the robot (its joints: "
                                   f"{', '.join(order)})")
            if name in seen:
                raise InvalidInput("joint_jog.joint_names", name, "named twice")
            seen.add(name)
            values[order[name]] = finite(f"joint_jog.velocities[{name}]", velocity)
        self._take(lambda received: self.servo.command_joints(values, received), message.header.stamp)

    def on_joy(self, message: sensor_msgs.Joy) -> None:
        """A joystick state, mapped by ``joy_device`` (docs/servo.md); stepped at once."""
        twist = joy_twist(message.axes, message.buttons, self.config)
        frame = self.config.joy_frame or self.config.robot_link_command_frame
        self._command(twist, frame, "joy", message.header.stamp, unitless=False)

    def _command(self, twist: Twist, frame: str, field: str, stamp: std_msgs.Time, unitless: bool) -> None:
        """The twist into the servo (a static frame's rotated now, an end-effector twist at every step); a step."""
        state = self.manager.state
        end_effector = bool(frame) and frame == self.manager.robot.end_effector and frame != state.params.fixed_frame
        if not end_effector:
            transform = state.params.frames().lookup(f"{field}.header.frame_id", frame, "twists",
                                                     self.manager.robot.end_effector)
            twist = twist if transform is None else rotate_twist(twist, transform.orientation)
        self._take(lambda received: self.servo.command(twist, received, end_effector_frame=end_effector,
                                                       unitless=unitless), stamp)

    def _take(self, store: Callable[[float], None], stamp: std_msgs.Time) -> None:
        """A validated command: ``store(received)`` gives it to the loop, its interval goes into the mean (Timing),
        and a step follows; while paused it is dropped. ``received`` (monotonic s) dates the command for
        ``incoming_command_timeout``: by its ``header.stamp`` when that is not zero, read against :attr:`stamp_clock`
        (ROS time over rclpy), as MoveIt Servo does — a command that waited in a queue is as old as it is, and one
        older than the timeout stops the arm instead of moving it — else by its arrival. A stamp ahead of that clock
        counts from the arrival, and so does one more than :data:`STAMP_TRUSTED_AGE` behind it (a publisher on another
        clock: simulated time, an unsynchronised machine), with a warning."""
        if self._paused:
            return
        now = time.monotonic()
        age = self.stamp_age(stamp)
        if age is not None and age > STAMP_TRUSTED_AGE:  # no queue holds a command this long: another clock's stamp
            self._warn_clock(age)
            age = None
        store(now - max(age or 0.0, 0.0))
        interval = min(now - self._last_command, 2.0 * self.config.publish_period)
        mean = self._command_interval
        self._command_interval = interval if mean == float("inf") else 0.8 * mean + 0.2 * interval
        self._last_command = now
        self.step(now)

    def _warn_clock(self, age: float) -> None:
        now = time.monotonic()
        if now - self._clock_warned >= CLOCK_WARNING_PERIOD:
            self._clock_warned = now
            _log.warning("%s: a command stamped %.3g s before its arrival: the publisher's clock is not this node's "
                         "(simulated time? an unsynchronised machine?); dating such commands by their arrival",
                         self.name, age)

    # ---- the loop ---------------------------------------------------------------------------------------
    def tick(self, now: float) -> None:
        """A step when none came for 0.9 ``publish_period``, or for 1.5 while commands drive the output (module
        docstring, Timing)."""
        period = self.config.publish_period
        following = self._command_interval <= FOLLOWING * period and self._last_step == self._last_command
        if now - self._last_step >= (1.5 if following else 0.9) * period:
            self.step(now)

    def step(self, now: float) -> ServoCommand | None:
        """One servo step at ``now`` (monotonic s) from the manager's state; publishes its command and status. None
        without a joint state, or while paused."""
        with self._lock:
            if self._paused:
                return None
            if now < self._last_step:
                now = self._last_step
            self._last_step = now
            try:
                measured = self.manager.measured_joint_angles([], "joint_states")
            except InvalidInput as exc:
                if not self.servo.streaming:
                    self._publish_status(ServoStatus.INVALID, f"{STATUS_MESSAGES[ServoStatus.INVALID]}: {exc.reason}")
                    return None
                measured = self.manager.joint_states.held.positions  # type: ignore[union-attr]
            command = self.servo.step(measured, now, self.manager.assistance_scene())
            if command.moving or self._was_moving:
                self.bus.publish(self.topics["command_out_topic"], self._command_message(command))
            self._was_moving = command.moving
            self._publish_status(command.status, command.message)
            return command

    def _publish_status(self, status: ServoStatus, message: str) -> None:
        """The code on ``status_topic`` when it changes (as Servo does); the sentence on ``status_text`` when its
        words change (its figures — a distance while slowing, a value in brackets — change every cycle and are not a new
        status)."""
        words = _FIGURES.sub("", message)
        code, text = self._status
        if int(status) != code:
            self.bus.publish(self.topics["status_topic"], std_msgs.Int8(data=int(status)))
        if (int(status), words) != (code, text):
            self.bus.publish(self.topics["status_text"], std_msgs.String(data=f"{status.name}: {message}"))
        self._status = (int(status), words)

    def _command_message(self, command: ServoCommand) -> RosMessage:
        """The command as ``command_out_type`` (built without re-validating: every value is a finite float the loop
        computed, and the layout is the model's)."""
        config = self.config
        if config.command_out_type == "std_msgs/Float64MultiArray":
            values = command.positions if config.publish_joint_positions else command.velocities
            return std_msgs.Float64MultiArray.model_construct(layout=std_msgs.MultiArrayLayout(), data=values.tolist())
        nanoseconds = round(config.publish_period * 1e9)
        point = trajectory_msgs.JointTrajectoryPoint.model_construct(
            positions=command.positions.tolist() if config.publish_joint_positions else [],
            velocities=command.velocities.tolist() if config.publish_joint_velocities else [],
            accelerations=command.accelerations.tolist() if config.publish_joint_accelerations else [], effort=[],
            time_from_start=std_msgs.Duration(sec=nanoseconds // 1_000_000_000, nanosec=nanoseconds % 1_000_000_000))
        # a zero stamp: "start now" for a joint_trajectory_controller
        return trajectory_msgs.JointTrajectory.model_construct(header=self._header, joint_names=self._joint_names,
                                                               points=[point])


def load_servo_file(path: str | Path, option: str = "servo configuration") -> tuple[ServoConfig, list[str]]:
    """A MoveIt Servo YAML file (flat, under ``moveit_servo:``, or a ROS parameters file with a ``servo_node`` /
    ``pfield_servo`` section) as a :class:`ServoConfig`, and the parameter names it ignored."""
    data = load_yaml_file(Path(path), option) or {}
    if not isinstance(data, Mapping):
        raise InvalidInput(option, str(path), "expected a mapping of MoveIt Servo parameters")
    for name in SERVO_NODE_NAMES:
        section = data.get(name.lstrip("/"))
        if isinstance(section, Mapping) and isinstance(section.get("ros__parameters"), Mapping):
            return servo_config_from_mapping(section["ros__parameters"])
    return servo_config_from_mapping(data)


def servo_from_parameters(manager: ManagerNode, params: Mapping[str, Mapping[str, Any]]) -> ServoNode | None:
    """The servo node ``--params`` asks for (a ``/pfield_servo`` or ``/servo_node`` section), else None."""
    sections = [params[name] for name in SERVO_NODE_NAMES if name in params]
    if not sections:
        return None
    if len(sections) > 1:
        raise InvalidInput("--params", list(SERVO_NODE_NAMES), "configure the servo in one section, not both")
    config, ignored = servo_config_from_mapping(sections[0])
    return ServoNode(manager.bus, manager, config, ignored)
