"""Compiled tracking of a joint-space path by the whole-body field's dampers (numba, ``cache=True``).

The global search returns a polyline of joint configurations w_0 … w_K. The arm follows it with a
*moving attractor*: a target q*(t) runs along the polyline, segment by segment, with a trapezoidal
speed profile that stops at every vertex (so q*(t) stays on the polyline, and its joint speeds and
accelerations stay within 80 % of the limits), and it waits while the arm lags more than ``lead``
(rad or m, max norm) behind. Each step solves the whole-body field's QP with the joint-space task

    minimise  ½‖q̇ − q̇_ref‖²,   q̇_ref = σ̇ (w_{k+1} − w_k) + k_p (q* − q),

with each joint's correction k_p (q* − q) capped at √(2 a e) (a: the acceleration left by the profile,
e = |q* − q|): the speed from which the joint can still stop at the target, so the pull never overshoots
into a limit cycle under the acceleration limits,

under the same velocity-damper rows (link–obstacle, self-collision, joint limits) as
:func:`~pfield.planning._whole_body_kernel.joint_velocity_step`, built by the same functions, then the same
velocity scaling and acceleration rate limit. So the tracked motion keeps the field's clearance
guarantees: no link gets closer than ``safety_distance`` even where the polyline cuts close.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from pfield.planning._rrt_kernel import capsules_valid
from pfield.planning._whole_body_kernel import _task, constrained_velocity
from pfield.planning._whole_body_layout import (
    DAMPING,
    DT,
    OUT_NEAREST_DISTANCE,
    OUT_POSITION_ERROR,
    OUT_ROTATION_ERROR,
    OUT_SELF_CLEARANCE,
    OUT_TWIST,
    ROT_TOL,
    TOL,
    make_workspace,
    unowned_robot,
    unowned_scene,
    unowned_workspace,
)
from pfield.planning._whole_body_loop import record_waypoint, step_culprit
from pfield.planning.status import PlanStatus
from pfield.robot._kinematics import joint_transforms

_PROFILE_SHARE = 0.8  # share of the joint speed / acceleration limits the moving target uses


@njit(cache=True)
def tracking_step(q, previous, has_prev, reference, robot, scene, goal_p, goal_q, params, ws):  # type: ignore[no-untyped-def]
    """The damper-constrained joint velocity closest to ``reference`` at ``q`` into ``ws.x`` (see module doc);
    pose, twist, goal errors and clearances into ``ws.out`` as the field's step does."""
    joint_transforms(q, robot.parents, robot.place_rot, robot.place_pos, robot.axes, robot.kinds, ws.rotations,
                     ws.origins)
    _task(robot, goal_p, goal_q, params, ws)
    n = q.shape[0]
    for i in range(n):
        for j in range(n):
            ws.h[i, j] = 0.0
        ws.h[i, i] = 1.0 + params[DAMPING]
        ws.rhs[i] = reference[i]
    return constrained_velocity(q, previous, has_prev, robot, scene, params, ws, 0.0)


@njit(cache=True, inline="always")
def _segment_rates(direction, robot):  # type: ignore[no-untyped-def]
    """Largest σ̇ and σ̈ (1/s, 1/s²) of q*(σ) = w_k + σ d within the profile's share of the joint limits."""
    rate, accel = math.inf, math.inf
    for j in range(direction.shape[0]):
        size = abs(direction[j])
        if size > 1e-12:
            rate = min(rate, robot.max_velocity[j] / size)
            accel = min(accel, robot.max_acceleration[j] / size)
    return _PROFILE_SHARE * rate, _PROFILE_SHARE * accel


@njit(cache=True, nogil=True)  # another thread may cancel the plan while it runs
def track_path(q0, waypoints, robot, scene, goal_p, goal_q, params, max_iterations, gain, lead, cancel):  # type: ignore[no-untyped-def]
    """Follow ``waypoints`` (K+1, n; the first is ``q0``) until the field's goal tolerances hold at the end.

    Returns ``(status, count, q, qdot, positions, quaternions, twists, clearances, culprit)`` like
    :func:`~pfield.planning._whole_body_loop.plan_loop` (a :class:`PlanStatus`): REACHED; COLLISION / SELF_COLLISION (a
    damper could not keep a pair apart: stopped before the contact); STAGNATION (the target reached the
    last vertex but the arm did not settle within the tolerances in a further ``max_iterations // 4``
    steps); ITERATION_LIMIT; CANCELLED (``cancel[0] != 0``, a :class:`~pfield.planning.CancelToken`'s flag,
    read every step).
    """
    n = q0.shape[0]
    # views without reference counting, as in the field's loop (``owned`` is read at the end: it lives until then)
    robot, scene = unowned_robot(robot), unowned_scene(scene)
    owned = make_workspace(n, robot.cap_joint.shape[0], scene.bounds.shape[0], robot.self_pairs.shape[0],
                           robot.prim_r.shape[0])
    ws = unowned_workspace(owned)
    total = max_iterations + 1
    qs, qds = np.empty((total, n)), np.empty((total, n))
    positions, quats, twists, clear = np.empty((total, 3)), np.empty((total, 4)), np.empty((total, 6)), np.empty(total)
    q, previous = q0.copy(), np.zeros(n)
    target, direction, reference = waypoints[0].copy(), np.zeros(n), np.zeros(n)
    dt = params[DT]
    segment, sigma, rate = 0, 1.0, 0.0  # sigma = 1: start the first segment at the first step
    top, accel = 0.0, 0.0
    settle_limit, settled_for = max(max_iterations // 4, 1), 0
    status, count = PlanStatus.ITERATION_LIMIT, total
    out = ws.out
    last = waypoints.shape[0] - 1
    for k in range(total):
        if sigma >= 1.0 and segment < last:
            segment += 1
            for j in range(n):
                direction[j] = waypoints[segment, j] - waypoints[segment - 1, j]
            sigma, rate = 0.0, 0.0
            top, accel = _segment_rates(direction, robot)
            if not math.isfinite(top):  # a repeated vertex: nothing to travel (and inf · 0 would be NaN)
                sigma, top, accel = 1.0, 0.0, 0.0
        lag = 0.0
        for j in range(n):
            lag = max(lag, abs(target[j] - q[j]))
        if sigma < 1.0 and lag <= lead:
            rate = min(rate + accel * dt, top, math.sqrt(2.0 * accel * (1.0 - sigma)))
            sigma = min(sigma + rate * dt, 1.0)
        else:
            rate = 0.0
        for j in range(n):
            target[j] = waypoints[segment - 1, j] + sigma * direction[j] if segment > 0 else waypoints[0, j]
            # the lag correction k_p e, no faster than the joint can brake to rest within |e| at the
            # acceleration left by the profile: a stronger pull overshoots into a limit cycle
            error = target[j] - q[j]
            braking = 2.0 * (1.0 - _PROFILE_SHARE) * robot.max_acceleration[j]
            pull = min(gain * abs(error), math.sqrt(braking * abs(error)))
            reference[j] = rate * direction[j] + math.copysign(pull, error)
        tracking_step(q, previous, k > 0, reference, robot, scene, goal_p, goal_q, params, ws)
        record_waypoint(k, q, out, qs, positions, quats, clear)
        if out[OUT_NEAREST_DISTANCE] < 0.0 or out[OUT_SELF_CLEARANCE] < 0.0:
            status = PlanStatus.COLLISION if out[OUT_NEAREST_DISTANCE] < 0.0 else PlanStatus.SELF_COLLISION
            count = max(k, 1)
            qds[count - 1], twists[count - 1] = 0.0, 0.0
            break
        finished = segment == last and sigma >= 1.0
        if finished and out[OUT_POSITION_ERROR] <= params[TOL] and out[OUT_ROTATION_ERROR] <= params[ROT_TOL]:
            status, count = PlanStatus.REACHED, k + 1
            qds[k], twists[k] = 0.0, 0.0
            break
        qds[k], twists[k] = ws.x, out[OUT_TWIST[0]:OUT_TWIST[1]]
        if k == total - 1:
            break
        if cancel[0] != 0:
            status, count = PlanStatus.CANCELLED, k + 1
            break
        if finished:
            settled_for += 1
            if settled_for > settle_limit:
                status, count = PlanStatus.STAGNATION, k + 1
                break
        for j in range(n):
            q[j] = min(max(q[j] + ws.x[j] * dt, robot.lower[j]), robot.upper[j])
            previous[j] = ws.x[j]
    return status, count, qs[:count], qds[:count], positions[:count], quats[:count], twists[:count], \
        clear[:count], step_culprit(owned.out)


@njit(cache=True)
def overlapping_waypoints(qs, robot, scene):  # type: ignore[no-untyped-def]
    """Which waypoints of ``qs`` (N, n) have a link capsule overlapping an obstacle or another capsule
    (``scene`` without offsets): where the conservative capsules cannot certify the motion."""
    ws = make_workspace(qs.shape[1], robot.cap_joint.shape[0], scene.bounds.shape[0], robot.self_pairs.shape[0],
                        robot.prim_r.shape[0])
    out = np.zeros(qs.shape[0], dtype=np.bool_)
    for k in range(qs.shape[0]):
        out[k] = not capsules_valid(qs[k], robot, scene, ws, 0.0)
    return out
