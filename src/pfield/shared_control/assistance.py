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
  executed command never approaches faster than the dampers allow and motion away is never slowed.
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
import math
import threading
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pfield import safety
from pfield._bound import BoundArrays
from pfield._validation import finite, in_range, kernel_vector, optional_vector
from pfield.errors import InvalidInput
from pfield.field.config import FieldConfig
from pfield.field.field import _fast_twist
from pfield.geometry import Obstacle, pack_obstacles
from pfield.geometry._sdf import empty_packed
from pfield.planning._whole_body_layout import OUT_TWIST
from pfield.planning.whole_body import obstacle_bounds
from pfield.robot.model import RobotModel
from pfield.shared_control import _assistance_kernel as _k
from pfield.shared_control.autonomy import whole_body_stepper
from pfield.spatial import Pose, Twist

__all__ = ["ARBITRATIONS", "Assistance", "AssistanceOptions", "AssistanceScene", "Flag", "task_space_assistance",
           "whole_body_assistance"]

ARBITRATIONS = ("linear", "linear_goal", "safety_only")
_TWIST = slice(*OUT_TWIST)
_MODES = {name: i for i, name in enumerate(ARBITRATIONS)}


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
        params = np.zeros(_k.N_PARAMS)
        params[_k.INFLUENCE], params[_k.SAFETY] = config.influence_distance, config.safety_distance
        params[_k.GAIN], params[_k.MAX_SPEED] = config.damper_gain, config.max_linear_velocity
        params[_k.MAX_ACCELERATION] = config.max_linear_acceleration
        params[_k.SCALE_THRESHOLD] = self.options.scene_threshold
        object.__setattr__(self, "_packed", packed)
        object.__setattr__(self, "_bounds", obstacle_bounds(packed))
        object.__setattr__(self, "_table", table)
        object.__setattr__(self, "_params", params)
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


def _goal_flags(scene: AssistanceScene, pose: Pose, autonomy: NDArray[np.float64]) -> tuple[int, float]:
    """(AT_GOAL | STALLED | NO_GOAL bits, goal share of ``linear_goal``) at the end-effector ``pose``."""
    if scene.field is None:
        return Flag.NO_GOAL, 0.0
    goal, options = scene.field.goal, scene.options
    distance = pose.translation_distance(goal)
    flags = 0
    if distance <= options.goal_tolerance and pose.rotation_distance(goal) <= scene.field.config.rotation_tolerance:
        flags |= Flag.AT_GOAL
    elif math.hypot(*autonomy[:3]) < options.stall_speed and math.hypot(*autonomy[3:]) < options.stall_speed:
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
    """
    if not isinstance(pose, Pose):
        raise InvalidInput("query_pose", pose, "expected a pfield.Pose")
    mode = _mode(scene, arbitration)
    user, flags = _user_twist(scene, user_command)
    flags |= _input_flags(input_age, scene.options)
    autonomy = Twist() if scene.field is None else scene.field.twist(pose, previous, dt)
    auto = autonomy.as_array()
    goal_flags, goal_share = _goal_flags(scene, pose, auto)
    params = scene._params.copy()  # type: ignore[attr-defined]
    params[_k.MODE], params[_k.GOAL_SHARE] = mode, goal_share
    out = np.empty(_k.N_OUT)
    _k.assist_point(pose.position, scene._packed, scene.velocity_table, user, auto, params, out)  # type: ignore[attr-defined]
    config = scene.config
    assert config is not None
    flags |= _limited(safety.limit_twist(out[_k.BLENDED:_k.BLENDED + 6], config.max_linear_velocity,
                                         config.max_angular_velocity))
    return _answer(scene, out, autonomy, np.zeros(0), pose.position, flags | goal_flags)


def _answer(scene: AssistanceScene, out: NDArray[np.float64], autonomy: Twist, joint_velocities: NDArray[np.float64],
            robot_point: NDArray[np.float64], flags: int) -> Assistance:
    """The answer from a compiled call's fresh ``out``: its vectors are read-only views of it; the scalars
    come through one tolist() (exact float64 values); the obstacle point p − d n̂ in the same IEEE operations
    as the array expression, without numpy's per-operation overhead."""
    out.setflags(write=False)
    values = out.tolist()
    nearest, distance = int(values[_k.NEAREST]), values[_k.DISTANCE]
    point = robot_point.tolist()
    if nearest >= 0:
        flags |= Flag.IN_COLLISION if distance <= 0.0 else 0
        flags |= Flag.NEAR_OBSTACLE if distance < scene.config.influence_distance else 0  # type: ignore[union-attr]
        n0, n1, n2 = values[_k.NORMAL], values[_k.NORMAL + 1], values[_k.NORMAL + 2]
        obstacle_point = np.array((point[0] - distance * n0, point[1] - distance * n1, point[2] - distance * n2))
    else:
        obstacle_point = np.array(point)
    alpha = values[_k.ALPHA]
    # the frozen answer filled in one step: its __init__ would call object.__setattr__ once per field
    answer = object.__new__(Assistance)
    answer.__dict__.update(
        autonomy_vector=autonomy, joint_velocities=joint_velocities,
        blended_command=_fast_twist(out[_k.BLENDED:_k.BLENDED + 6]), alpha=alpha, speed_scale=values[_k.SCALE],
        nearest_obstacle_id=scene._ids[nearest] if nearest >= 0 else "",  # type: ignore[attr-defined]
        nearest_distance=distance, nearest_normal=out[_k.NORMAL:_k.NORMAL + 3], robot_point=robot_point,
        obstacle_point=obstacle_point, time_to_collision=values[_k.TTC], flags=flags,
        message=_message(flags, alpha, values[_k.LIMITED] > 0))
    return answer


# ---------------------------------------------------------------------------------------------- whole body


class _Workspace:
    """The arrays of :func:`pfield.shared_control._assistance_kernel.bound_assist` for one (scene, robot), bound once.

    Slots: the robot's kinematics (0–8), its link model (9–17), the scene's packed obstacles (18–25), the
    joint limits (26, 27), obstacle centres, bounding radii and velocities (28–30), then the workspace:
    joint frames (31, 32), Jacobians (33, 34), world segments (35–38), scratch (39).
    """

    def __init__(self, scene: AssistanceScene, robot: RobotModel) -> None:
        n, g, k = robot.n_joints, robot.geometry, robot.kinematics
        self.scene, self.robot = scene, robot
        links, prims = len(g.joints), len(g.prim_r)
        centres, bounds = scene._bounds  # type: ignore[attr-defined]
        arrays = [k.parents, k.place_rot, k.place_pos, k.axes, k.kinds, k.support, np.array([k.ee_joint]), k.ee_rot,
                  k.ee_pos, g.joints, g.a, g.b, g.radii, g.link_start, g.prim_joint, g.prim_a, g.prim_b, g.prim_r,
                  *scene._packed, robot.lower_limits, robot.upper_limits, centres, bounds,  # type: ignore[attr-defined]
                  scene.velocity_table, np.empty((n, 3, 3)), np.empty((n, 3)), np.empty((6, n)), np.empty((3, n)),
                  np.empty((links, 3)), np.empty((links, 3)), np.empty((prims, 3)), np.empty((prims, 3)),
                  np.empty((2, 3))]
        self._bound = BoundArrays([np.ascontiguousarray(a) for a in arrays])
        self.table = self._bound.table
        self.zeros = np.zeros(n)
        # the parameter vector of the compiled call: the scene's, then the whole-body options (MODE and
        # GOAL_SHARE are written per call)
        options = scene.options
        self.params = np.zeros(_k.N_PARAMS_WHOLE_BODY)
        self.params[:_k.N_PARAMS] = scene._params  # type: ignore[attr-defined]
        self.params[_k.DAMPING], self.params[_k.LIMIT_MARGIN] = options.damping, options.joint_limit_margin
        self.params[_k.SINGULARITY], self.params[_k.STALL_SPEED] = options.singularity_threshold, options.stall_speed
        self.params[_k.GOAL_TOLERANCE], self.params[_k.GOAL_RADIUS] = options.goal_tolerance, options.goal_radius
        self.params[_k.HINT_LINK] = self.params[_k.HINT_OBSTACLE] = -1.0  # none: bound_assist_step sets them
        if scene.field is not None:
            self.params[_k.ROTATION_TOLERANCE] = scene.field.config.rotation_tolerance
            self.stepper = whole_body_stepper(scene.field, robot)


_CACHE = threading.local()


def _workspace(scene: AssistanceScene, robot: RobotModel) -> _Workspace:
    """The bound workspace of (scene, robot) for this thread (the last one used is kept)."""
    entry: _Workspace | None = getattr(_CACHE, "entry", None)
    if entry is None or entry.scene is not scene or entry.robot is not robot:
        entry = _CACHE.entry = _Workspace(scene, robot)
    return entry


def _assist_step(work: _Workspace, robot: RobotModel, joint_angles: ArrayLike, previous: ArrayLike | None,
                 dt: float, user: NDArray[np.float64], qd: NDArray[np.float64],
                 out: NDArray[np.float64]) -> NDArray[np.float64]:
    """The step's row, with ``qd`` and ``out`` filled by one compiled call
    (:func:`pfield.shared_control._assistance_kernel.bound_assist_step`). Kernel vectors
    (:func:`pfield._validation.kernel_vector`) go in as they are (the call checks their values); anything else
    is validated first, and a value the call refuses is validated again for its error."""
    for attempt in range(2):
        fast = kernel_vector(joint_angles) and (previous is None or kernel_vector(previous))
        if attempt or not fast:
            joint_angles = robot.check_joint_angles(joint_angles, "joint_angles")
            previous = optional_vector("prev_joint_velocities", previous, robot.n_joints)
        given = previous is not None
        if given and len(previous) == robot.n_joints:  # type: ignore[arg-type]
            # rule 3 of pfield.safety (a NaN stays, for the compiled check to refuse)
            previous = safety.clip_joint_velocities(previous, robot.velocity_limits)  # type: ignore[arg-type]
        row: NDArray[np.float64] = _k.bound_assist_step(
            joint_angles, previous if given else work.zeros, given, given and dt > 0.0,
            work.stepper.bound_table(dt), user, work.params, qd, out, work.table)
        if row.shape[0]:
            return row
    raise InvalidInput("joint_angles", joint_angles, "refused by the compiled step")  # not reached: checked above


def whole_body_assistance(scene: AssistanceScene, robot: RobotModel, joint_angles: ArrayLike,
                          user_command: Twist | None = None, arbitration: str = "", *,
                          prev_joint_velocities: ArrayLike | None = None, dt: float = 0.0,
                          input_age: float | None = None) -> Assistance:
    """Assistance for ``robot`` at ``joint_angles`` (whole body).

    q̇_auto from :func:`pfield.shared_control.whole_body_autonomy`; the operator's twist mapped to joints by damped
    least squares q̇_user = Jᵀ(J Jᵀ + λ² I)⁻¹ u_user; q̇ = α q̇_auto + (1 − α) q̇_user with α from the nearest
    link clearance; then the nearest link point's relative approach speed −n̂ᵀ(J_p q̇ − v_obs) is held below
    the damper by the minimum-norm correction Δq̇ = J_pᵀ n̂ e / ‖J_pᵀ n̂‖² (e the excess).
    ``blended_command`` = J q̇; ``time_to_collision`` is that of the nearest link point under q̇_user.
    The field's step (the autonomy's q̇) and all of this run in one compiled call
    (:func:`pfield.shared_control._assistance_kernel.bound_assist_step`); without a goal, the assistance alone.
    """
    mode = _mode(scene, arbitration)
    step = in_range("delta_time", dt, 0.0, math.inf, "s") if dt else 0.0
    user, flags = _user_twist(scene, user_command)
    flags |= _input_flags(input_age, scene.options)
    work = _workspace(scene, robot)
    params = work.params
    params[_k.MODE] = mode
    qd, out = np.empty(robot.n_joints), np.empty(_k.N_OUT_WHOLE_BODY)
    if scene.field is None:
        q = robot.check_joint_angles(joint_angles, "joint_angles")
        autonomy = Twist()
        goal_flags, params[_k.GOAL_SHARE] = _goal_flags(scene, robot.forward_kinematics(q), autonomy.as_array())
        _k.bound_assist(q, work.zeros, user, params, qd, out, work.table)
    else:
        row = work.stepper.limited(_assist_step(work, robot, joint_angles, prev_joint_velocities, step, user, qd, out))
        autonomy = _fast_twist(row[_TWIST])
        goal_flags = (Flag.AT_GOAL if out[_k.AT_GOAL] else 0) | (Flag.STALLED if out[_k.STALLED] else 0)
    flags |= goal_flags | (Flag.AT_JOINT_LIMIT if out[_k.AT_LIMIT] else 0) | \
        (Flag.NEAR_SINGULARITY if out[_k.SINGULAR] else 0)
    config = scene.config
    assert config is not None
    flags |= _limited(safety.limit_joint_command(qd, out[_k.BLENDED:_k.BLENDED + 6], robot.velocity_limits,
                                                 config.max_linear_velocity, config.max_angular_velocity))
    return _answer(scene, out, autonomy, qd, out[_k.POINT:_k.POINT + 3], flags)
