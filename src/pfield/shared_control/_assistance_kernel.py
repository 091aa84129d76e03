"""Compiled core of shared-control assistance at one robot point (the laws: :mod:`pfield.shared_control.assistance`).

One call, arrays in and out: the nearest obstacle (exact signed distance), the arbitration weight α, the
blend u = α u_auto + (1 − α) u_user, the relative velocity dampers applied to it, MoveIt Servo's speed scale
and the time to collision of the operator's command. No allocation; obstacle velocities are an (M, 3) array.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from pfield._bound import float_view1, float_view2, float_view3, int_view1, int_view2
from pfield._linalg import cholesky_inplace, cholesky_solve
from pfield.field.forces import damper_speed, project_damper
from pfield.geometry._packed import PackedObstacles
from pfield.geometry._sdf import mesh_addresses, obstacle_signed_distance
from pfield.planning._whole_body_flat import bound_step, bound_workspace
from pfield.planning._whole_body_layout import (
    OUT_NEAREST_CAPSULE,
    OUT_NEAREST_DISTANCE,
    OUT_NEAREST_OBSTACLE,
    OUT_POSITION_ERROR,
    OUT_ROTATION_ERROR,
    OUT_SIZE,
    OUT_TWIST,
)
from pfield.robot._clearance import (
    capsule_level_distance,
    capsule_lower_bound,
    fitted_distance_below,
    near_segments,
    world_segments,
)
from pfield.robot._kinematics import end_effector_kinematics, linear_point_jacobian

# parameter vector layout
INFLUENCE, SAFETY, GAIN, MAX_SPEED, MAX_ACCELERATION, MODE, GOAL_SHARE, SCALE_THRESHOLD = range(8)
N_PARAMS = 8
# arbitration modes (MODE)
MODE_LINEAR, MODE_LINEAR_GOAL, MODE_SAFETY_ONLY = 0, 1, 2
# output layout
BLENDED, ALPHA, SCALE, NEAREST, DISTANCE, NORMAL, TTC, LIMITED = 0, 6, 7, 8, 9, 10, 13, 14
N_OUT = 15
_OFFSET_ROUNDING = 1e-9  # m: a pair the field step holds at d_s by its start offset reads d_s within this
_SWEEPS = 8  # alternating projections over the active dampers (von Neumann); 1–2 suffice in practice


@njit(cache=True)
def obstacle_share(distance: float, influence: float, safety: float) -> float:
    """α_obs = clip((Q − d)/(Q − d_s), 0, 1): 0 beyond the influence distance Q, 1 at the safety distance."""
    return min(max((influence - distance) / (influence - safety), 0.0), 1.0)


@njit(cache=True)
def servo_scale(distance: float, threshold: float) -> float:
    """MoveIt Servo's collision velocity scale: exp(k (d − d_t)) for 0 < d < d_t, k = −ln(0.001)/d_t.

    1 beyond the threshold d_t, 0.001 at contact, 0 in collision (d ≤ 0) as Servo halts there.
    """
    if distance >= threshold:
        return 1.0
    if distance <= 0.0:
        return 0.0
    k = -math.log(0.001) / threshold
    return math.exp(k * (distance - threshold))


@njit(cache=True)
def limit_approach(p, packed, velocities, vx, vy, vz, params):  # type: ignore[no-untyped-def]
    """The nearest velocity whose approach speed −n̂ᵀ(v − v_obs) to every obstacle within Q obeys its damper.

    Alternating projections onto the half-spaces −n̂ᵀ(v − v_obs,i) ≤ s_i(d_i) (s_i = NEO damper speed,
    :func:`pfield.field.forces.damper_speed`); each projection only adds velocity along n̂_i (away from
    obstacle i), so motion away from an obstacle is never slowed. Returns (vx, vy, vz, changed).
    """
    changed = False
    count = packed.kinds.shape[0]
    for _ in range(_SWEEPS):
        moved = False
        for i in range(count):
            d, nx, ny, nz = obstacle_signed_distance(packed, i, p)
            if d >= params[INFLUENCE]:
                continue
            allowed = damper_speed(d, params[INFLUENCE], params[SAFETY], params[GAIN], params[MAX_SPEED],
                                   params[MAX_ACCELERATION])
            ox, oy, oz = velocities[i, 0], velocities[i, 1], velocities[i, 2]
            wx, wy, wz, hit = project_damper(vx - ox, vy - oy, vz - oz, nx, ny, nz, allowed)
            if hit:
                vx, vy, vz = wx + ox, wy + oy, wz + oz
                moved = changed = True
        if not moved:
            break
    return vx, vy, vz, changed


@njit(cache=True)
def assist_point(p, packed, velocities, user, auto, params, out):  # type: ignore[no-untyped-def]
    """Fill ``out`` (:data:`N_OUT`,) for robot point ``p``, operator twist ``user`` (6,), autonomy ``auto`` (6,)."""
    best, nearest = math.inf, -1
    bx, by, bz = 0.0, 0.0, 0.0
    ttc = math.inf
    for i in range(packed.kinds.shape[0]):
        d, nx, ny, nz = obstacle_signed_distance(packed, i, p)
        if d < best:
            best, nearest, bx, by, bz = d, i, nx, ny, nz
        # first-order time to collision: d / (relative approach speed), for the operator's command held
        approach = -(nx * (user[0] - velocities[i, 0]) + ny * (user[1] - velocities[i, 1])
                     + nz * (user[2] - velocities[i, 2]))
        if d <= 0.0:
            ttc = 0.0
        elif approach > 0.0:
            ttc = min(ttc, d / approach)
    mode = int(params[MODE])
    if mode == MODE_SAFETY_ONLY:
        alpha = 0.0
    else:
        alpha = obstacle_share(best, params[INFLUENCE], params[SAFETY]) if nearest >= 0 else 0.0
        if mode == MODE_LINEAR_GOAL:
            alpha = max(alpha, params[GOAL_SHARE])
    for k in range(6):
        out[BLENDED + k] = alpha * auto[k] + (1.0 - alpha) * user[k]
    vx, vy, vz, changed = limit_approach(p, packed, velocities, out[0], out[1], out[2], params)
    out[0], out[1], out[2] = vx, vy, vz
    out[ALPHA] = alpha
    out[SCALE] = servo_scale(best, params[SCALE_THRESHOLD])
    out[NEAREST] = nearest
    out[DISTANCE] = best
    out[NORMAL], out[NORMAL + 1], out[NORMAL + 2] = bx, by, bz
    out[TTC] = ttc
    out[LIMITED] = 1.0 if changed else 0.0


@njit(cache=True)
def nearest_link(rotations, origins, model, packed, centres, bounds, scratch, segments, hint_c, hint_i,  # type: ignore[no-untyped-def]
                 segments_ready):
    """Closest link–obstacle pair of the fitted link model: (link, obstacle, clearance, nx, ny, nz, px, py, pz).

    ``model`` = (joints, cap_a, cap_b, cap_r, link_start, prim_joint, prim_a, prim_b, prim_r) of
    :class:`pfield.robot.geometry.RobotGeometry` (bounding capsules and fitted primitives), ``segments`` =
    (link ends a, b (L, 3), primitive ends a, b (Np, 3)) the world-segment workspace. ``n`` is the obstacle's
    outward normal at the closest point, ``p`` the robot's witness point (the primitive's axis point − r n).
    A pair whose bound is no better than the best so far is skipped
    (:func:`pfield.robot._clearance.link_obstacle_distance_below` with that cutoff, in its two levels).
    ``hint_c``, ``hint_i`` ≥ 0 name a pair already known to be the closest (see :func:`bound_assist_step`):
    only it is evaluated.
    ``segments_ready``: ``segments`` already hold the world segments at these joint frames.
    """
    joints, cap_a, cap_b, cap_r, link_start, prim_joint, prim_a, prim_b, prim_r = model
    seg_a, seg_b, prim_seg_a, prim_seg_b = segments
    if not segments_ready:
        world_segments(rotations, origins, joints, cap_a, cap_b, seg_a, seg_b)
        near_segments(rotations, origins, seg_a, seg_b, cap_r, link_start, prim_joint, prim_a, prim_b, centres,
                      bounds, prim_seg_a, prim_seg_b)
    best, best_c, best_i = math.inf, -1, -1
    bn = np.zeros(3)
    bp = np.zeros(3)
    kinds, rows, meshes = packed.kinds, packed.rows, mesh_addresses(packed)
    # the hinted pair alone (when it names one), or every pair
    hinted = 0 <= hint_c < joints.shape[0] and 0 <= hint_i < kinds.shape[0]
    first_c, last_c = (hint_c, hint_c + 1) if hinted else (0, joints.shape[0])
    first_i, last_i = (hint_i, hint_i + 1) if hinted else (0, kinds.shape[0])
    for c in range(first_c, last_c):
        for i in range(first_i, last_i):
            if capsule_lower_bound(centres, bounds, i, seg_a, seg_b, cap_r, c) >= best:
                continue  # the call below would answer this bound, not exact: the pair cannot be nearer
            # link_obstacle_distance_below with cutoff best, its two levels called here (see fitted_distance_below)
            d, exact, px, py, pz, nx, ny, nz = capsule_level_distance(
                kinds, rows, meshes, i, seg_a[c, 0], seg_a[c, 1], seg_a[c, 2], seg_b[c, 0], seg_b[c, 1], seg_b[c, 2],
                cap_r[c], scratch)
            if not exact and d < best:
                d, exact, px, py, pz, nx, ny, nz = fitted_distance_below(
                    kinds, rows, meshes, i, centres[i, 0], centres[i, 1], centres[i, 2], bounds[i], link_start[c],
                    link_start[c + 1], prim_seg_a, prim_seg_b, prim_r, scratch, best)
            if exact and d < best:
                best, best_c, best_i = d, c, i
                bn[0], bn[1], bn[2] = nx, ny, nz
                bp[0], bp[1], bp[2] = px, py, pz
    if best_c >= 0:
        # the witness point on the surface: the axis point less the radius of the primitive that decided
        radius = obstacle_signed_distance(packed, best_i, bp)[0] - best
        for k in range(3):
            bp[k] -= radius * bn[k]
    return best_c, best_i, best, bn[0], bn[1], bn[2], bp[0], bp[1], bp[2]


@njit(cache=True, inline="always")
def below_singular_value(gram, threshold):  # type: ignore[no-untyped-def]
    """σ_min(J) < ``threshold`` for ``gram`` = J Jᵀ (6, 6), ``threshold`` > 0, without an eigen solver.

    σ_min² is the smallest eigenvalue of J Jᵀ, so σ_min < t exactly when J Jᵀ − t² I is not positive
    definite, i.e. when its Cholesky factorisation meets a pivot ≤ 0.
    """
    m = np.empty((6, 6))
    for r in range(6):
        for c in range(6):
            m[r, c] = gram[r, c]
        m[r, r] -= threshold * threshold
    for j in range(6):
        pivot = m[j, j]
        for k in range(j):
            pivot -= m[j, k] * m[j, k]
        if not pivot > 0.0:
            return True
        m[j, j] = math.sqrt(pivot)
        for i in range(j + 1, 6):
            value = m[i, j]
            for k in range(j):
                value -= m[i, k] * m[j, k]
            m[i, j] = value / m[j, j]
    return False


# whole-body extras: parameter slots after N_PARAMS, output slots after N_OUT
DAMPING, LIMIT_MARGIN, SINGULARITY = N_PARAMS, N_PARAMS + 1, N_PARAMS + 2
GOAL_TOLERANCE, ROTATION_TOLERANCE, STALL_SPEED, GOAL_RADIUS = N_PARAMS + 3, N_PARAMS + 4, N_PARAMS + 5, N_PARAMS + 6
HINT_LINK, HINT_OBSTACLE = N_PARAMS + 7, N_PARAMS + 8  # the closest pair when known (nearest_link), else −1
N_PARAMS_WHOLE_BODY = N_PARAMS + 9
AT_LIMIT, SINGULAR, POINT, AT_GOAL, STALLED = N_OUT, N_OUT + 1, N_OUT + 2, N_OUT + 5, N_OUT + 6
N_OUT_WHOLE_BODY = N_OUT + 7


@njit(cache=True, inline="always")
def _times(point_jac, qd):  # type: ignore[no-untyped-def]
    """The point velocity J_p q̇ (3 scalars) of a (3, n) point Jacobian."""
    x = y = z = 0.0
    for j in range(qd.shape[0]):
        x += point_jac[0, j] * qd[j]
        y += point_jac[1, j] * qd[j]
        z += point_jac[2, j] * qd[j]
    return x, y, z


@njit(cache=True)
def assist_joints(q, lower, upper, kin, model, packed, centres, bounds, velocities, qd_auto, user,  # type: ignore[no-untyped-def]
                  params,
                  rotations, origins, jac, point_jac, scratch, segments, qd, out, frames_ready):
    """Whole-body assistance in one call (the laws: :func:`pfield.shared_control.whole_body_assistance`).

    ``kin``: the robot's packed kinematics (``RobotModel.kinematics``); ``model``, ``segments``: the fitted
    link model and its world-segment workspace (:func:`nearest_link`);
    ``qd`` receives the blended joint velocities, ``out`` (:data:`N_OUT_WHOLE_BODY`,) everything else.
    ``frames_ready``: ``rotations``, ``origins``, ``jac`` and ``segments`` already hold the joint frames, the
    end-effector Jacobian and the world segments at ``q`` (a field step's, :func:`bound_assist_step`).
    """
    n = q.shape[0]
    parents, place_rot, place_pos, axes, kinds, support, ee_joint, ee_rot, ee_pos = kin
    if not frames_ready:
        end_effector_kinematics(q, parents, place_rot, place_pos, axes, kinds, support, ee_joint, ee_rot, ee_pos,
                                rotations, origins, jac)
    # q̇_user = Jᵀ (J Jᵀ + λ² I)⁻¹ u_user, in loops (6 × n: LAPACK's call overhead exceeds the work)
    gram = np.empty((6, 6))
    for r in range(6):
        for c in range(r + 1):
            total = 0.0
            for j in range(n):
                total += jac[r, j] * jac[c, j]
            gram[r, c] = gram[c, r] = total
    out[SINGULAR] = 1.0 if below_singular_value(gram, params[SINGULARITY]) else 0.0
    for k in range(6):
        gram[k, k] += params[DAMPING] * params[DAMPING]
    size = gram.shape[0]  # a run-time 6: with the literal, the solver would compile a second time
    cholesky_inplace(gram, size)
    y = np.empty(6)
    cholesky_solve(gram, user, y, size)
    qd_user = np.empty(n)
    for j in range(n):
        total = 0.0
        for k in range(6):
            total += jac[k, j] * y[k]
        qd_user[j] = total
    out[AT_LIMIT] = 0.0
    for j in range(n):
        if q[j] - lower[j] < params[LIMIT_MARGIN] or upper[j] - q[j] < params[LIMIT_MARGIN]:
            out[AT_LIMIT] = 1.0
    cap_joints = model[0]
    c, i, clearance, nx, ny, nz, px, py, pz = nearest_link(rotations, origins, model, packed, centres, bounds,
                                                           scratch, segments, int(params[HINT_LINK]),
                                                           int(params[HINT_OBSTACLE]), frames_ready)
    mode = int(params[MODE])
    alpha = 0.0
    if mode != MODE_SAFETY_ONLY and c >= 0:
        alpha = obstacle_share(clearance, params[INFLUENCE], params[SAFETY])
        if mode == MODE_LINEAR_GOAL:
            alpha = max(alpha, params[GOAL_SHARE])
    for j in range(n):
        qd[j] = alpha * qd_auto[j] + (1.0 - alpha) * qd_user[j]
    ttc, limited = math.inf, False
    if c >= 0:
        linear_point_jacobian(rotations, origins, axes, kinds, support, cap_joints[c], px, py, pz, point_jac)
        ox, oy, oz = velocities[i, 0], velocities[i, 1], velocities[i, 2]
        ux, uy, uz = _times(point_jac, qd_user)
        approach_user = -(nx * (ux - ox) + ny * (uy - oy) + nz * (uz - oz))
        if clearance <= 0.0:
            ttc = 0.0
        elif approach_user > 0.0:
            ttc = clearance / approach_user
        if clearance < params[INFLUENCE]:
            allowed = damper_speed(clearance, params[INFLUENCE], params[SAFETY], params[GAIN], params[MAX_SPEED],
                                   params[MAX_ACCELERATION])
            vx, vy, vz = _times(point_jac, qd)
            excess = -(nx * (vx - ox) + ny * (vy - oy) + nz * (vz - oz)) - allowed
            norm2 = 0.0
            for j in range(n):
                direction = point_jac[0, j] * nx + point_jac[1, j] * ny + point_jac[2, j] * nz
                norm2 += direction * direction
            if excess > 0.0 and norm2 > 1e-12:
                for j in range(n):
                    direction = point_jac[0, j] * nx + point_jac[1, j] * ny + point_jac[2, j] * nz
                    qd[j] += direction * excess / norm2
                limited = True
    for k in range(6):
        total = 0.0
        for j in range(n):
            total += jac[k, j] * qd[j]
        out[BLENDED + k] = total
    out[ALPHA], out[NEAREST], out[DISTANCE] = alpha, i, clearance
    out[SCALE] = servo_scale(clearance, params[SCALE_THRESHOLD])
    out[NORMAL], out[NORMAL + 1], out[NORMAL + 2] = nx, ny, nz
    out[TTC], out[LIMITED] = ttc, 1.0 if limited else 0.0
    out[POINT], out[POINT + 1], out[POINT + 2] = px, py, pz


@njit(cache=True, inline="always")
def _unbound(table):  # type: ignore[no-untyped-def]
    """The arrays bound by :class:`pfield.shared_control.assistance._Workspace` (slot order there), as
    :func:`assist_joints` takes them: kinematics, link model, obstacles, world segments."""
    kin = (int_view1(table, 0), float_view3(table, 1), float_view2(table, 2), float_view2(table, 3),
           int_view1(table, 4), int_view2(table, 5), int_view1(table, 6)[0], float_view2(table, 7),
           float_view1(table, 8))
    model = (int_view1(table, 9), float_view2(table, 10), float_view2(table, 11), float_view1(table, 12),
             int_view1(table, 13), int_view1(table, 14), float_view2(table, 15), float_view2(table, 16),
             float_view1(table, 17))
    packed = PackedObstacles(int_view1(table, 18), float_view2(table, 19), float_view3(table, 20),
                             float_view3(table, 21), float_view2(table, 22), float_view2(table, 23),
                             int_view2(table, 24), int_view2(table, 25))
    segments = (float_view2(table, 35), float_view2(table, 36), float_view2(table, 37), float_view2(table, 38))
    return kin, model, packed, segments


@njit(cache=True)
def bound_assist(q, qd_auto, user, params, qd, out, table):  # type: ignore[no-untyped-def]
    """:func:`assist_joints` on the arrays bound by :class:`pfield.shared_control.assistance._Workspace`."""
    kin, model, packed, segments = _unbound(table)
    assist_joints(q, float_view1(table, 26), float_view1(table, 27), kin, model, packed, float_view2(table, 28),
                  float_view1(table, 29), float_view2(table, 30), qd_auto, user, params, float_view3(table, 31),
                  float_view2(table, 32), float_view2(table, 33), float_view2(table, 34), float_view2(table, 39),
                  segments, qd, out, q.shape[0] < 0)  # False, as a run-time bool: one compile for both callers


@njit(cache=True)
def bound_assist_step(q, previous, given, use_previous, step_table, user, params, qd, out, table):  # type: ignore[no-untyped-def]
    """The whole-body field step at ``q`` and the assistance on its q̇, in one call.

    The step is :func:`pfield.planning._whole_body_flat.bound_step` on ``step_table`` (it checks ``q`` and
    ``previous`` itself). Its position and rotation errors give the goal outputs (``AT_GOAL``: both within
    ``GOAL_TOLERANCE`` / ``ROTATION_TOLERANCE``; else ``STALLED``: the autonomy twist slower than
    ``STALL_SPEED`` in both parts) and ``linear_goal``'s share clip(1 − ‖g − p‖/R, 0, 1) (written into
    ``params[GOAL_SHARE]``); then :func:`bound_assist` on ``table`` at q clamped to its limits. Returns the
    step's row; an empty array when an input is bad (the caller's validating path then raises).
    """
    row = bound_step(q, previous, given, use_previous, step_table)
    if row.shape[0] == 0:
        return row
    lower, upper = float_view1(table, 26), float_view1(table, 27)
    values = np.empty(q.shape[0])
    for j in range(q.shape[0]):
        values[j] = min(max(q[j], lower[j]), upper[j])
    distance = row[OUT_POSITION_ERROR]
    at_goal = distance <= params[GOAL_TOLERANCE] and row[OUT_ROTATION_ERROR] <= params[ROTATION_TOLERANCE]
    t = OUT_TWIST[0]
    linear = math.sqrt(row[t] * row[t] + row[t + 1] * row[t + 1] + row[t + 2] * row[t + 2])
    angular = math.sqrt(row[t + 3] * row[t + 3] + row[t + 4] * row[t + 4] + row[t + 5] * row[t + 5])
    stalled = not at_goal and linear < params[STALL_SPEED] and angular < params[STALL_SPEED]
    params[GOAL_SHARE] = min(max(1.0 - distance / params[GOAL_RADIUS], 0.0), 1.0)
    # The step evaluated every link–obstacle pair exactly below the influence distance Q (its dampers'
    # cutoff), the others only by bounds ≥ Q; so a nearest pair it reports in (d_s, Q) is the closest of all.
    # (At or below d_s the step's start offsets hold pairs at d_s, up to rounding: then the whole search decides.)
    nearest = row[OUT_NEAREST_DISTANCE]
    known = params[SAFETY] + _OFFSET_ROUNDING < nearest < params[INFLUENCE]
    params[HINT_LINK] = row[OUT_NEAREST_CAPSULE] if known else -1.0
    params[HINT_OBSTACLE] = row[OUT_NEAREST_OBSTACLE] if known else -1.0
    # continue from the step's joint frames, Jacobian and world segments (the same link model and obstacles)
    ws = bound_workspace(step_table)
    kin, model, packed, _ = _unbound(table)
    assist_joints(values, lower, upper, kin, model, packed, float_view2(table, 28), float_view1(table, 29),
                  float_view2(table, 30), row[OUT_SIZE:], user, params, ws.rotations, ws.origins, ws.jac,
                  float_view2(table, 34), float_view2(table, 39), (ws.seg_a, ws.seg_b, ws.prim_seg_a, ws.prim_seg_b),
                  qd, out, row.shape[0] > 0)  # True, as a run-time bool (see bound_assist)
    out[AT_GOAL] = 1.0 if at_goal else 0.0
    out[STALLED] = 1.0 if stalled else 0.0
    return row
