"""Compiled whole-body field: one joint-velocity step (numba, ``cache=True``); the loop is in ``_whole_body_loop``.

Each step solves the small QP (Haviland & Corke, "NEO: A novel expeditious optimisation algorithm for
reactive motion control of manipulators", RA-L 2021, eqs. 14–20)::

    minimise  ½‖J q̇ − ẋ‖²_W + ½ λ² ‖q̇ − q̇_rep‖²
    s.t.      n_kᵀ J_k q̇ ≥ −s(d_k)         for every link–obstacle and self-collision pair within Q,
              ±q̇_j ≥ −s_j(q_j)             near the joint position limits,

where ẋ = [v; ω] is the field's end-effector twist (attraction of :mod:`pfield.field.forces`, soft
saturated), J the end-effector Jacobian, W = diag(1, 1, 1, w_r, w_r, w_r), n_k the unit normal from the
obstacle to link point k and J_k that point's linear Jacobian (so n_kᵀ J_k q̇ = ḋ_k). The velocity damper
s(d) = min(ξ v_max (d − d_s)/(Q − d_s), (d − d_s)/(2 dt)) lets links approach obstacles only as fast as
they can still stop at d_s (Faverjon & Tournassoud 1987), so a goal configuration inside the influence
distance is still reached: nothing *pushes* the end effector off its goal. The Khatib repulsion
η(1/d − 1/Q)/d² (saturated, Khatib 1986) enters only as the posture preference q̇_rep = Σ J_kᵀ n_k ·
v_max·m_k/F_cap, which a small λ² confines to the task's null space: the redundant joints bend away
from obstacles without displacing the goal. The damped least-squares part (λ) also keeps the step bounded
near singularities (Nakamura & Hanafusa 1986). After the QP, the joint speeds are scaled uniformly into
the URDF velocity limits and rate-limited by the joint acceleration limits (dropped in a step where the
rate limit would break a damper row: safety first).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from pfield._linalg import cholesky_inplace, cholesky_solve, hildreth
from pfield._spatial_kernels import matrix_to_quat, rotation_error
from pfield.field.forces import attraction, khatib_magnitude, soft_saturate, stepped_damper_speed
from pfield.geometry._sdf import mesh_addresses
from pfield.planning._whole_body_layout import (
    DAMPING,
    DT,
    ETA,
    F_CAP,
    GAMMA,
    INFLUENCE,
    JOINT_INFLUENCE,
    JOINT_SAFETY,
    K_ATT,
    K_ROT,
    NULL_GAIN,
    OUT_CLEARANCE,
    OUT_NEAREST_CAPSULE,
    OUT_NEAREST_DISTANCE,
    OUT_NEAREST_OBSTACLE,
    OUT_NEAREST_SELF_PAIR,
    OUT_ORIENTATION,
    OUT_POSITION,
    OUT_POSITION_ERROR,
    OUT_ROTATION_ERROR,
    OUT_SELF_CLEARANCE,
    OUT_TWIST,
    ROT_WEIGHT,
    SAFETY,
    V_MAX,
    W_MAX,
    XI,
    RobotArrays,
    Scene,
    Workspace,
)
from pfield.robot._clearance import (
    capsule_level_distance,
    capsule_lower_bound,
    fitted_distance_below,
    link_pair_distance,
    near_segments,
    world_segments,
)
from pfield.robot._kinematics import (
    frame_pose,
    joint_transforms,
    linear_point_jacobian,
    point_jacobian,
)


@njit(cache=True, inline="always")
def _task(robot: RobotArrays, goal_p: np.ndarray, goal_q: np.ndarray, params: np.ndarray, ws: Workspace) -> None:
    """End-effector pose, Jacobian and the field's desired twist; fills ws.h/ws.rhs with the QP's normal eqs."""
    rot, pos = frame_pose(ws.rotations, ws.origins, robot.ee_joint, robot.ee_rot, robot.ee_pos)
    point_jacobian(ws.rotations, ws.origins, robot.axes, robot.kinds, robot.support, robot.ee_joint, pos, ws.jac)
    quat = matrix_to_quat(rot)
    ex, ey, ez = goal_p[0] - pos[0], goal_p[1] - pos[1], goal_p[2] - pos[2]
    fx, fy, fz = attraction(ex, ey, ez, params[K_ATT], params[GAMMA])
    vx, vy, vz = soft_saturate(fx, fy, fz, params[V_MAX])
    rx, ry, rz = rotation_error(quat[0], quat[1], quat[2], quat[3], goal_q[0], goal_q[1], goal_q[2], goal_q[3])
    k = params[K_ROT]
    wx, wy, wz = soft_saturate(k * rx, k * ry, k * rz, params[W_MAX])
    twist, weights = ws.task[0], ws.task[1]
    twist[0], twist[1], twist[2], twist[3], twist[4], twist[5] = vx, vy, vz, wx, wy, wz
    weights[0:3] = 1.0
    weights[3:6] = params[ROT_WEIGHT]
    n = ws.x.shape[0]
    for i in range(n):
        s = 0.0
        for r in range(6):
            s += ws.jac[r, i] * weights[r] * twist[r]
        ws.rhs[i] = s
        for j in range(i + 1):
            s = 0.0
            for r in range(6):
                s += ws.jac[r, i] * weights[r] * ws.jac[r, j]
            ws.h[i, j] = s
            ws.h[j, i] = s
        ws.h[i, i] += params[DAMPING]
    ws.out[OUT_POSITION[0]:OUT_POSITION[1]] = pos
    ws.out[OUT_ORIENTATION[0]:OUT_ORIENTATION[1]] = quat
    ws.out[OUT_POSITION_ERROR] = math.sqrt(ex * ex + ey * ey + ez * ez)
    ws.out[OUT_ROTATION_ERROR] = math.sqrt(rx * rx + ry * ry + rz * rz)


@njit(cache=True, inline="always")
def _segments(robot: RobotArrays, ws: Workspace) -> None:
    world_segments(ws.rotations, ws.origins, robot.cap_joint, robot.cap_a, robot.cap_b, ws.seg_a, ws.seg_b)
    world_segments(ws.rotations, ws.origins, robot.prim_joint, robot.prim_a, robot.prim_b, ws.prim_seg_a,
                   ws.prim_seg_b)


@njit(cache=True, inline="always")
def _segments_near(robot: RobotArrays, scene: Scene, ws: Workspace) -> None:
    """:func:`_segments` for the field's step: the fitted primitives only of links that may reach the fine
    level (:func:`pfield.robot._clearance.near_segments`); the others are never read by the step."""
    world_segments(ws.rotations, ws.origins, robot.cap_joint, robot.cap_a, robot.cap_b, ws.seg_a, ws.seg_b)
    near_segments(ws.rotations, ws.origins, ws.seg_a, ws.seg_b, robot.cap_r, robot.link_start, robot.prim_joint,
                  robot.prim_a, robot.prim_b, scene.centres, scene.bounds, ws.prim_seg_a, ws.prim_seg_b)


@njit(cache=True, inline="always")
def _add_row(kin: tuple[np.ndarray, ...], jlin: np.ndarray, rows: np.ndarray, bounds: np.ndarray, m: int, nx: float,
             ny: float, nz: float, joint: int, px: float, py: float, pz: float, bound: float) -> int:
    """Row nᵀ J_p(point) (J of the point carried by ``joint``) with bound −s; returns the new row count.

    ``kin`` = (rotations, origins, axes, kinds, support), unpacked by the caller outside its loops.
    """
    linear_point_jacobian(kin[0], kin[1], kin[2], kin[3], kin[4], joint, px, py, pz, jlin)
    for j in range(jlin.shape[1]):
        rows[m, j] = nx * jlin[0, j] + ny * jlin[1, j] + nz * jlin[2, j]
    bounds[m] = bound
    return m + 1


@njit(cache=True, inline="always")
def _obstacle_rows(robot: RobotArrays, scene: Scene, params: np.ndarray, ws: Workspace, m: int, hold: bool) -> int:
    """Damper rows and null-space repulsion of every link–obstacle pair within Q; returns the row count.

    One row per pair, at the closest point of the link's nearest primitive
    (:func:`pfield.robot._clearance.link_obstacle_distance_below`). A pair's distance less its start offset
    (``scene.obstacle_offsets``); ``hold``: offsets taken at this very configuration, i.e. max(d, d_s) (a pair
    already closer than d_s may not approach further), without the offsets array.

    Distances are exact (on the fitted primitives) below min(Q, 10 cm); beyond, a pair's clearance is a lower
    bound: its bounding capsule's distance (also for the nearest pair), Q itself when every primitive is
    farther, or its bounding sphere's (clearance only). Measured on MotionBenchMaker table scenes,
    evaluating primitives between Q and 10 cm cost a third of the step."""
    influence, dt = params[INFLUENCE], params[DT]
    clearance, culprit_c, culprit_o = math.inf, -1, -1
    # hoisted out of the loops: numba reference-counts tuple members on every access (see _distance)
    packed, centres, bounds = scene.packed, scene.centres, scene.bounds
    kinds, rows, meshes = packed.kinds, packed.rows, mesh_addresses(packed)
    seg_a, seg_b, cap_r, cap_joint, scratch = ws.seg_a, ws.seg_b, robot.cap_r, robot.cap_joint, ws.scratch
    link_start, prim_a, prim_b, prim_r = robot.link_start, ws.prim_seg_a, ws.prim_seg_b, robot.prim_r
    offsets = scene.obstacle_offsets
    worst = math.inf
    speed, safety, null_scale = params[XI] * params[V_MAX], params[SAFETY], params[NULL_GAIN] * params[V_MAX]
    kin = (ws.rotations, ws.origins, robot.axes, robot.kinds, robot.support)
    jlin, wrows, wb, free = ws.jlin, ws.rows, ws.b, ws.free
    for c in range(cap_joint.shape[0]):
        for i in range(bounds.shape[0]):
            # the cheap bound first, in scalars: most pairs end here, before a call that takes arrays
            lower = capsule_lower_bound(centres, bounds, i, seg_a, seg_b, cap_r, c)
            if lower >= influence:  # link_obstacle_distance_below's own first test, answered here
                clearance = min(clearance, lower)
                continue
            # link_obstacle_distance_below's two levels, called here (see fitted_distance_below for why): fitted
            # primitives only below Q: beyond it a pair gives no row, and its bounding capsule's distance (within
            # a few cm of the primitives') stands for it
            d, exact, px, py, pz, nx, ny, nz = capsule_level_distance(
                kinds, rows, meshes, i, seg_a[c, 0], seg_a[c, 1], seg_a[c, 2], seg_b[c, 0], seg_b[c, 1], seg_b[c, 2],
                cap_r[c], scratch)
            if not exact and d < influence:
                d, exact, px, py, pz, nx, ny, nz = fitted_distance_below(
                    kinds, rows, meshes, i, centres[i, 0], centres[i, 1], centres[i, 2], bounds[i], link_start[c],
                    link_start[c + 1], prim_a, prim_b, prim_r, scratch, influence)
            clearance = min(clearance, d)
            d = max(d, safety) if hold else d - offsets[c, i]
            if d < worst:
                worst, culprit_c, culprit_o = d, c, i
            if not exact or d >= influence or cap_joint[c] < 0:  # not exact: a lower bound, at least Q
                continue
            bound = -stepped_damper_speed(d, influence, safety, speed, dt)
            m = _add_row(kin, jlin, wrows, wb, m, nx, ny, nz, cap_joint[c], px, py, pz, bound)
            push = null_scale * khatib_magnitude(d, params[ETA], influence, params[F_CAP]) / params[F_CAP]
            for j in range(free.shape[0]):
                free[j] += push * wrows[m - 1, j]
    out = ws.out
    out[OUT_CLEARANCE], out[OUT_NEAREST_CAPSULE], out[OUT_NEAREST_OBSTACLE] = clearance, culprit_c, culprit_o
    out[OUT_NEAREST_DISTANCE] = worst
    return m


@njit(cache=True, inline="always")
def _self_rows(robot: RobotArrays, scene: Scene, params: np.ndarray, ws: Workspace, m: int, hold: bool) -> int:
    """Damper rows of the self-collision pairs within Q (covering capsules); offsets and ``hold`` as in
    :func:`_obstacle_rows`."""
    influence, dt = params[INFLUENCE], params[DT]
    speed, safety = params[XI] * params[V_MAX], params[SAFETY]
    clearance, nearest = math.inf, -1
    kin = (ws.rotations, ws.origins, robot.axes, robot.kinds, robot.support)
    jlin, jlin2, wrows, wb = ws.jlin, ws.jlin2, ws.rows, ws.b
    pairs, seg_a, seg_b, cap_joint = robot.self_pairs, ws.seg_a, ws.seg_b, robot.cap_joint
    self_r = robot.self_r
    offsets = scene.self_offsets
    for k in range(pairs.shape[0]):
        c1, c2 = pairs[k, 0], pairs[k, 1]
        d, p1x, p1y, p1z, p2x, p2y, p2z = link_pair_distance(c1, c2, seg_a, seg_b, self_r)
        d = max(d, safety) if hold else d - offsets[k]
        if d < clearance:
            clearance, nearest = d, k
        if d >= influence:
            continue
        dx, dy, dz = p1x - p2x, p1y - p2y, p1z - p2z
        dist = math.sqrt(dx * dx + dy * dy + dz * dz)
        if dist < 1e-12:
            continue
        nx, ny, nz = dx / dist, dy / dist, dz / dist
        bound = -stepped_damper_speed(d, influence, safety, speed, dt)
        m = _add_row(kin, jlin, wrows, wb, m, nx, ny, nz, cap_joint[c1], p1x, p1y, p1z, bound)
        linear_point_jacobian(kin[0], kin[1], kin[2], kin[3], kin[4], cap_joint[c2], p2x, p2y, p2z, jlin2)
        for j in range(jlin2.shape[1]):
            wrows[m - 1, j] -= nx * jlin2[0, j] + ny * jlin2[1, j] + nz * jlin2[2, j]
    ws.out[OUT_SELF_CLEARANCE], ws.out[OUT_NEAREST_SELF_PAIR] = clearance, nearest
    return m


@njit(cache=True, inline="always")
def _joint_limit_rows(q: np.ndarray, robot: RobotArrays, params: np.ndarray, ws: Workspace, m: int) -> int:
    n = q.shape[0]
    for j in range(n):
        for side in (1.0, -1.0):
            limit = robot.lower[j] if side > 0 else robot.upper[j]
            if not math.isfinite(limit):
                continue
            gap = side * (q[j] - limit)
            if gap >= params[JOINT_INFLUENCE]:
                continue
            ws.rows[m, :] = 0.0
            ws.rows[m, j] = side
            ws.b[m] = -stepped_damper_speed(gap, params[JOINT_INFLUENCE], params[JOINT_SAFETY], robot.max_velocity[j],
                                      params[DT])
            m += 1
    return m


@njit(cache=True, inline="always")
def _limit_speed(q_prev_velocity: np.ndarray, has_prev: bool, robot: RobotArrays, params: np.ndarray, ws: Workspace,
                 m: int) -> None:
    """Uniform scaling into the velocity limits, then the joint rate limit unless it breaks a damper."""
    x = ws.x
    n = x.shape[0]
    scale = 1.0
    for j in range(n):
        if abs(x[j]) * scale > robot.max_velocity[j]:
            scale = robot.max_velocity[j] / abs(x[j])
    x *= scale
    if not has_prev:
        return
    limited = ws.limited
    for j in range(n):
        step = robot.max_acceleration[j] * params[DT]
        limited[j] = min(max(x[j], q_prev_velocity[j] - step), q_prev_velocity[j] + step)
    for k in range(m):
        with_limit, without = 0.0, 0.0
        for j in range(n):
            with_limit += ws.rows[k, j] * limited[j]
            without += ws.rows[k, j] * x[j]
        if with_limit < ws.b[k] - 1e-9 and with_limit < without:
            return
    x[:] = limited


@njit(cache=True, inline="always")
def constrained_velocity(q: np.ndarray, previous: np.ndarray, has_prev: bool, robot: RobotArrays, scene: Scene,
                         params: np.ndarray, ws: Workspace, free_weight: float) -> int:
    """The joint velocity of the task in ``ws.h`` / ``ws.rhs`` under the velocity dampers (link–obstacle,
    self-collision, joint limits) into ``ws.x``, speed- and rate-limited, and its twist J q̇ into ``ws.out``;
    ``free_weight`` scales the dampers' free-space term added to the task. Returns the number of rows."""
    _segments_near(robot, scene, ws)
    return velocity_from_segments(q, previous, has_prev, robot, scene, params, ws, free_weight, False)


@njit(cache=True, inline="always")
def velocity_from_segments(q: np.ndarray, previous: np.ndarray, has_prev: bool, robot: RobotArrays, scene: Scene,
                           params: np.ndarray, ws: Workspace, free_weight: float, hold: bool) -> int:
    """:func:`constrained_velocity` once the world segments are in ``ws`` (:func:`_segments_near`); ``hold``:
    the start offsets are taken at ``q`` itself (:func:`_obstacle_rows`)."""
    ws.free[:] = 0.0
    # a run-time zero: with the literal 0, type inference also compiles hildreth for m = Literal[int](0)
    m = _obstacle_rows(robot, scene, params, ws, np.int64(0), hold)  # type: ignore[arg-type]
    m = _self_rows(robot, scene, params, ws, m, hold)
    m = _joint_limit_rows(q, robot, params, ws, m)
    n = q.shape[0]
    for j in range(n):
        ws.rhs[j] += free_weight * ws.free[j]
    cholesky_inplace(ws.h, n)
    cholesky_solve(ws.h, ws.rhs, ws.x, n)
    hildreth(ws.h, ws.x, ws.rows, ws.b, m, n, ws.hinv, ws.mu, ws.curvature, 200, 1e-7)
    _limit_speed(previous, has_prev, robot, params, ws, m)
    for r in range(6):
        s = 0.0
        for j in range(n):
            s += ws.jac[r, j] * ws.x[j]
        ws.out[OUT_TWIST[0] + r] = s
    return m


@njit(cache=True)
def joint_velocity_step(q: np.ndarray, previous: np.ndarray, has_prev: bool, robot: RobotArrays, scene: Scene,
                        goal_p: np.ndarray, goal_q: np.ndarray, params: np.ndarray, ws: Workspace) -> int:
    """The whole-body field's joint velocity at ``q`` into ``ws.x``; pose, twist, clearances into ``ws.out``."""
    joint_transforms(q, robot.parents, robot.place_rot, robot.place_pos, robot.axes, robot.kinds, ws.rotations,
                     ws.origins)
    _task(robot, goal_p, goal_q, params, ws)
    return constrained_velocity(q, previous, has_prev, robot, scene, params, ws, params[DAMPING])
