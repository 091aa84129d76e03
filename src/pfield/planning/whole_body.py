"""Whole-body planning: the potential field acting on every link of a robot, integrated in joint space.

``plan_whole_body(field, robot, q0, dt, goal_tolerance, max_iterations)`` starts from joint angles ``q0`` and
integrates the joint velocity of :mod:`pfield.planning._whole_body_kernel` (one compiled loop,
:mod:`pfield.planning._whole_body_loop`) until the end
effector is within ``goal_tolerance`` (m) and ``rotation_tolerance`` (rad) of the field's goal pose.

Why a damped least-squares QP rather than the plain transpose map q̇ = Jᵀ F: the transpose map moves the
end effector along J Jᵀ F, which is not the field's direction and converges at rates that differ by the
squared singular values (tens of thousands of steps in the C++ original); the damped pseudo-inverse
follows the field's twist exactly where the arm can, stays bounded near singularities, and leaves the
null space to the obstacle repulsion (mapped with each link point's Jacobian transpose). Obstacles and
self-collision enter as velocity dampers (NEO), so the arm never gets closer than ``safety_distance`` and a
goal near obstacles is still reached. See ``docs/robots.md``.

Failure reasons: ``collision`` (the start configuration collides — checked exactly with coal — or the
dampers could not keep a squeezed link off an obstacle: the plan stops *before* the contact),
``self-collision`` (likewise between link capsules), ``stagnation`` (no progress in ``stagnation_window``
s) and ``iteration limit``.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pfield._validation import finite, positive
from pfield.errors import InvalidInput
from pfield.field._evaluate import _bounding_radius
from pfield.field.config import FieldConfig
from pfield.geometry import Obstacle, pack_obstacles
from pfield.geometry._packed import PackedObstacles
from pfield.geometry._sdf import empty_packed
from pfield.planning import _whole_body_kernel as _wb
from pfield.planning import _whole_body_loop as _loop
from pfield.planning.fallback import FALLBACK_PLANNER, FIELD_PLANNER, whole_body_fallback
from pfield.planning.global_search import check_global_options
from pfield.planning.result import PlannedPath
from pfield.planning.retime import retime_joint_path
from pfield.robot.model import RobotModel
from pfield.spatial import Pose

__all__ = ["WholeBodyOptions", "joint_velocity_sign_flips", "plan_whole_body", "plan_whole_body_packed"]

_LOG = logging.getLogger(__name__)
DEFAULT_MAX_ITERATIONS = 30000


@dataclass(frozen=True)
class WholeBodyOptions:
    """Whole-body settings that are not field parameters (the field's come from :class:`FieldConfig`).

    Attributes:
        rotation_weight: w_r (m²/rad²), weight of the angular rows of the task in the QP.
        damping: λ² (−), damped least-squares regulariser; also the weight of the null-space repulsion.
        null_space_gain: scale of the Khatib repulsion used as the null-space posture preference.
        joint_influence: (rad or m) joint-limit dampers act within this distance of a limit.
        joint_safety: (rad or m) joint-limit dampers stop the joint this far inside the limit.
        acceleration_limits: (rad/s² or m/s²) per joint; ``None`` uses ``max_angular_acceleration``
            for revolute and ``max_linear_acceleration`` for prismatic joints.
    """

    rotation_weight: float = 0.5
    damping: float = 1e-3
    null_space_gain: float = 0.3
    joint_influence: float = 0.1
    joint_safety: float = 0.01
    acceleration_limits: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        for name in ("rotation_weight", "damping", "joint_influence"):
            positive(name, getattr(self, name))
        finite("null_space_gain", self.null_space_gain)
        if not 0.0 <= self.joint_safety < self.joint_influence:
            raise InvalidInput("joint_safety", self.joint_safety, "must be in [0, joint_influence)")


def obstacle_bounds(packed: PackedObstacles) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Bounding sphere (centre (M, 3), radius (M,)) of every packed obstacle, for culling."""
    radii = np.array([_bounding_radius(packed, i) for i in range(len(packed.kinds))], dtype=np.float64)
    return np.ascontiguousarray(packed.rows[:, 0:3]), radii


def pack_robot(robot: RobotModel, config: FieldConfig, options: WholeBodyOptions) -> _wb.RobotArrays:
    """The robot's kinematics, capsules and limits as the kernel's :class:`RobotArrays`."""
    k, g = robot.kinematics, robot.geometry
    if options.acceleration_limits is None:
        accel = np.where(k.kinds == 0, config.max_angular_acceleration, config.max_linear_acceleration)
    else:
        accel = np.array([positive(f"acceleration_limits[{i}]", a) for i, a in enumerate(options.acceleration_limits)])
        if accel.shape != (robot.n_joints,):
            raise InvalidInput("acceleration_limits", options.acceleration_limits, f"expected {robot.n_joints} values")
    return _wb.RobotArrays(k.parents, k.place_rot, k.place_pos, k.axes, k.kinds, k.support, k.ee_joint, k.ee_rot,
                           k.ee_pos, g.joints, g.a, g.b, g.radii, g.self_pairs, np.array(robot.lower_limits),
                           np.array(robot.upper_limits), np.array(robot.velocity_limits), accel.astype(np.float64))


def kernel_parameters(config: FieldConfig, dt: float, goal_tolerance: float, rotation_tolerance: float,
                      options: WholeBodyOptions) -> NDArray[np.float64]:
    """The kernel's parameter vector (indices in :mod:`pfield.planning._whole_body_kernel`)."""
    params = np.zeros(_wb.N_PARAMS)
    params[_wb.K_ATT], params[_wb.K_ROT] = config.attractive_gain, config.rotational_attractive_gain
    params[_wb.GAMMA], params[_wb.V_MAX] = config.attractive_threshold, config.max_linear_velocity
    params[_wb.W_MAX], params[_wb.INFLUENCE] = config.max_angular_velocity, config.influence_distance
    params[_wb.SAFETY], params[_wb.XI] = config.safety_distance, config.damper_gain
    params[_wb.ETA], params[_wb.F_CAP] = config.repulsive_gain, config.max_repulsive_force
    params[_wb.DT], params[_wb.TOL], params[_wb.ROT_TOL] = dt, goal_tolerance, rotation_tolerance
    params[_wb.STAG_STEPS] = max(1.0, math.ceil(config.stagnation_window / dt))
    params[_wb.STAG_PROGRESS] = config.stagnation_progress
    params[_wb.JOINT_INFLUENCE], params[_wb.JOINT_SAFETY] = options.joint_influence, options.joint_safety
    params[_wb.ROT_WEIGHT], params[_wb.DAMPING] = options.rotation_weight, options.damping
    params[_wb.NULL_GAIN] = options.null_space_gain
    return params


def make_scene(packed: PackedObstacles | None, robot: _wb.RobotArrays | None = None,
               q0: NDArray[np.float64] | None = None, safety_distance: float = 0.0) -> _wb.Scene:
    """Packed obstacles, their bounding spheres and the start offsets of :class:`~._whole_body_kernel.Scene`.

    With ``robot`` and ``q0``, capsule pairs that start closer than ``safety_distance`` get the offset
    ``d0 − safety_distance`` (they may not approach further); otherwise all offsets are zero.
    """
    packed = empty_packed() if packed is None else packed
    centres, radii = obstacle_bounds(packed)
    n_caps = 0 if robot is None else len(robot.cap_joint)
    n_pairs = 0 if robot is None else len(robot.self_pairs)
    scene = _wb.Scene(packed, centres, radii, np.zeros((n_caps, len(radii))), np.zeros(n_pairs))
    if robot is None or q0 is None:
        return scene
    obstacle, own = _loop.pair_distances(q0, robot, scene)
    return scene._replace(obstacle_offsets=np.minimum(obstacle - safety_distance, 0.0),
                          self_offsets=np.minimum(own - safety_distance, 0.0))


def _failure_reason(status: int, count: int, culprit: NDArray[np.int64], robot: RobotModel,
                    errors: tuple[float, float], names: list[str] | None, dt: float) -> str:
    pos_err, rot_err = errors
    state = f"position error {pos_err:.4f} m, rotation error {rot_err:.4f} rad"
    if status == _wb.COLLISION:
        link = robot.geometry.capsules[int(culprit[0])].link
        obstacle = names[int(culprit[1])] if names else f"#{int(culprit[1])}"
        return (f"collision: the next step would bring link {link!r} into contact with obstacle {obstacle!r}; "
                f"stopped at step {count - 1}")
    if status == _wb.SELF_COLLISION:
        return f"self-collision: the next step would bring two link capsules into contact; stopped at step {count - 1}"
    if status == _wb.STAGNATION:
        return (f"stagnation: no progress toward the goal within the stagnation window "
                f"({state}, t = {(count - 1) * dt:.2f} s)")
    return f"iteration limit: {count - 1} steps without reaching the goal ({state})"


def plan_whole_body_packed(config: FieldConfig, goal: Pose, packed: PackedObstacles | None, robot: RobotModel,
                           q0: ArrayLike, dt: float = 0.01, goal_tolerance: float = 0.01,
                           max_iterations: int = DEFAULT_MAX_ITERATIONS, rotation_tolerance: float | None = None,
                           options: WholeBodyOptions | None = None,
                           obstacles: Sequence[Obstacle] | None = None, *, global_fallback: bool = True,
                           global_time_limit: float | None = None) -> PlannedPath:
    """Whole-body plan against already packed obstacles (see :func:`plan_whole_body`).

    ``obstacles`` (the objects ``packed`` was made from) name obstacles in failure reasons and allow the
    exact start check: a start whose capsules are already within ``safety_distance`` of something is
    checked with coal on the robot's meshes, and a real contact fails the plan at once.
    """
    fallback, global_options = check_global_options(global_fallback, global_time_limit)
    obstacle_names = [o.id for o in obstacles] if obstacles else None
    step = positive("delta_time", dt)
    tolerance = positive("goal_tolerance", goal_tolerance)
    rot_tol = config.rotation_tolerance if rotation_tolerance is None else positive("rotation_tolerance",
                                                                                   rotation_tolerance)
    iterations = _iterations(max_iterations)
    start = robot.check_joint_angles(q0, "starting_joint_angles")
    opts = options or WholeBodyOptions()
    params = kernel_parameters(config, step, tolerance, rot_tol, opts)
    arrays = pack_robot(robot, config, opts)
    scene = make_scene(packed, arrays, start, config.safety_distance)
    touching, distance = _start_collision(robot, start, scene, obstacles)
    if touching:
        return _single_waypoint(robot, start, f"collision: the start configuration collides ({touching})", distance)
    status, count, qs, qds, pos, quats, twists, clear, culprit = _loop.plan_loop(
        start, arrays, scene, np.array(goal.position, dtype=np.float64),
        np.array(goal.orientation, dtype=np.float64), params, iterations)
    # --- global fallback: the field stopped short; search, then let the field track the found path
    planner, fallback_reason = FIELD_PLANNER, ""
    if fallback and status in (_wb.STAGNATION, _wb.ITERATION_LIMIT, _wb.COLLISION, _wb.SELF_COLLISION):
        outcome = whole_body_fallback(robot, arrays, scene, start, qs[-1].copy(), goal, params, iterations, config,
                                      obstacles, global_options)
        if outcome.loop is not None:
            status, count, qs, qds, pos, quats, twists, clear, culprit = outcome.loop
            planner = FALLBACK_PLANNER
        fallback_reason = outcome.reason
    # --- end of the global fallback
    errors = (float(np.linalg.norm(goal.position - pos[-1])), float(Pose(pos[-1], quats[-1]).rotation_distance(goal)))
    reason = "" if status == _wb.SUCCESS else _failure_reason(status, count, culprit, robot, errors,
                                                              obstacle_names, step)
    if reason and fallback_reason:
        reason = f"{reason}; {fallback_reason}"
    if reason:
        _LOG.info("whole-body plan failed: %s", reason)
    trajectory = retime_joint_path(robot.joint_names, qs, robot.velocity_limits, arrays.max_acceleration, step)
    return PlannedPath(success=status == _wb.SUCCESS, failure_reason=reason, times=np.arange(count) * step,
                       positions=pos, orientations=quats, twists=twists, clearances=clear, iterations=count - 1,
                       joint_names=robot.joint_names, joint_positions=qs, joint_velocities=qds, planner=planner,
                       trajectory=trajectory)


def _start_collision(robot: RobotModel, start: NDArray[np.float64], scene: _wb.Scene,
                     obstacles: Sequence[Obstacle] | None) -> tuple[str, float]:
    """("", ·) or (the touching pair, the exact obstacle distance) when capsules start too close and coal
    confirms a real contact."""
    if not (np.any(scene.obstacle_offsets < 0.0) or np.any(scene.self_offsets < 0.0)):
        return "", math.inf
    from pfield.robot.collision import CollisionChecker

    # only the kinds of pairs that start too close need the exact check (building obstacle shapes costs ms)
    near = list(obstacles or ()) if np.any(scene.obstacle_offsets < 0.0) else []
    report = CollisionChecker(robot, near).check(start)
    return (report.pair if report.in_collision else ""), report.distance


def _single_waypoint(robot: RobotModel, start: NDArray[np.float64], reason: str, clearance: float) -> PlannedPath:
    pose = robot.forward_kinematics(start)
    _LOG.info("whole-body plan failed: %s", reason)
    return PlannedPath(success=False, failure_reason=reason, times=np.zeros(1), positions=pose.position[None],
                       orientations=pose.orientation[None], twists=np.zeros((1, 6)), clearances=np.full(1, clearance),
                       iterations=0, joint_names=robot.joint_names, joint_positions=start[None],
                       joint_velocities=np.zeros((1, robot.n_joints)))


def _iterations(value: Any) -> int:
    try:
        number = int(value)
    except (TypeError, ValueError) as exc:
        raise InvalidInput("max_iterations", value, "must be an integer") from exc
    if number != value or number < 0:
        raise InvalidInput("max_iterations", value, "must be an integer >= 0 (0 means 30000)")
    return number or DEFAULT_MAX_ITERATIONS


def _field_parts(field: Any) -> tuple[FieldConfig, Pose, PackedObstacles | None, list[Obstacle]]:
    """(config, goal, packed obstacles, obstacles) of a :class:`~pfield.field.PotentialField`."""
    config, goal = field.config, field.goal
    if goal is None:
        raise InvalidInput("goal", None, "the field has no goal pose")
    obstacles = list(getattr(field, "obstacles", ()) or ())
    arrays = getattr(field, "arrays", None)
    packed = arrays.packed if arrays is not None else pack_obstacles(obstacles)
    return config, goal, packed, obstacles


def plan_whole_body(field: Any, robot: RobotModel, q0: ArrayLike, dt: float = 0.01, goal_tolerance: float = 0.01,
                    max_iterations: int = DEFAULT_MAX_ITERATIONS, rotation_tolerance: float | None = None,
                    options: WholeBodyOptions | None = None, *, global_fallback: bool = True,
                    global_time_limit: float | None = None) -> PlannedPath:
    """Plan in joint space from ``q0`` to the field's goal pose, every link repelled by its obstacles.

    Args:
        field: a :class:`~pfield.field.PotentialField` (config, goal and obstacles are read from it).
        robot: the robot; its joint limits, velocity limits and link capsules are used.
        q0: starting joint angles (rad / m), tree order; outside the limits → ``InvalidInput``.
        dt: integration step (s); goal_tolerance: position tolerance (m); rotation_tolerance: (rad),
            default ``config.rotation_tolerance``; max_iterations: steps, 0 means 30000.
        global_fallback: when the field stagnates, reaches the iteration limit or is squeezed against an
            obstacle (a ``collision`` the plan stopped before), search a joint path globally and let the
            field track it (:mod:`pfield.planning.fallback`); ``planner`` tells.
        global_time_limit: wall-clock limit of that search (s); None: 2 s.

    Returns:
        A :class:`PlannedPath` with joint names, positions and velocities for every waypoint (the start
        included), the end-effector poses (FK of each waypoint), twists J q̇ and link clearances (exact
        signed distance of the nearest link capsule within the influence distance, a lower bound beyond).
    """
    config, goal, packed, obstacles = _field_parts(field)
    return plan_whole_body_packed(config, goal, packed, robot, q0, dt, goal_tolerance, max_iterations,
                                  rotation_tolerance, options, obstacles, global_fallback=global_fallback,
                                  global_time_limit=global_time_limit)


def joint_velocity_sign_flips(path: PlannedPath, threshold: float = 1e-3) -> int:
    """Number of sign changes of joint velocities along ``path`` (chattering measure).

    A change counts when a joint's velocity goes from above ``threshold`` to below −``threshold`` (or the
    reverse) between consecutive waypoints where it is not within ±``threshold`` (rad/s).
    """
    if path.joint_velocities is None or len(path) < 2:
        return 0
    velocities = path.joint_velocities
    signs = np.where(np.abs(velocities) > threshold, np.sign(velocities), 0.0)
    flips = 0
    for column in signs.T:
        nonzero = column[column != 0.0]
        flips += int(np.count_nonzero(nonzero[1:] != nonzero[:-1]))
    return flips
