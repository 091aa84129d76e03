"""Whole-body planning: the potential field acting on every link of a robot, integrated in joint space.

``plan_whole_body(field, robot, q0, dt, goal_tolerance, max_iterations)`` starts from joint angles ``q0`` and
integrates the joint velocity of the compiled core (``src/core/planning/whole_body``: one call per plan, through
:mod:`pfield.planning._whole_body_core`) until the end effector is within ``goal_tolerance`` (m) and
``rotation_tolerance`` (rad) of the field's goal pose.

Why a damped least-squares QP rather than the plain transpose map q̇ = Jᵀ F: the transpose map moves the
end effector along J Jᵀ F, which is not the field's direction and converges at rates that differ by the
squared singular values (tens of thousands of steps in the C++ original); the damped pseudo-inverse
follows the field's twist exactly where the arm can, stays bounded near singularities, and leaves the
null space to the obstacle repulsion (mapped with each link point's Jacobian transpose). Obstacles and
self-collision enter as velocity dampers (NEO), so the arm never gets closer than ``safety_distance`` and a
goal near obstacles is still reached. See ``docs/robots.md``.

Outcomes (:class:`~pfield.planning.PlanStatus` on the path, the sentence in ``failure_reason`` naming the
blocking link and obstacle or the two links, their distance and where): START_INVALID (the start
configuration collides — checked exactly with coal before anything else), GOAL_INVALID (likewise a given goal
configuration), COLLISION (the dampers could not keep a squeezed link
off an obstacle: the plan stops *before* the contact), SELF_COLLISION (likewise between link capsules),
STAGNATION (the rule of :class:`~pfield.planning.PlanOptions`), ITERATION_LIMIT and CANCELLED.

Never a collision reported as reached: a motion that reaches the goal — the field's own, or the global
fallback's — is reported REACHED only after it passes the certificate (:func:`pfield.planning.certify.certify_path`:
the exact meshes, obstacles and self pairs, every waypoint and every 0.01 rad between). When the field's own motion
fails it, the global fallback (if on) plans from the start; otherwise the plan ends with COLLISION or
SELF_COLLISION, naming the pair, and its path stops before the contact.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pfield._validation import finite, nonnegative, positive
from pfield.errors import InvalidInput
from pfield.field.config import FieldConfig
from pfield.geometry import Obstacle, empty_packed, pack_obstacles
from pfield.geometry.packed import PackedObstacles, bounding_radius
from pfield.planning import _whole_body_core as _core_loop
from pfield.planning import _whole_body_layout as _wb
from pfield.planning.cancel import cancel_flag
from pfield.planning.certify import certify_path
from pfield.planning.fallback import FALLBACK_PLANNER, FIELD_PLANNER, whole_body_fallback
from pfield.planning.global_search import GlobalOptions, nearest_equivalent
from pfield.planning.options import PlanOptions
from pfield.planning.result import PlannedPath
from pfield.planning.retime import retime_joint_path
from pfield.planning.status import ROOT_CAUSES, PlanStatus
from pfield.robot.collision import CollisionChecker
from pfield.robot.limits import missing_velocity_limit
from pfield.robot.model import RobotModel
from pfield.spatial import Pose

__all__ = ["WholeBodyOptions", "core_robot", "joint_velocity_sign_flips", "plan_whole_body", "plan_whole_body_packed"]

core_robot = _core_loop.core_robot
"""The core's robot of :func:`pack_robot`'s arrays (read in place), bound once per arrays: what a compiled consumer
of a robot (the whole-body assistance) takes."""

_LOG = logging.getLogger(__name__)

JOINT_GOAL_TOLERANCE = 0.1
"""rad (or m): how far from a joint goal (``goal_configuration``) a plan may end on any joint and count as reached.
The field is attracted by the goal's pose, and the pose tolerances leave the joints that much room (the UR5's
MotionBenchMaker plans: 0.009-0.062 rad); a redundant arm's other posture or another IK branch at the same pose (the
Panda's box and bookshelf problems without the posture term of :attr:`WholeBodyOptions.posture_gain`: 0.7 and 5.4
rad, median; the UR5's flipped wrists: 2.7-4.1 rad) is not the configuration asked for, so the global fallback
searches to it."""


@dataclass(frozen=True)
class WholeBodyOptions:
    """Whole-body settings that are not field parameters (the field's come from :class:`FieldConfig`).

    Attributes:
        rotation_weight: w_r (m²/rad²), weight of the angular rows of the task in the QP.
        damping: λ² (−), damped least-squares regulariser; also the weight of the null-space repulsion.
        null_space_gain: scale of the Khatib repulsion used as the null-space posture preference.
        joint_influence: (rad or m) joint-limit dampers act within this distance of a limit.
        joint_safety: (rad or m) joint-limit dampers stop the joint this far inside the limit.
        posture_gain: (1/s, ≥ 0) with a joint goal (``goal_configuration``), the field's steps are drawn toward it
            at ``posture_gain · (q_goal − q)`` through the null-space channel (the damped least squares' free
            term, beside the repulsion), so a redundant arm approaching the goal pose also approaches the posture
            asked for; 0 turns it off. It moves only what the task leaves free: a 6-joint arm away from
            singularities is not affected. The plan still ends when the pose is reached (the joints are not
            corrected after it: beyond :data:`JOINT_GOAL_TOLERANCE` the global fallback searches).
        acceleration_limits: (rad/s² or m/s²) per joint, of the planner's steps and of the retimed trajectory;
            ``None``: the steps use ``max_angular_acceleration`` (revolute) and ``max_linear_acceleration``
            (prismatic), the trajectory :attr:`RobotModel.acceleration_limits`.
    """

    rotation_weight: float = 0.5
    damping: float = 1e-3
    null_space_gain: float = 0.3
    joint_influence: float = 0.1
    joint_safety: float = 0.01
    posture_gain: float = 1.0
    """Measured on the Panda's MotionBenchMaker problems (issue 34; 40 of box, 100 of bookshelf_small), gains 0, 0.5,
    1, 2: the field alone reached the joint goal on 4, 22, 34, 38 of box (median 7.9, 4.3, 3.9, 3.7 ms) and 2, 17,
    31, 35 of bookshelf_small (p95 154, 94, 95, 94 ms), the median joint path on bookshelf_small 4.93, 4.90, 5.16,
    5.39 rad; the UR5's (6 joints) unchanged. The pull is not capped: at half or a quarter of each joint's velocity
    limit the bookshelf_small p95 was 133 and 136 ms. The plans' median smallest link-model clearance, gain 0 → 1:
    box 12.3 → 17.6 mm, bookshelf_small 10.0 → 7.3 mm (the field's own motions, certified on the meshes as every
    reached plan)."""
    acceleration_limits: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        for name in ("rotation_weight", "damping", "joint_influence"):
            positive(name, getattr(self, name))
        finite("null_space_gain", self.null_space_gain)
        nonnegative("posture_gain", self.posture_gain)
        if not 0.0 <= self.joint_safety < self.joint_influence:
            raise InvalidInput("joint_safety", self.joint_safety, "must be in [0, joint_influence)")


def obstacle_bounds(packed: PackedObstacles) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Bounding sphere (centre (M, 3), radius (M,)) of every packed obstacle, for culling."""
    radii = np.array([bounding_radius(packed, i) for i in range(len(packed.kinds))], dtype=np.float64)
    return np.ascontiguousarray(packed.rows[:, 0:3]), radii


def pack_robot(robot: RobotModel, config: FieldConfig, options: WholeBodyOptions) -> _wb.RobotArrays:
    """The robot's kinematics, link model and limits as the kernel's :class:`RobotArrays` (the one door of whole-body
    plans, steppers and assistance: a joint without a velocity limit is refused here, naming it), with the robot's
    self-pair tables (:func:`pfield.planning._whole_body_core.pair_tables`, made once per robot; only the global
    search's state check asks them)."""
    missing = missing_velocity_limit(robot.joint_names, robot.velocity_limits, robot.urdf_path.name)
    if missing:
        raise InvalidInput("robot", robot.name, missing)
    k, g = robot.kinematics, robot.geometry
    if options.acceleration_limits is None:
        accel = np.where(k.kinds == 0, config.max_angular_acceleration, config.max_linear_acceleration)
    else:
        accel = np.array([positive(f"acceleration_limits[{i}]", a) for i, a in enumerate(options.acceleration_limits)])
        if accel.shape != (robot.n_joints,):
            raise InvalidInput("acceleration_limits", options.acceleration_limits, f"expected {robot.n_joints} values")
    arrays = _wb.RobotArrays(k.parents, k.place_rot, k.place_pos, k.axes, k.kinds, k.support, k.ee_joint, k.ee_rot,
                             k.ee_pos, g.joints, g.a, g.b, g.radii, g.self_pairs, np.array(robot.lower_limits),
                             np.array(robot.upper_limits), np.array(robot.velocity_limits), accel.astype(np.float64),
                             g.link_start, g.prim_joint, g.prim_a, g.prim_b, g.prim_r, g.self_radii)
    return arrays._replace(pair_tables=_core_loop.pair_tables(robot, arrays))


def kernel_parameters(config: FieldConfig, plan: PlanOptions, options: WholeBodyOptions) -> NDArray[np.float64]:
    """The kernel's parameter vector (layout ``PARAMS`` of :mod:`pfield.planning._whole_body_layout`).

    ``plan`` must be resolved against ``config`` (:meth:`PlanOptions.resolved`)."""
    assert plan.rotation_tolerance is not None and plan.stagnation_progress is not None
    return _wb.PARAMS.pack({
        "attractive_gain": config.attractive_gain, "rotational_attractive_gain": config.rotational_attractive_gain,
        "attractive_threshold": config.attractive_threshold, "max_linear_velocity": config.max_linear_velocity,
        "max_angular_velocity": config.max_angular_velocity, "influence_distance": config.influence_distance,
        "safety_distance": config.safety_distance, "damper_gain": config.damper_gain,
        "repulsive_gain": config.repulsive_gain, "max_repulsive_force": config.max_repulsive_force,
        "dt": plan.dt, "goal_tolerance": plan.goal_tolerance, "rotation_tolerance": plan.rotation_tolerance,
        "stagnation_steps": plan.stagnation_steps, "stagnation_progress": plan.stagnation_progress,
        "joint_influence": options.joint_influence, "joint_safety": options.joint_safety,
        "rotation_weight": options.rotation_weight, "damping": options.damping,
        "null_space_gain": options.null_space_gain,
    })


def make_scene(packed: PackedObstacles | None, robot: _wb.RobotArrays | None = None,
               q0: NDArray[np.float64] | None = None, safety_distance: float = 0.0) -> _wb.Scene:
    """Packed obstacles, their bounding spheres and the start offsets of :class:`~._whole_body_layout.Scene`.

    With ``robot`` and ``q0``, link pairs that start closer than ``safety_distance`` get the offset
    ``d0 − safety_distance`` (they may not approach further); otherwise all offsets are zero.
    """
    packed = empty_packed() if packed is None else packed
    centres, radii = obstacle_bounds(packed)
    n_caps = 0 if robot is None else len(robot.cap_joint)
    n_pairs = 0 if robot is None else len(robot.self_pairs)
    scene = _wb.Scene(packed, centres, radii, np.zeros((n_caps, len(radii))), np.zeros(n_pairs))
    if robot is None or q0 is None:
        return scene
    obstacle, own = _core_loop.pair_distances(q0, robot, scene, safety_distance)  # exact where an offset is set
    return scene._replace(obstacle_offsets=np.minimum(obstacle - safety_distance, 0.0),
                          self_offsets=np.minimum(own - safety_distance, 0.0))


def _failure_reason(status: PlanStatus, count: int, culprit: NDArray[np.float64], robot: RobotModel,
                    errors: tuple[float, float], names: list[str] | None, dt: float, influence: float) -> str:
    """The sentence beside ``status``: the blocking link and obstacle (or the two links), their distance
    and where (the time and the end effector's remaining errors). Beyond the influence distance the step
    knows a pair's distance only as a lower bound, and says so."""
    pos_err, rot_err = errors
    capsules = robot.geometry.capsules
    where = f"at t = {(count - 1) * dt:.2f} s, position error {pos_err:.4f} m, rotation error {rot_err:.4f} rad"
    capsule, obstacle, distance, pair, self_distance = (float(v) for v in culprit)
    blocking = ""
    if capsule >= 0 and obstacle >= 0:
        obstacle_name = names[int(obstacle)] if names else f"#{int(obstacle)}"
        bound = "at least " if distance >= influence else ""
        blocking = f"link {capsules[int(capsule)].link!r} is {bound}{distance:.4f} m from obstacle {obstacle_name!r}"
    self_links = ""
    if pair >= 0:
        first, second = (int(c) for c in robot.geometry.self_pairs[int(pair)])
        self_links = f"links {capsules[first].link!r} and {capsules[second].link!r} are {self_distance:.4f} m apart"
    if status == PlanStatus.COLLISION:
        return f"collision: the next step would bring {blocking or 'a link'} into contact; stopped at step {count - 1}"
    if status == PlanStatus.SELF_COLLISION:
        return (f"self-collision: the next step would bring {self_links or 'two links'} into contact; "
                f"stopped at step {count - 1}")
    nearest = "; ".join(part for part in (blocking, self_links) if part) or "no obstacle or link pair within reach"
    if status == PlanStatus.STAGNATION:
        return f"stagnation: no progress toward the goal within the stagnation window ({where}; nearest: {nearest})"
    if status == PlanStatus.CANCELLED:
        return f"cancelled after {count - 1} steps ({where})"
    return f"iteration limit: {count - 1} steps without reaching the goal ({where}; nearest: {nearest})"


def plan_whole_body_packed(config: FieldConfig, goal: Pose, packed: PackedObstacles | None, robot: RobotModel,
                           q0: ArrayLike, dt: float | None = None, goal_tolerance: float | None = None,
                           max_iterations: int | None = None, rotation_tolerance: float | None = None,
                           options: WholeBodyOptions | None = None,
                           obstacles: Sequence[Obstacle] | None = None, *, global_fallback: bool | None = None,
                           global_time_limit: float | None = None, plan_options: PlanOptions | None = None,
                           goal_configuration: ArrayLike | None = None) -> PlannedPath:
    """Whole-body plan against already packed obstacles (see :func:`plan_whole_body`).

    ``obstacles`` (the objects ``packed`` was made from) name obstacles in failure reasons and are what the
    exact checks (coal on the robot's meshes) test against: a start (or given goal configuration) in contact
    fails the plan at once (START_INVALID, GOAL_INVALID), and a reached motion must pass the certificate.
    Packed obstacles without their objects → ``InvalidInput`` (nothing could certify a motion among them).
    """
    settings = PlanOptions.build(plan_options, dt=dt, goal_tolerance=goal_tolerance, max_iterations=max_iterations,
                                 rotation_tolerance=rotation_tolerance, global_fallback=global_fallback,
                                 global_time_limit=global_time_limit).resolved(config)
    obstacle_names = [o.id for o in obstacles] if obstacles else None
    if obstacles is None and packed is not None and len(packed.kinds) > 0:
        raise InvalidInput("obstacles", None, "give the Obstacle objects the packed obstacles were made from: "
                           "the certificate checks every reached motion against them on the exact meshes")
    start = robot.check_joint_angles(q0, "starting_joint_angles")
    goal_q = None if goal_configuration is None else _goal_configuration(robot, goal, goal_configuration, settings,
                                                                         start)
    opts = options or WholeBodyOptions()
    params = kernel_parameters(config, settings, opts)
    arrays = pack_robot(robot, config, opts)
    scene = make_scene(packed, arrays, start, config.safety_distance)
    checker = CollisionChecker(robot, list(obstacles or ()))
    invalid = _endpoint_collision(checker, start, goal_q)
    if invalid is not None:
        return _single_waypoint(robot, start, *invalid)
    cancel = cancel_flag(settings.cancel)
    status, count, qs, qds, pos, quats, twists, clear, culprit = _core_loop.plan_loop(
        start, arrays, scene, np.array(goal.position, dtype=np.float64),
        np.array(goal.orientation, dtype=np.float64), params, settings.max_iterations, cancel,
        goal_q, opts.posture_gain)
    certificate_reason = ""
    # a joint goal first: a motion that ends in another configuration goes to the fallback, and is certified only if
    # it is what the plan returns (the fallback found nothing), not before
    joint_off = False
    if status == PlanStatus.REACHED and goal_q is not None:
        off = float(np.max(np.abs(qs[-1] - goal_q)))
        if off > JOINT_GOAL_TOLERANCE:  # the goal pose, but not the configuration asked for: search to that one
            status, joint_off = PlanStatus.STAGNATION, True
            certificate_reason = (f"the field reached the goal pose in another configuration than the joint goal "
                                  f"(a joint {off:.3g} rad from it, beyond {JOINT_GOAL_TOLERANCE:g})")
            _LOG.info("whole-body plan: %s", certificate_reason)

    def cut_at_contact() -> PlanStatus | None:
        """The planner's certificate of the field's motion (the exact meshes): at a contact the path ends before it
        (at the waypoint before, the start at least), the reason says so, and the contact's status is returned;
        None when clear."""
        nonlocal certificate_reason, count, qs, qds, pos, quats, twists, clear
        certificate = certify_path(robot, list(obstacles or ()), qs, checker=checker)
        if certificate.clear:
            return None
        certificate_reason = certificate.describe()
        _LOG.info("whole-body plan: the field's motion fails the certificate: %s", certificate_reason)
        count = max(1, certificate.waypoint + (1 if certificate.fraction > 0.0 else 0))
        qs, qds, pos, quats, twists, clear = (a[:count] for a in (qs, qds, pos, quats, twists, clear))
        return PlanStatus.SELF_COLLISION if certificate.self_collision else PlanStatus.COLLISION

    if status == PlanStatus.REACHED:
        status = cut_at_contact() or status
    # --- global fallback: the field stopped short (or its motion failed the certificate, or ended in another
    # configuration than the joint goal); search, then let the field track the found path (the fallback certifies
    # its own motion)
    planner, fallback_reason, field_status = FIELD_PLANNER, "", status
    if settings.global_fallback and status in (PlanStatus.STAGNATION, PlanStatus.ITERATION_LIMIT,
                                               PlanStatus.COLLISION, PlanStatus.SELF_COLLISION):
        outcome = whole_body_fallback(robot, arrays, scene, start, qs[-1].copy(), goal, params,
                                      settings.max_iterations, config, obstacles,
                                      GlobalOptions(time_limit=settings.global_time_limit, seed=settings.global_seed),
                                      cancel, goal_q, checker)
        if outcome.loop is not None:
            status, count, qs, qds, pos, quats, twists, clear, culprit = outcome.loop
            planner = FALLBACK_PLANNER
        else:
            status, fallback_reason = outcome.status, outcome.reason
    # --- end of the global fallback
    if joint_off and planner == FIELD_PLANNER:  # the field's motion is what a failed plan returns: certified too
        contact = cut_at_contact()
        if contact is not None and not fallback_reason:  # a fallback that ran keeps its status, as for any motion
            status = contact
    errors = (float(np.linalg.norm(goal.position - pos[-1])), float(Pose(pos[-1], quats[-1]).rotation_distance(goal)))
    reason = "" if status == PlanStatus.REACHED else (certificate_reason or _failure_reason(
        field_status, count, culprit, robot, errors, obstacle_names, settings.dt, config.influence_distance))
    if reason and fallback_reason:  # the root cause first: a goal no search can reach explains the field's stop
        root_first = status in ROOT_CAUSES
        reason = f"{fallback_reason}; {reason}" if root_first else f"{reason}; {fallback_reason}"
    if reason:
        _LOG.info("whole-body plan failed: %s", reason)
    # the trajectory's accelerations: the robot's (joint_limits.yaml or the documented defaults) unless the
    # options set the planner's joint limits explicitly
    retime_limits = robot.acceleration_limits if opts.acceleration_limits is None else arrays.max_acceleration
    trajectory = retime_joint_path(robot.joint_names, qs, robot.velocity_limits, retime_limits, settings.dt)
    return PlannedPath(success=status == PlanStatus.REACHED, failure_reason=reason,
                       times=np.arange(count) * settings.dt, positions=pos, orientations=quats, twists=twists,
                       clearances=clear, iterations=count - 1, joint_names=robot.joint_names, joint_positions=qs,
                       joint_velocities=qds, status=status, planner=planner, trajectory=trajectory)


def _goal_configuration(robot: RobotModel, goal: Pose, values: ArrayLike, settings: PlanOptions,
                        start: NDArray[np.float64]) -> NDArray[np.float64]:
    """``values`` checked as a goal configuration: within the joint limits, and its end effector at ``goal``
    within the plan's tolerances. A continuous joint's value (no limits) is taken as the angle of the same rotation
    nearest its ``start`` value, as MoveIt compares continuous joints: the field's pull, the reached check and the
    search then turn it the short way (a goal 2π from the start is the start's own rotation, not a full turn).
    Joints with limits keep the value asked for."""
    q = robot.check_joint_angles(values, "goal_configuration")
    reached = robot.forward_kinematics(q)
    position_error = float(np.linalg.norm(reached.position - goal.position))
    rotation_error = float(reached.rotation_distance(goal))
    assert settings.rotation_tolerance is not None
    if position_error > settings.goal_tolerance or rotation_error > settings.rotation_tolerance:
        raise InvalidInput("goal_configuration", q.tolist(),
                           f"its end effector is {position_error:.4g} m and {rotation_error:.4g} rad from the goal "
                           f"pose (tolerances {settings.goal_tolerance:g} m, {settings.rotation_tolerance:g} rad); "
                           "give a configuration at the goal, or none to let the planner solve the IK")
    return nearest_equivalent(robot, q, start, continuous_only=True)


def _endpoint_collision(checker: CollisionChecker, start: NDArray[np.float64], goal: NDArray[np.float64] | None
                        ) -> tuple[str, float, PlanStatus] | None:
    """(reason, exact distance, status) when the start (START_INVALID) or the given goal configuration
    (GOAL_INVALID) is in contact on the exact meshes (obstacles or a self pair), naming the pair; else None."""
    for q, status, what in ((start, PlanStatus.START_INVALID, "start"), (goal, PlanStatus.GOAL_INVALID, "goal")):
        if q is None:
            continue
        report = checker.contact(q)
        if report is not None:
            kind = "self-collision" if report.self_distance <= report.distance else "collision"
            distance = min(report.distance, report.self_distance)
            return (f"{kind}: the {what} configuration collides ({report.pair}, exact mesh distance "
                    f"{distance * 1e3:.2f} mm)", report.distance, status)
    return None


def _single_waypoint(robot: RobotModel, start: NDArray[np.float64], reason: str, clearance: float,
                     status: PlanStatus = PlanStatus.START_INVALID) -> PlannedPath:
    pose = robot.forward_kinematics(start)
    _LOG.info("whole-body plan failed: %s", reason)
    return PlannedPath(success=False, failure_reason=reason, times=np.zeros(1), positions=pose.position[None],
                       orientations=pose.orientation[None], twists=np.zeros((1, 6)), clearances=np.full(1, clearance),
                       iterations=0, joint_names=robot.joint_names, joint_positions=start[None],
                       joint_velocities=np.zeros((1, robot.n_joints)), status=status)


def _field_parts(field: Any) -> tuple[FieldConfig, Pose, PackedObstacles | None, list[Obstacle]]:
    """(config, goal, packed obstacles, obstacles) of a :class:`~pfield.field.PotentialField`."""
    config, goal = field.config, field.goal
    if goal is None:
        raise InvalidInput("goal", None, "the field has no goal pose")
    obstacles = list(getattr(field, "obstacles", ()) or ())
    arrays = getattr(field, "arrays", None)
    packed = arrays.packed if arrays is not None else pack_obstacles(obstacles)
    return config, goal, packed, obstacles


def plan_whole_body(field: Any, robot: RobotModel, q0: ArrayLike, dt: float | None = None,
                    goal_tolerance: float | None = None, max_iterations: int | None = None,
                    rotation_tolerance: float | None = None, options: WholeBodyOptions | None = None, *,
                    global_fallback: bool | None = None, global_time_limit: float | None = None,
                    plan_options: PlanOptions | None = None, goal_configuration: ArrayLike | None = None
                    ) -> PlannedPath:
    """Plan in joint space from ``q0`` to the field's goal pose, every link repelled by its obstacles.

    Args:
        field: a :class:`~pfield.field.PotentialField` (config, goal and obstacles are read from it).
        robot: the robot; its joint limits, velocity limits and link capsules are used.
        q0: starting joint angles (rad / m), tree order; outside the limits → ``InvalidInput``.
        dt, goal_tolerance, max_iterations, rotation_tolerance: shorthands for the :class:`PlanOptions`
            fields of those names (dt 0.01 s, 0.01 m, 30000 steps, the config's rotation tolerance).
        options: the whole-body QP's own settings (:class:`WholeBodyOptions`).
        plan_options: every planning setting and the cancel token (:class:`PlanOptions`).
        global_fallback, global_time_limit: shorthands for those :class:`PlanOptions` fields: when the field
            stagnates, reaches the iteration limit or is squeezed against an obstacle (a collision the plan
            stopped before), search a joint path globally and let the field track it
            (:mod:`pfield.planning.fallback`); :attr:`PlannedPath.planner` tells which produced the path.
        goal_configuration: joint positions (tree order) at the goal pose, e.g. a MoveIt request's joint
            goal: the plan is reached only within :data:`JOINT_GOAL_TOLERANCE` of it on every joint. The field
            is attracted by the pose, and drawn toward this configuration where the task leaves the arm free
            (:attr:`WholeBodyOptions.posture_gain`); when it reaches the pose in another configuration (another IK
            branch), the global fallback searches to this one (no IK). A continuous joint's value counts as the
            angle of the same rotation nearest the start (MoveIt's convention), so it is turned the short way.
            Outside the limits, or its end effector not at the goal pose within the tolerances → ``InvalidInput``;
            colliding → the fallback ends with ``GOAL_INVALID`` at once.

    Returns:
        A :class:`PlannedPath` with joint names, positions and velocities for every waypoint (the start
        included), the end-effector poses (FK of each waypoint), twists J q̇ and link clearances (exact
        signed distance of the fitted link model below the influence distance and 10 cm, a lower bound beyond),
        and its ``status``.
    """
    config, goal, packed, obstacles = _field_parts(field)
    return plan_whole_body_packed(config, goal, packed, robot, q0, dt, goal_tolerance, max_iterations,
                                  rotation_tolerance, options, obstacles, global_fallback=global_fallback,
                                  global_time_limit=global_time_limit, plan_options=plan_options,
                                  goal_configuration=goal_configuration)


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
