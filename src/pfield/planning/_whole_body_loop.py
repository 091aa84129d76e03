"""Compiled whole-body loops on top of :func:`~pfield.planning._whole_body_kernel.joint_velocity_step`: the
planning loop and the single step of the autonomy vector (numba, cache=True); the link clearances come
from :mod:`pfield.robot._clearance`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from pfield.planning._whole_body_kernel import (
    COLLISION,
    DT,
    ITERATION_LIMIT,
    ROT_TOL,
    SAFETY,
    SELF_COLLISION,
    STAG_PROGRESS,
    STAG_STEPS,
    STAGNATION,
    SUCCESS,
    TOL,
    _segments,
    joint_velocity_step,
    make_workspace,
)
from pfield.robot._clearance import fill_clearances
from pfield.robot._kinematics import joint_transforms


@njit(cache=True)
def plan_loop(q0, robot, scene, goal_p, goal_q, params, max_iterations):  # type: ignore[no-untyped-def]
    """Integrate q ← clip(q + q̇ dt) from ``q0`` until the goal, a collision, stagnation or the iteration limit.

    Returns ``(status, count, q, qdot, positions, quaternions, twists, clearances, culprit)`` with ``count``
    recorded waypoints (the start included). Waypoint k holds the configuration q_k, the velocity applied
    from it (zero at the last waypoint of a successful plan) and the end-effector twist J(q_k) q̇_k.
    """
    n = q0.shape[0]
    ws = make_workspace(n, robot.cap_joint.shape[0], scene.bounds.shape[0], robot.self_pairs.shape[0],
                        robot.prim_r.shape[0])
    total = max_iterations + 1
    qs, qds = np.empty((total, n)), np.empty((total, n))
    positions, quats, twists, clear = np.empty((total, 3)), np.empty((total, 4)), np.empty((total, 6)), np.empty(total)
    q, previous = q0.copy(), np.zeros(n)
    errors = np.empty((total, 2))  # goal errors (m, rad) per waypoint, for the stagnation window
    window, progress, dt = int(params[STAG_STEPS]), params[STAG_PROGRESS], params[DT]
    status, count = ITERATION_LIMIT, total
    culprit = np.array((-1, -1))
    for k in range(total):
        joint_velocity_step(q, previous, True, robot, scene, goal_p, goal_q, params, ws)
        qs[k], positions[k], quats[k], clear[k] = q, ws.out[6:9], ws.out[9:13], ws.out[13]
        pos_err, rot_err = ws.out[15], ws.out[16]
        if ws.out[19] < 0.0 or ws.out[14] < 0.0:
            # the last step brought capsules into contact (an infeasible squeeze): stop before it
            status, count = (COLLISION if ws.out[19] < 0.0 else SELF_COLLISION), max(k, 1)
            culprit[0], culprit[1] = int(ws.out[17]), int(ws.out[18])
            qds[count - 1], twists[count - 1] = 0.0, 0.0
            break
        if pos_err <= params[TOL] and rot_err <= params[ROT_TOL]:
            status, count = SUCCESS, k + 1
            qds[k], twists[k] = 0.0, 0.0
            break
        qds[k], twists[k] = ws.x, ws.out[0:6]
        if k == total - 1:
            break
        # stagnation: neither error fell by ``progress`` over the last window (steady but slow progress, or
        # trading rotation for position, is not stagnation; a limit cycle or a blocked arm is)
        errors[k, 0], errors[k, 1] = pos_err, rot_err
        if k >= window and pos_err > errors[k - window, 0] - progress and rot_err > errors[k - window, 1] - progress:
            status, count = STAGNATION, k + 1
            break
        for j in range(n):
            q[j] = min(max(q[j] + ws.x[j] * dt, robot.lower[j]), robot.upper[j])
            previous[j] = ws.x[j]
    return status, count, qs[:count], qds[:count], positions[:count], quats[:count], twists[:count], \
        clear[:count], culprit


@njit(cache=True)
def fill_pair_distances(q, robot, scene, ws, obstacle, own, cutoff):  # type: ignore[no-untyped-def]
    """Link clearances (m) at ``q`` into ``obstacle`` (L, M, link–obstacle) and ``own`` (P, self pairs).

    Link–obstacle pairs whose bounding-capsule bound is ≥ ``cutoff`` get that bound instead of the exact value.
    """
    joint_transforms(q, robot.parents, robot.place_rot, robot.place_pos, robot.axes, robot.kinds, ws.rotations,
                     ws.origins)
    _segments(robot, ws)
    fill_clearances(ws.seg_a, ws.seg_b, robot.cap_r, robot.self_r, robot.link_start, ws.prim_seg_a, ws.prim_seg_b,
                    robot.prim_r, robot.self_pairs, scene.packed, scene.centres, scene.bounds, ws.scratch, obstacle,
                    own, cutoff)


@njit(cache=True)
def autonomy_step(q, previous, has_prev, robot, scene, goal_p, goal_q, params, ws):  # type: ignore[no-untyped-def]
    """One whole-body field evaluation at ``q`` for shared control: the start offsets are taken at ``q`` itself
    (pairs already closer than d_s may not approach further), then :func:`joint_velocity_step`."""
    obstacle, own = scene.obstacle_offsets, scene.self_offsets
    safety = params[SAFETY]
    fill_pair_distances(q, robot, scene, ws, obstacle, own, safety)
    for c in range(obstacle.shape[0]):
        for i in range(obstacle.shape[1]):
            obstacle[c, i] = min(obstacle[c, i] - safety, 0.0)
    for k in range(own.shape[0]):
        own[k] = min(own[k] - safety, 0.0)
    return joint_velocity_step(q, previous, has_prev, robot, scene, goal_p, goal_q, params, ws)
