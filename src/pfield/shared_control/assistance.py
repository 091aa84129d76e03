"""Shared-control assistance: the operator's command arbitrated with the field's, and why (ComputeAssistance).

Given the operator's twist u_user and the field's autonomy vector u_auto (:mod:`pfield.shared_control.autonomy`):

* **nearest obstacle** — exact signed distance d from the robot (the end-effector point in task space, the
  fitted link model in whole body) to every obstacle; ``nearest_normal`` n̂ = ∇d (unit, from the obstacle toward
  the robot), ``robot_point`` p and ``obstacle_point`` p − d n̂ (the witness points).
* **arbitration** — linear blending u = α u_auto + (1 − α) u_user (Dragan & Srinivasa 2013, "A policy-blending
  formalism for shared control", §3, with α a function of the robot's situation). pfield's α:

  - ``linear``: α = clip((Q − d)/(Q − d_s), 0, 1) with Q = ``influence_distance``, d_s = ``safety_distance``:
    the operator alone beyond the field's influence, the field alone at the safety margin;
  - ``linear_goal``: α = max(α_obs, clip(1 − ‖g − p‖/R, 0, 1)) with R = ``goal_radius``: the field also takes
    over near the goal (the "confidence grows as the goal nears" arbitration of Dragan & Srinivasa);
  - ``safety_only``: α = 0, the operator's command with only its approach limited.
* **dampers on the blend** — for every obstacle within Q the relative approach speed −n̂ᵀ(v − v_obs) is held
  below the NEO velocity damper s(d) (Haviland & Corke 2021, eq. 20; :func:`pfield.field.forces.damper_speed`)
  by projecting v onto the half-space (only velocity along n̂, away from the obstacle, is added), so the
  executed command never approaches faster than the dampers allow and motion away is never slowed (whole body:
  at every link point within Q, :func:`whole_body_assistance`).
* **speed_scale** — MoveIt Servo's collision velocity scale exp(k (d − d_t)), k = −ln(0.001)/d_t, for
  d < d_t (1 beyond, 0 in collision), with Servo's default thresholds d_t = 0.02 m (scene) and 0.01 m (self)
  (moveit_servo ``collision_monitor``/``collision_check`` and its ``servo_parameters.yaml``). Reported, not
  applied: pfield limits the approach instead of slowing every direction.
* **time_to_collision** — first-order: min over obstacles of d_i / (−n̂_iᵀ(u_user − v_obs,i)) among those the
  operator's command (held constant) approaches; 0 in collision, ``inf`` when none is approached.

Moving obstacles: ``velocities`` maps obstacle ids to their world velocity (m/s; the node estimates them for
``Dynamic`` obstacles or takes them from ``/pfield/obstacle_velocities``). Only the assistance's dampers and
time to collision use them; the autonomy vector and plans treat every obstacle as static at its current pose.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pfield import safety
from pfield._core import assistance as _core
from pfield._core import robot as _robot_core
from pfield._validation import as_vector, finite, in_range, optional_vector
from pfield.errors import InvalidInput
from pfield.field.config import FieldConfig
from pfield.geometry import Obstacle, empty_packed, pack_obstacles
from pfield.planning.whole_body import WholeBodyOptions, core_robot, obstacle_bounds, pack_robot
from pfield.robot.model import LIMIT_TOLERANCE, RobotModel
from pfield.shared_control._recent import Recent
from pfield.shared_control.autonomy import whole_body_stepper
from pfield.spatial import Pose, Twist, readonly_parts, twist_from_checked

__all__ = ["ARBITRATIONS", "Assistance", "AssistanceOptions", "AssistanceScene", "Flag", "servo_scale",
           "task_space_assistance", "whole_body_assistance"]

ARBITRATIONS = ("linear", "linear_goal", "safety_only")
_MODES = {name: getattr(_core.Arbitration, name) for name in ARBITRATIONS}
_LOG = logging.getLogger(__name__)


def servo_scale(distance: float, threshold: float) -> float:
    """MoveIt Servo's collision velocity scale exp(k (d − d_t)), k = −ln(0.001)/d_t, for 0 < d < d_t: 1 beyond the
    threshold d_t, 0.001 at contact, 0 in collision (d ≤ 0), where Servo halts (module docstring)."""
    scale: float = _core.servo_scale(distance, threshold)
    return scale


class Flag:
    """Bits of :attr:`Assistance.flags` (the ComputeAssistance response's ``FLAG_*`` constants)."""

    IN_COLLISION = 1
    NEAR_OBSTACLE = 2
    AT_GOAL = 4
    STALLED = 8
    AT_JOINT_LIMIT = 16
    NEAR_SINGULARITY = 32
    STALE_INPUT = 64
    NO_GOAL = 128
    VELOCITY_LIMITED = 256
    """The operator's command or the blend exceeded a velocity limit and was scaled down to it
    (:mod:`pfield.safety`)."""
    HALTED = 512
    """No finite command could be computed from the inputs: the commands are zero (:mod:`pfield.safety`)."""


@dataclass(frozen=True)
class AssistanceOptions:
    """Parameters of the assistance laws (module docstring); validated on construction."""

    arbitration: str = "linear"
    """Default mode: ``linear``, ``linear_goal`` or ``safety_only``."""
    goal_radius: float = 0.2
    """m: R of ``linear_goal``: within it the goal share 1 − ‖g − p‖/R grows to 1."""
    scene_threshold: float = 0.02
    """m: MoveIt Servo's ``scene_collision_proximity_threshold`` (its default) for ``speed_scale``."""
    self_threshold: float = 0.01
    """m: MoveIt Servo's ``self_collision_proximity_threshold`` (its default)."""
    goal_tolerance: float = 0.01
    """m: ``FLAG_AT_GOAL`` when the position error is within it (and the rotation within ``rotation_tolerance``)."""
    stale_input_timeout: float = 0.5
    """s: ``FLAG_STALE_INPUT`` when the operator's command is older."""
    stall_speed: float = 1e-4
    """m/s: ``FLAG_STALLED`` when the autonomy vector is slower than this away from the goal (a local minimum)."""
    singularity_threshold: float = 0.01
    """``FLAG_NEAR_SINGULARITY`` when the smallest singular value of the end-effector Jacobian is below it."""
    joint_limit_margin: float = 0.01
    """rad (m): ``FLAG_AT_JOINT_LIMIT`` when a joint is this close to a position limit."""
    damping: float = 0.01
    """λ of the damped least-squares map q̇ = Jᵀ(J Jᵀ + λ² I)⁻¹ u of the operator's twist (whole body)."""

    def __post_init__(self) -> None:
        if self.arbitration not in _MODES:
            raise InvalidInput("arbitration", self.arbitration, f"expected one of {list(ARBITRATIONS)}")
        for name in ("goal_radius", "scene_threshold", "self_threshold", "goal_tolerance", "stale_input_timeout",
                     "stall_speed", "singularity_threshold", "joint_limit_margin", "damping"):
            value = finite(name, getattr(self, name))
            if value <= 0.0:
                raise InvalidInput(name, value, "must be > 0")
            object.__setattr__(self, name, value)


@dataclass(frozen=True, eq=False)
class AssistanceScene:
    """What assistance is computed against, validated and packed once: parameters, goal, obstacles, velocities.

    ``field``: the :class:`~pfield.field.PotentialField` giving the autonomy vector (None without a goal:
    then ``config`` and ``obstacles`` must be given and the autonomy vector is zero). ``velocities``: obstacle
    id → world velocity (m/s); obstacles not named are static.
    """

    field: Any = None
    config: FieldConfig | None = None
    obstacles: Sequence[Obstacle] | None = None
    velocities: Mapping[str, ArrayLike] = dataclasses.field(default_factory=dict)
    options: AssistanceOptions = dataclasses.field(default_factory=AssistanceOptions)

    def __post_init__(self) -> None:
        if self.field is not None:
            object.__setattr__(self, "config", self.field.config)
            object.__setattr__(self, "obstacles", tuple(self.field.obstacles))
            packed = self.field.arrays.packed
        else:
            if not isinstance(self.config, FieldConfig):
                raise InvalidInput("config", self.config, "expected a pfield.FieldConfig when no field is given")
            object.__setattr__(self, "obstacles", tuple(self.obstacles or ()))
            packed = pack_obstacles(list(self.obstacles)) if self.obstacles else empty_packed()
        obstacles: tuple[Obstacle, ...] = tuple(self.obstacles or ())
        ids = [o.id for o in obstacles]
        unknown = sorted(set(self.velocities) - set(ids))
        if unknown:
            raise InvalidInput("velocities", unknown, "names obstacles the scene does not hold")
        table = np.zeros((len(obstacles), 3))
        for i, key in enumerate(ids):
            if key in self.velocities:
                table[i] = safety.check_obstacle_velocity(f"velocities[{key!r}]", self.velocities[key])
        config = self.config
        assert config is not None
        params = _core.Params(
            influence_distance=config.influence_distance, safety_distance=config.safety_distance,
            damper_gain=config.damper_gain, max_linear_velocity=config.max_linear_velocity,
            max_linear_acceleration=config.max_linear_acceleration, max_angular_velocity=config.max_angular_velocity,
            scale_threshold=self.options.scene_threshold)
        # the compiled scene reads the packed obstacles, their bounding spheres (one robot.Obstacles) and the velocity
        # table in place
        obstacles = _robot_core.Obstacles(*packed, *obstacle_bounds(packed))
        object.__setattr__(self, "_core", _core.AssistanceScene(obstacles, table, params))
        object.__setattr__(self, "_table", table)
        object.__setattr__(self, "_ids", ids)

    @property
    def velocity_table(self) -> NDArray[np.float64]:
        """(M, 3) obstacle velocities in the scene's obstacle order (m/s)."""
        table: NDArray[np.float64] = self._table  # type: ignore[attr-defined]
        return table


@dataclass(frozen=True, eq=False)
class Assistance:
    """One assistance answer; the field names are the ComputeAssistance response's (units there)."""

    autonomy_vector: Twist
    joint_velocities: NDArray[np.float64]
    blended_command: Twist
    alpha: float
    speed_scale: float
    nearest_obstacle_id: str
    nearest_distance: float
    nearest_normal: NDArray[np.float64]
    robot_point: NDArray[np.float64]
    obstacle_point: NDArray[np.float64]
    time_to_collision: float
    flags: int
    message: str


def _mode(scene: AssistanceScene, arbitration: str) -> int:
    """The mode of ``arbitration`` (empty: the default); without a goal always safety_only (u_auto = 0)."""
    name = arbitration or scene.options.arbitration
    if name not in _MODES:
        raise InvalidInput("arbitration", arbitration, f"expected one of {list(ARBITRATIONS)} or empty")
    return _MODES["safety_only"] if scene.field is None else _MODES[name]


def _user_twist(scene: AssistanceScene, user_command: Twist | None) -> tuple[NDArray[np.float64], int]:
    """The operator's twist as the compiled call takes it, scaled within the speed limits when beyond them
    (:mod:`pfield.safety` rule 3: ``FLAG_VELOCITY_LIMITED``), and its flags."""
    if user_command is None:
        return np.zeros(6), 0
    if not isinstance(user_command, Twist):
        raise InvalidInput("user_command", user_command, "expected a pfield.Twist or None")
    config = scene.config
    assert config is not None
    user, clipped = safety.clip_twist(user_command.as_array(), config.max_linear_velocity, config.max_angular_velocity)
    return user, Flag.VELOCITY_LIMITED if clipped else 0


def _limited(outcome: int) -> int:
    """The flag of an output-contract outcome (:mod:`pfield.safety`)."""
    return (Flag.VELOCITY_LIMITED if outcome == safety.SCALED else 0) | (Flag.HALTED if outcome == safety.HALTED else 0)


def _goal_flags(scene: AssistanceScene, pose: Pose, autonomy: Twist) -> tuple[int, float]:
    """(AT_GOAL | STALLED | NO_GOAL bits, goal share of ``linear_goal``) at the end-effector ``pose``."""
    if scene.field is None:
        return Flag.NO_GOAL, 0.0
    goal, options = scene.field.goal, scene.options
    distance = pose.translation_distance(goal)
    flags = 0
    if distance <= options.goal_tolerance and pose.rotation_distance(goal) <= scene.field.config.rotation_tolerance:
        flags |= Flag.AT_GOAL
    elif math.hypot(*autonomy.linear) < options.stall_speed and math.hypot(*autonomy.angular) < options.stall_speed:
        flags |= Flag.STALLED
    return flags, min(max(1.0 - distance / options.goal_radius, 0.0), 1.0)


_FLAG_NAMES = tuple((name.lower().replace("_", " "), bit) for name, bit in vars(Flag).items()
                    if isinstance(bit, int))


def _message(flags: int, alpha: float, limited: bool) -> str:
    names = [name for name, bit in _FLAG_NAMES if flags & bit]
    action = "approach limited by the dampers" if limited else "command passed through the dampers unchanged"
    if flags & Flag.HALTED:
        action = safety.describe(safety.HALTED)
    return f"alpha {alpha:.3f}; {action}" + (f"; {', '.join(names)}" if names else "")


def _input_flags(input_age: float | None, options: AssistanceOptions) -> int:
    if input_age is None:
        return 0
    age = finite("input_age", input_age)
    return Flag.STALE_INPUT if age > options.stale_input_timeout else 0


def task_space_assistance(scene: AssistanceScene, pose: Pose, user_command: Twist | None = None,
                          arbitration: str = "", *, previous: Twist | None = None, dt: float = 0.0,
                          input_age: float | None = None) -> Assistance:
    """Assistance for an end effector at ``pose`` (the robot is the point ``pose.position``).

    ``user_command``: the operator's twist (world frame; None or zero: none); ``arbitration``: a mode of
    :data:`ARBITRATIONS` (empty: the scene's default); ``previous``/``dt``: the autonomy vector's rate limit
    (:meth:`PotentialField.twist`); ``input_age``: s since the operator's command was issued (stale flag).
    The laws run in one compiled call (``src/core/shared_control/assist``), the output contract included.
    """
    if not isinstance(pose, Pose):
        raise InvalidInput("query_pose", pose, "expected a pfield.Pose")
    mode = _mode(scene, arbitration)
    user, flags = _user_twist(scene, user_command)
    flags |= _input_flags(input_age, scene.options)
    autonomy = Twist() if scene.field is None else scene.field.twist(pose, previous, dt)
    goal_flags, goal_share = _goal_flags(scene, pose, autonomy)
    result = scene._core.assist_point(pose.position, user, autonomy.linear, autonomy.angular,  # type: ignore[attr-defined]
                                      mode, goal_share)
    return _answer(scene, result, autonomy, np.zeros(0), pose.position, flags | goal_flags | _limited(result.outcome))


def _answer(scene: AssistanceScene, result: Any, autonomy: Twist, joint_velocities: NDArray[np.float64],
            robot_point: NDArray[np.float64], flags: int) -> Assistance:
    """The answer from a compiled call's fresh result (``_core.assistance.PointAssistance`` or
    ``JointAssistance``): its vectors are read-only views of the result's own memory."""
    nearest, distance = result.nearest, result.distance
    if nearest >= 0:
        flags |= Flag.IN_COLLISION if distance <= 0.0 else 0
        flags |= Flag.NEAR_OBSTACLE if distance < scene.config.influence_distance else 0  # type: ignore[union-attr]
    alpha = result.alpha
    # the frozen answer filled in one step: its __init__ would call object.__setattr__ once per field
    answer = object.__new__(Assistance)
    answer.__dict__.update(
        autonomy_vector=autonomy, joint_velocities=joint_velocities,
        blended_command=twist_from_checked(*readonly_parts(result.blended)), alpha=alpha,
        speed_scale=result.speed_scale,
        nearest_obstacle_id=scene._ids[nearest] if nearest >= 0 else "",  # type: ignore[attr-defined]
        nearest_distance=distance, nearest_normal=result.normal, robot_point=robot_point,
        obstacle_point=result.obstacle_point, time_to_collision=result.time_to_collision, flags=flags,
        message=_message(flags, alpha, result.limited))
    return answer


# ---------------------------------------------------------------------------------------------- whole body


def _whole_body(scene: AssistanceScene, robot: RobotModel) -> Any:
    """The compiled whole-body assistance of (scene, robot) (``_core.assistance.WholeBody``: the robot's arrays,
    the scene's obstacles, the options and, with a goal, the field's step bound once; it owns its workspace)."""
    options = scene.options
    config = scene.config
    assert config is not None
    params = _core.JointParams(
        damping=options.damping, joint_limit_margin=options.joint_limit_margin,
        singularity_threshold=options.singularity_threshold, goal_tolerance=options.goal_tolerance,
        rotation_tolerance=config.rotation_tolerance, stall_speed=options.stall_speed, goal_radius=options.goal_radius)
    if scene.field is None:
        arrays = pack_robot(robot, config, WholeBodyOptions())
        return _core.WholeBody(core_robot(arrays), scene._core, params, LIMIT_TOLERANCE)  # type: ignore[attr-defined]
    # the field's step of the autonomy vector (its stepper's robot, bound once, goal and parameters): the same step
    # whole_body_autonomy takes, fused in front of the assistance
    robot_core, goal_position, goal_orientation, step_params = whole_body_stepper(scene.field, robot).bound()
    return _core.WholeBody(robot_core, scene._core, params, LIMIT_TOLERANCE,  # type: ignore[attr-defined]
                           goal_position, goal_orientation, step_params)


_WORKSPACES: Recent[Any] = Recent()
"""The compiled whole-body assistance of (scene, robot) on each thread (several scenes in turn: one per goal)."""


def _workspace(scene: AssistanceScene, robot: RobotModel) -> Any:
    """The compiled whole-body assistance of (scene, robot) for this thread."""
    return _WORKSPACES.get(scene, robot, lambda: _whole_body(scene, robot))


def _assist_step(work: Any, robot: RobotModel, joint_angles: ArrayLike, previous: ArrayLike | None, dt: float,
                 user: NDArray[np.float64], mode: Any, user_joints: NDArray[np.float64] | None = None) -> Any:
    """The field's step and the assistance on its q̇ in one compiled call (``WholeBody.step``). C-contiguous float64
    vectors go in as they are (the call checks their values: n joint angles within the limits, finite previous
    velocities); anything else, or a value the call refuses, is validated first, for its error. ``user_joints``:
    the operator's joint velocities (validated), or None for the twist ``user``."""
    try:
        result = work.step(joint_angles, previous, dt, user, mode, user_joints)
    except TypeError:  # another type (a list, a strided view, float32): the validating path converts it
        result = None
    if result is None:
        q = robot.check_joint_angles(joint_angles, "joint_angles")
        result = work.step(q, optional_vector("prev_joint_velocities", previous, robot.n_joints), dt, user, mode,
                           user_joints)
        if result is None:  # not reached: every input was checked above
            raise InvalidInput("joint_angles", joint_angles, "refused by the compiled step")
    return result


def whole_body_assistance(scene: AssistanceScene, robot: RobotModel, joint_angles: ArrayLike,
                          user_command: Twist | None = None, arbitration: str = "", *,
                          prev_joint_velocities: ArrayLike | None = None, dt: float = 0.0,
                          input_age: float | None = None,
                          user_joint_velocities: ArrayLike | None = None) -> Assistance:
    """Assistance for ``robot`` at ``joint_angles`` (whole body).

    q̇_auto from :func:`pfield.shared_control.whole_body_autonomy`; the operator's twist mapped to joints by damped
    least squares q̇_user = Jᵀ(J Jᵀ + λ² I)⁻¹ u_user, or the operator's ``user_joint_velocities`` (n, rad/s or m/s:
    a joint jog) as q̇_user itself, not both; q̇ = α q̇_auto + (1 − α) q̇_user with α from the nearest
    link clearance; then every link point's relative approach speed −n̂ᵀ(J_p q̇ − v_obs) to each obstacle within
    Q is held below the damper s(d) by the nearest q̇ (Euclidean) that holds all of them: the nearest link point's
    minimum-norm correction Δq̇ = J_pᵀ n̂ e / ‖J_pᵀ n̂‖² (e the excess) when it holds the others too (it is then
    the projection onto all of them), else the core's velocity QP over one row per link–obstacle pair within Q
    (``planning/damper_rows.hpp``, ``math/qp.hpp``).
    ``blended_command`` = J q̇; ``time_to_collision`` is that of the nearest link point under q̇_user.
    The field's step (the autonomy's q̇) and all of this run in one compiled call
    (``src/core/shared_control/assist``, the output contract included); without a goal, the assistance alone.
    """
    mode = _mode(scene, arbitration)
    step = in_range("delta_time", dt, 0.0, math.inf, "s") if dt else 0.0
    user, flags = _user_twist(scene, user_command)
    user_joints = None
    if user_joint_velocities is not None:
        if user_command is not None:
            raise InvalidInput("user_joint_velocities", user_joint_velocities,
                               "give the operator's twist (user_command) or joint velocities, not both")
        user_joints, clipped = safety.clip_joint_command(
            as_vector("user_joint_velocities", user_joint_velocities, robot.n_joints), robot.velocity_limits)
        flags |= Flag.VELOCITY_LIMITED if clipped else 0
    flags |= _input_flags(input_age, scene.options)
    work = _workspace(scene, robot)
    if scene.field is None:
        q = robot.check_joint_angles(joint_angles, "joint_angles")
        autonomy = Twist()
        result = work.assist(q, user, mode, 0.0, user_joints)  # linear_goal's share is 0 without a goal
        goal_flags = Flag.NO_GOAL
    else:
        result = _assist_step(work, robot, joint_angles, prev_joint_velocities, step, user, mode, user_joints)
        if result.autonomy_outcome == safety.HALTED:
            _LOG.warning("whole-body step: %s", safety.describe(safety.HALTED))
        autonomy = twist_from_checked(*readonly_parts(result.autonomy))
        goal_flags = (Flag.AT_GOAL if result.at_goal else 0) | (Flag.STALLED if result.stalled else 0)
    flags |= goal_flags | (Flag.AT_JOINT_LIMIT if result.at_limit else 0) | \
        (Flag.NEAR_SINGULARITY if result.singular else 0) | _limited(result.outcome)
    return _answer(scene, result, autonomy, result.joint_velocities, result.robot_point, flags)
