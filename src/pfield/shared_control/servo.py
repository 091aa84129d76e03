"""The servo loop: the latest operator command turned into joint commands at a fixed rate, through the assistance.

A :class:`Servo` is MoveIt Servo's twist and joint-jog modes with pfield's field in the loop. Every
:meth:`Servo.step` (at ``publish_period``, or when a command arrives) takes the latest operator command, of either
kind (the latest wins) — a twist u (fixed frame; a twist in the end-effector frame is rotated by FK of the commanded
joints at every step, so it turns with the tool), or joint velocities q̇_u (a joint jog, :meth:`Servo.command_joints`)
— and:

1. **assistance** — :func:`~pfield.shared_control.whole_body_assistance` at the commanded joints q: u mapped to
   joints by damped least squares (a joint jog's q̇_u taken as it is), blended with the field's motion
   (arbitration), the approach of every link to every obstacle held below the velocity damper (motion *along* an
   obstacle passes: the command is steered, not scaled as Servo's collision scale does), joint velocity limits and
   the twist limits (:mod:`pfield.safety`);
2. **stale command** — a command older than ``incoming_command_timeout`` is replaced by zero: the loop decelerates
   to a stop (``COMMAND_TIMEOUT``);
3. **singularity** (twists only: a joint jog names its joints' motion, as in Servo) — Servo's rule on the condition
   number κ = σ_max/σ_min of the 6×n end-effector Jacobian: the speed is scaled by 1 − (κ − κ_l)/(κ_u − κ_l) above κ_l
   = ``lower_singularity_threshold``, where κ_u is ``hard_stop_singularity_threshold`` when the motion increases κ
   (probed by a 1 mrad step along q̇) and κ_l + m (κ_h − κ_l) when it decreases it (m =
   ``leaving_singularity_threshold_multiplier``); motion toward the singularity stops at κ ≥ κ_h (moveit_servo
   ``utils/common.cpp``, ``velocityScalingFactorForSingularity``); motion away keeps at least
   :data:`LEAVING_MIN_SCALE` of its speed, so the robot can always leave;
4. **acceleration** — |q̇ − q̇_prev| ≤ a_max dt per joint, by moving from q̇_prev toward the target by one factor
   (the direction of change is kept), a = :attr:`RobotModel.acceleration_limits`; the dampers and the joint margins
   come first (safety over smoothness: a collision or joint-bound status may decelerate faster);
5. **joint position limits** — no step ends inside ``joint_limit_margins`` of a limit: q̇_j ≤ (q_max,j − m_j − q_j)/dt
   and ≥ (q_min,j + m_j − q_j)/dt where it moves toward the limit (motion away always passes); every joint is scaled
   by one factor (``halt_all_joints_in_cartesian_mode``, for a joint jog ``halt_all_joints_in_joint_mode``: the
   direction is kept) or only the offending joints are (``JOINT_BOUND``);
6. **integration** — q_cmd = q + q̇ dt, clipped to the position limits;
7. **look-ahead** — near an obstacle, the clearance at q_cmd is computed: a step that would end closer than
   the field's ``safety_distance`` (the dampers' margin) to an obstacle, and closer than now, is not taken (the
   robot holds, ``HALT_FOR_COLLISION``; moving away passes). The dampers of stage 1 hold every link point on the
   velocity the assistance answers; stages 3–5 change that velocity (just after the operator turns, stage 4 still
   carries some of the previous velocity's approach), so this checks the step actually taken
   (tests/servo/test_servo_lookahead.py). Skipped when no point can travel that far in one step (:data:`REACH`).

The commanded joints q are the previous command's while the loop streams (what the controller is tracking, as a
position interface needs: the previous step moved, or had a fresh command), else the measured joints passed to
:meth:`Servo.step` (an idle loop follows the arm when something else, e.g. a trajectory controller, moves it).
``dt`` is the time since the previous step (at most 2 ``publish_period``), ``publish_period`` for the first. Status
codes are MoveIt Servo's (``moveit_servo/utils/datatypes.hpp``) plus pfield's ``COMMAND_TIMEOUT``; the most severe
reason wins.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pfield._enums import NamedIntEnum
from pfield._validation import as_vector, finite
from pfield.errors import InvalidInput
from pfield.robot.model import RobotModel
from pfield.shared_control.assistance import (
    Assistance,
    AssistanceScene,
    Flag,
    whole_body_assistance,
)
from pfield.shared_control.servo_config import ServoConfig, unitless_scaled, unitless_scaled_joints
from pfield.spatial import Twist, readonly_parts, rotate_vectors, twist_from_checked

__all__ = ["LEAVING_MIN_SCALE", "MIN_PERIOD", "REACH", "STATUS_MESSAGES", "Servo", "ServoCommand", "ServoStatus"]

MIN_PERIOD = 1e-4
"""s: the shortest dt a step integrates over (two steps at the same instant advance by this)."""
LEAVING_MIN_SCALE = 0.1
"""The smallest speed scale of a motion that leaves a singularity (module docstring, stage 3)."""
_PROBE_STEP = 1e-3
REACH = 2.0
"""m: a bound on the distance of any point of the robot from any of its joint axes (the arms pfield ships reach
under 1.5 m); it decides when stage 7's look-ahead can be skipped."""
_LIMITED = "approach limited by the dampers"
"""The words of an assistance answer whose approach the dampers limited (``assistance._message``)."""
"""rad: the joint step along q̇ that tells whether the motion approaches a singularity (κ grows) or leaves it."""


class ServoStatus(NamedIntEnum):
    """Why the servo slows or stops; MoveIt Servo's ``StatusCode`` values, plus pfield's ``COMMAND_TIMEOUT``."""

    INVALID = -1
    NO_WARNING = 0
    DECELERATE_FOR_APPROACHING_SINGULARITY = 1
    HALT_FOR_SINGULARITY = 2
    DECELERATE_FOR_LEAVING_SINGULARITY = 3
    DECELERATE_FOR_COLLISION = 4
    """pfield: the approach to an obstacle is limited by the dampers; motion along it passes (steering)."""
    HALT_FOR_COLLISION = 5
    """pfield: in contact, or the next step would end closer than the safety distance; only motion away passes."""
    JOINT_BOUND = 6
    COMMAND_TIMEOUT = 10
    """No command within ``incoming_command_timeout``: decelerating to (or holding) a stop."""


STATUS_MESSAGES = {
    ServoStatus.INVALID: "no joint state to servo from",
    ServoStatus.NO_WARNING: "no warnings",
    ServoStatus.DECELERATE_FOR_APPROACHING_SINGULARITY: "moving closer to a singularity, decelerating",
    ServoStatus.HALT_FOR_SINGULARITY: "very close to a singularity, stopped",
    ServoStatus.DECELERATE_FOR_LEAVING_SINGULARITY: "moving away from a singularity, decelerating",
    ServoStatus.DECELERATE_FOR_COLLISION: "close to an obstacle: approach limited, steering along it",
    ServoStatus.HALT_FOR_COLLISION: "at an obstacle (in contact, or a step from the safety distance): only motion "
                                    "away passes",
    ServoStatus.JOINT_BOUND: "at a joint limit margin, halting motion toward it",
    ServoStatus.COMMAND_TIMEOUT: "no command within incoming_command_timeout: stopping",
}
"""The words of each status (the ``message`` of a :class:`ServoCommand` starts with them)."""
_SEVERITY = (ServoStatus.HALT_FOR_COLLISION, ServoStatus.HALT_FOR_SINGULARITY, ServoStatus.JOINT_BOUND,
             ServoStatus.DECELERATE_FOR_APPROACHING_SINGULARITY, ServoStatus.DECELERATE_FOR_LEAVING_SINGULARITY,
             ServoStatus.DECELERATE_FOR_COLLISION, ServoStatus.COMMAND_TIMEOUT)


@dataclass(frozen=True, eq=False)
class ServoCommand:
    """One step's joint command (the robot's joint order: ``joint_names``).

    ``positions`` (rad or m), ``velocities`` (rad/s or m/s), ``accelerations`` ((q̇ − q̇_prev)/dt), ``period`` (s,
    the step's dt), ``status`` and ``message`` (why it slows or stops), ``moving`` (a non-zero velocity), and the
    step's ``assistance`` answer (None when the command was stale).
    """

    joint_names: tuple[str, ...]
    positions: NDArray[np.float64]
    velocities: NDArray[np.float64]
    accelerations: NDArray[np.float64]
    period: float
    status: ServoStatus
    message: str
    moving: bool
    assistance: Assistance | None


@dataclass(frozen=True, eq=False)
class _Command:
    """The operator's latest command: a twist (6,: fixed frame, or the end-effector frame with ``end_effector``) or
    joint velocities (n,: a joint jog), in m/s, rad/s; ``received`` on the clock :meth:`Servo.step` is given."""

    received: float
    twist: NDArray[np.float64] | None = None
    end_effector: bool = False
    joints: NDArray[np.float64] | None = None


class Servo:
    """The servo loop of ``robot`` (module docstring). Thread-safe: :meth:`command` and :meth:`step` may come from
    different threads.

    ``scene``: the obstacles, goal and field parameters the assistance works against (a step may pass another);
    ``arbitration``: the assistance's mode when ``config.arbitration`` is empty.
    """

    def __init__(self, robot: RobotModel, config: ServoConfig | None = None, scene: AssistanceScene | None = None,
                 arbitration: str = "linear") -> None:
        self.robot = robot
        self.config = config or ServoConfig()
        self.scene = scene
        self.arbitration = self.config.arbitration or arbitration
        if self.config.ee_frame and self.config.ee_frame != robot.end_effector:
            raise InvalidInput("ee_frame", self.config.ee_frame, f"the robot's end effector is "
                               f"{robot.end_effector!r} (give that, or leave ee_frame empty)")
        self._margins = self.config.margins(robot.n_joints)
        self._lower = np.asarray(robot.lower_limits, dtype=np.float64)
        self._upper = np.asarray(robot.upper_limits, dtype=np.float64)
        self._acceleration = np.asarray(robot.acceleration_limits, dtype=np.float64)
        self._lock = threading.Lock()
        self._command: _Command | None = None
        self._positions: NDArray[np.float64] | None = None
        self._velocities = np.zeros(robot.n_joints)
        self._last_step: float | None = None
        self._moving = False
        self._active = False  # the last step moved or had a fresh command: the next continues from its command
        self._bare: dict[int, AssistanceScene] = {}

    # ---- input ------------------------------------------------------------------------------------------
    def command(self, twist: Twist, received: float, *, end_effector_frame: bool = False,
                unitless: bool = True) -> None:
        """The operator's latest twist (fixed frame, or the end-effector frame), received at ``received`` (s, the
        clock :meth:`step` is given). ``unitless``: apply ``command_in_type`` (a joystick's twist is already
        scaled: False)."""
        if not isinstance(twist, Twist):
            raise InvalidInput("twist", twist, "expected a pfield.Twist")
        stamp = finite("received", received)
        values = np.concatenate([twist.linear, twist.angular]).astype(np.float64)
        if not np.isfinite(values).all():
            raise InvalidInput("twist", values.tolist(), "must be finite")
        if unitless:
            scaled = unitless_scaled(twist, self.config)
            values = np.concatenate([scaled.linear, scaled.angular]).astype(np.float64)
        with self._lock:
            self._command = _Command(stamp, twist=values, end_effector=bool(end_effector_frame))

    def command_joints(self, velocities: ArrayLike, received: float, *, unitless: bool = True) -> None:
        """The operator's latest joint jog: one velocity per joint in the robot's order (rad/s or m/s; 0 for joints
        not jogged), received at ``received`` (s). ``unitless``: apply ``command_in_type`` (``unitless`` scales by
        ``scale_joint``, Servo's ``scale.joint``)."""
        stamp = finite("received", received)
        values = as_vector("velocities", velocities, self.robot.n_joints)
        if unitless:
            values = unitless_scaled_joints(values, self.config)
        with self._lock:
            self._command = _Command(stamp, joints=values)

    def stop(self) -> None:
        """Forget the command (the next steps decelerate to a stop)."""
        with self._lock:
            self._command = None

    @property
    def streaming(self) -> bool:
        """True while the last step moved the robot (the next starts from its command)."""
        return self._positions is not None and self._moving

    # ---- the loop ---------------------------------------------------------------------------------------
    def step(self, joint_angles: ArrayLike, now: float, scene: AssistanceScene | None = None) -> ServoCommand:
        """One cycle at time ``now`` (s) from the measured ``joint_angles`` (used when not streaming; up to
        :data:`~pfield.robot.model.MEASURED_BOUNDS_ERROR` past a limit taken at the limit)."""
        config = self.config
        measured = self.robot.check_measured_joint_angles(joint_angles, "joint_angles")
        now = finite("now", now)
        scene = scene or self.scene
        if scene is None:
            raise InvalidInput("scene", None, "the servo needs an AssistanceScene (obstacles and field parameters)")
        with self._lock:
            command = self._command
            last = self._last_step
        if last is not None and now < last:
            raise InvalidInput("now", now, f"earlier than the previous step ({last:g} s): use one monotonic clock")
        streaming = self._positions is not None and self._active and last is not None and \
            now - last <= max(2.0 * config.publish_period, config.incoming_command_timeout)
        dt = config.publish_period
        if streaming and last is not None:  # the time since the previous step, within [MIN_PERIOD, 2 publish_period]
            dt = min(max(now - last, MIN_PERIOD), 2.0 * config.publish_period)
        base = self._positions if streaming and self._positions is not None else measured
        previous = self._velocities if streaming else np.zeros(self.robot.n_joints)
        stale = command is None or now - command.received > config.incoming_command_timeout
        reasons: list[ServoStatus] = []
        answer: Assistance | None = None
        if stale:
            target = np.zeros(self.robot.n_joints)
            reasons.append(ServoStatus.COMMAND_TIMEOUT)
        else:
            assert command is not None
            answer = self._assist(scene, base, command, previous, dt)
            target = np.array(answer.joint_velocities, dtype=np.float64)
            reasons += _collision_reasons(answer)
        jog = command is not None and command.joints is not None
        if not jog:
            target = self._singularity(base, target, reasons)
        velocities = self._accelerate(previous, target, dt, safety_first=bool(reasons) and not stale)
        halt_all = config.halt_all_joints_in_joint_mode if jog else config.halt_all_joints_in_cartesian_mode
        velocities = self._joint_bounds(base, velocities, dt, reasons, halt_all)
        positions = np.clip(base + velocities * dt, self._lower, self._upper)
        if answer is not None and answer.flags & Flag.NEAR_OBSTACLE and config.check_collisions and \
                self._may_close_in(scene, answer, velocities, dt) and self._closes_in(scene, answer, positions):
            velocities, positions = np.zeros_like(velocities), base.copy()
            reasons.append(ServoStatus.HALT_FOR_COLLISION)
        accelerations = (velocities - previous) / dt if dt > 0 else np.zeros_like(velocities)
        status = next((s for s in _SEVERITY if s in reasons), ServoStatus.NO_WARNING)
        moving = bool(np.any(velocities))
        with self._lock:
            self._positions, self._velocities, self._last_step = positions, velocities, now
            self._moving = moving
            self._active = moving or not stale
        message = STATUS_MESSAGES[status]
        if answer is not None and status in (ServoStatus.DECELERATE_FOR_COLLISION, ServoStatus.HALT_FOR_COLLISION):
            message += f": obstacle {answer.nearest_obstacle_id!r} at {answer.nearest_distance:.3g} m"
        return ServoCommand(self.robot.joint_names, positions, velocities, accelerations, dt, status, message, moving,
                            answer)

    def reconfigure(self, config: ServoConfig) -> None:
        """Use ``config`` from the next step on (its joint margins checked against the robot first)."""
        margins = config.margins(self.robot.n_joints)
        with self._lock:
            self.config, self._margins = config, margins
            self.arbitration = config.arbitration or self.arbitration

    def halt(self) -> ServoCommand | None:
        """Stop now, where the last step commanded (a pause): the command is forgotten and the next step starts from
        the measured joints (:meth:`reset`). Returns the command that holds the arm there — the last commanded
        positions at zero velocity — or None when no step has commanded a position since the last reset."""
        n = self.robot.n_joints
        with self._lock:
            positions = self._positions
            self._command = None
            self._positions, self._last_step, self._moving, self._active = None, None, False, False
            self._velocities = np.zeros(n)
        if positions is None:
            return None
        return ServoCommand(self.robot.joint_names, positions.copy(), np.zeros(n), np.zeros(n),
                            self.config.publish_period, ServoStatus.NO_WARNING, "halted where commanded", False, None)

    def reset(self) -> None:
        """Start again from the measured joints at the next step (a new session, or after the robot was moved)."""
        with self._lock:
            self._positions, self._last_step, self._moving, self._active = None, None, False, False
            self._velocities = np.zeros(self.robot.n_joints)

    # ---- the stages -------------------------------------------------------------------------------------
    def _assist(self, scene: AssistanceScene, q: NDArray[np.float64], command: _Command,
                previous: NDArray[np.float64], dt: float) -> Assistance:
        if not self.config.check_collisions:
            scene = self._without_obstacles(scene)
        if command.joints is not None:
            return whole_body_assistance(scene, self.robot, q, None, self.arbitration, prev_joint_velocities=previous,
                                         dt=dt, user_joint_velocities=command.joints)
        assert command.twist is not None
        linear, angular = command.twist[:3], command.twist[3:]
        if command.end_effector:  # the end-effector frame turns with the tool: rotate by FK of the joints commanded now
            orientation = self.robot.forward_kinematics(q).orientation
            linear, angular = rotate_vectors(orientation, linear), rotate_vectors(orientation, angular)
        user = twist_from_checked(*readonly_parts(np.concatenate([linear, angular])))  # checked when it came in
        return whole_body_assistance(scene, self.robot, q, user, self.arbitration, prev_joint_velocities=previous,
                                     dt=dt)

    def _without_obstacles(self, scene: AssistanceScene) -> AssistanceScene:
        bare = self._bare.get(id(scene))
        if bare is None or bare.config is not scene.config:
            bare = AssistanceScene(config=scene.config, obstacles=[], options=scene.options)
            self._bare = {id(scene): bare}
        return bare

    @staticmethod
    def _may_close_in(scene: AssistanceScene, answer: Assistance, velocities: NDArray[np.float64], dt: float) -> bool:
        """False when no robot point can come within ``safety_distance``: a step moves any point by at most
        :data:`REACH` · Σ|q̇_j| dt (each joint turns it about an axis at most REACH away), and every point is at least
        the nearest distance from every obstacle."""
        travel = REACH * float(np.abs(velocities).sum()) * dt
        return answer.nearest_distance - travel < scene.config.safety_distance  # type: ignore[union-attr]

    def _closes_in(self, scene: AssistanceScene, answer: Assistance, positions: NDArray[np.float64]) -> bool:
        """True when the step to ``positions`` brings the robot closer than the field's ``safety_distance`` (the
        margin the dampers keep) to an obstacle and closer than it is now (stage 7 of the module docstring)."""
        ahead = whole_body_assistance(scene, self.robot, positions, None, "safety_only")
        return ahead.nearest_distance < min(answer.nearest_distance, scene.config.safety_distance)  # type: ignore[union-attr]

    def _singularity(self, q: NDArray[np.float64], target: NDArray[np.float64], reasons: list[ServoStatus]
                     ) -> NDArray[np.float64]:
        """Servo's singularity scale on ``target`` (module docstring, stage 3)."""
        speed = float(np.linalg.norm(target))
        if speed == 0.0:
            return target
        config = self.config
        low, hard = config.lower_singularity_threshold, config.hard_stop_singularity_threshold
        kappa = self.robot.condition_number(q)
        if kappa <= low:
            return target
        probe = np.clip(q + _PROBE_STEP * target / speed, self._lower, self._upper)
        approaching = self.robot.condition_number(probe) > kappa
        upper = hard if approaching else low + (hard - low) * config.leaving_singularity_threshold_multiplier
        if approaching and kappa >= hard:
            reasons.append(ServoStatus.HALT_FOR_SINGULARITY)
            return np.zeros_like(target)
        scale = 1.0 - (kappa - low) / (upper - low)
        # moving away is never stopped: beyond the leaving range it keeps LEAVING_MIN_SCALE of its speed (pfield's
        # choice; Servo's scale would reach 0 there and hold the robot in the singularity)
        scale = max(scale, 0.0 if approaching else LEAVING_MIN_SCALE)
        if config.override_velocity_scaling_factor > 0.0:
            scale = config.override_velocity_scaling_factor
        reasons.append(ServoStatus.DECELERATE_FOR_APPROACHING_SINGULARITY if approaching
                       else ServoStatus.DECELERATE_FOR_LEAVING_SINGULARITY)
        return target * scale

    def _accelerate(self, previous: NDArray[np.float64], target: NDArray[np.float64], dt: float,
                    safety_first: bool) -> NDArray[np.float64]:
        """From ``previous`` toward ``target`` by the largest factor within the acceleration limits (stage 4);
        with ``safety_first`` (a collision or singularity reason) a change toward zero speed is not limited."""
        change = target - previous
        room = self._acceleration * dt
        excess = np.abs(change) > room
        if not excess.any():
            return target
        if safety_first and float(np.linalg.norm(target)) <= float(np.linalg.norm(previous)):
            return target
        factor = float(np.min(room[excess] / np.abs(change[excess])))
        return previous + factor * change

    def _joint_bounds(self, q: NDArray[np.float64], velocities: NDArray[np.float64], dt: float,
                      reasons: list[ServoStatus], halt_all: bool) -> NDArray[np.float64]:
        """No step ends inside a joint's margin (stage 5); ``halt_all``: every joint scaled by one factor."""
        upper_room = np.maximum((self._upper - self._margins - q) / dt, 0.0)
        lower_room = np.minimum((self._lower + self._margins - q) / dt, 0.0)
        over = velocities > upper_room
        under = velocities < lower_room
        if not (over.any() or under.any()):
            return velocities
        reasons.append(ServoStatus.JOINT_BOUND)
        if halt_all:
            ratios = np.concatenate([upper_room[over] / velocities[over], lower_room[under] / velocities[under]])
            return velocities * float(max(0.0, min(1.0, ratios.min())))
        return np.clip(velocities, lower_room, upper_room)


def _collision_reasons(answer: Assistance) -> list[ServoStatus]:
    """HALT_FOR_COLLISION in contact; DECELERATE_FOR_COLLISION when the dampers limited the approach (the
    assistance's answer says so in its message, :data:`_LIMITED`)."""
    if answer.flags & Flag.IN_COLLISION:
        return [ServoStatus.HALT_FOR_COLLISION]
    if answer.flags & Flag.NEAR_OBSTACLE and _LIMITED in answer.message:
        return [ServoStatus.DECELERATE_FOR_COLLISION]
    return []
