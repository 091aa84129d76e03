"""Compiled whole-body loops on top of :func:`~pfield.planning._whole_body_kernel.joint_velocity_step`: the
planning loop and the single step of the autonomy vector (numba, cache=True).

The planner and :class:`~pfield.planning.WholeBodyStepper` run the compiled core's port
(``src/core/planning/whole_body``, :mod:`pfield.planning._whole_body_core`); these stay as its twins
(tests/planning/test_core_whole_body.py) until they go. The link clearances (``pair_distances``) are in
:mod:`pfield.planning._whole_body_core`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from pfield.planning._progress import track_progress
from pfield.planning._whole_body_kernel import _segments_near, _task, joint_velocity_step, velocity_from_segments
from pfield.planning._whole_body_layout import (
    DAMPING,
    DT,
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
    ROT_TOL,
    STAG_PROGRESS,
    STAG_STEPS,
    TOL,
    RobotArrays,
    Scene,
    Workspace,
    make_workspace,
    unowned_robot,
    unowned_scene,
    unowned_workspace,
)
from pfield.planning.status import PlanStatus
from pfield.robot._kinematics import joint_transforms


@njit(cache=True, inline="always")
def record_waypoint(k: int, q: np.ndarray, out: np.ndarray, qs: np.ndarray, positions: np.ndarray,
                    quats: np.ndarray, clear: np.ndarray) -> None:
    """Waypoint ``k`` of a loop's outputs from ``q`` and its step result row ``out``."""
    qs[k], positions[k], clear[k] = q, out[OUT_POSITION[0]:OUT_POSITION[1]], out[OUT_CLEARANCE]
    quats[k] = out[OUT_ORIENTATION[0]:OUT_ORIENTATION[1]]


@njit(cache=True, inline="always")
def step_culprit(out: np.ndarray) -> np.ndarray:
    """The loop's ``culprit`` (5,) of the step result row ``out`` (see :func:`plan_loop`)."""
    return np.array((out[OUT_NEAREST_CAPSULE], out[OUT_NEAREST_OBSTACLE], out[OUT_NEAREST_DISTANCE],
                     out[OUT_NEAREST_SELF_PAIR], out[OUT_SELF_CLEARANCE]))


@njit(cache=True, nogil=True)  # another thread may cancel the plan while it runs
def plan_loop(q0: np.ndarray, robot: RobotArrays, scene: Scene, goal_p: np.ndarray, goal_q: np.ndarray,
              params: np.ndarray, max_iterations: int, cancel: np.ndarray) -> tuple[Any, ...]:
    """Integrate q ← clip(q + q̇ dt) from ``q0`` until the goal, a collision, stagnation, the iteration limit
    or ``cancel[0] != 0`` (a :class:`~pfield.planning.CancelToken`'s flag, read every step).

    Returns ``(status, count, q, qdot, positions, quaternions, twists, clearances, culprit)`` with ``count``
    recorded waypoints (the start included) and ``status`` a :class:`PlanStatus`. Waypoint k holds the
    configuration q_k, the velocity applied from it (zero at the last waypoint of a successful plan) and
    the end-effector twist J(q_k) q̇_k. ``culprit`` (5,) describes the last step evaluated: the capsule and
    obstacle of its closest link–obstacle pair, that pair's distance (m, less its start offset), the
    closest self pair and its distance (indices −1 when there is none).
    """
    n = q0.shape[0]
    # every step binds dozens of arrays: views without reference counting (the arguments and ``owned`` keep
    # the memory; ``owned`` is read at the end, so it lives until then)
    robot, scene = unowned_robot(robot), unowned_scene(scene)
    owned = make_workspace(n, robot.cap_joint.shape[0], scene.bounds.shape[0], robot.self_pairs.shape[0],
                           robot.prim_r.shape[0])
    ws = unowned_workspace(owned)
    total = max_iterations + 1
    qs, qds = np.empty((total, n)), np.empty((total, n))
    positions, quats, twists, clear = np.empty((total, 3)), np.empty((total, 4)), np.empty((total, 6)), np.empty(total)
    q, previous = q0.copy(), np.zeros(n)
    window, progress, dt = int(params[STAG_STEPS]), params[STAG_PROGRESS], params[DT]
    state = (math.inf, math.inf, math.inf, math.inf)
    status, count = PlanStatus.ITERATION_LIMIT, total
    out = ws.out
    for k in range(total):
        # has_prev as a run-time bool (dt > 0 always holds here): the same specialisation as autonomy_step's
        joint_velocity_step(q, previous, dt > 0.0, robot, scene, goal_p, goal_q, params, ws)
        record_waypoint(k, q, out, qs, positions, quats, clear)
        pos_err, rot_err = out[OUT_POSITION_ERROR], out[OUT_ROTATION_ERROR]
        if out[OUT_NEAREST_DISTANCE] < 0.0 or out[OUT_SELF_CLEARANCE] < 0.0:
            # the last step brought capsules into contact (an infeasible squeeze): stop before it
            status = PlanStatus.COLLISION if out[OUT_NEAREST_DISTANCE] < 0.0 else PlanStatus.SELF_COLLISION
            count = max(k, 1)
            qds[count - 1], twists[count - 1] = 0.0, 0.0
            break
        if pos_err <= params[TOL] and rot_err <= params[ROT_TOL]:
            status, count = PlanStatus.REACHED, k + 1
            qds[k], twists[k] = 0.0, 0.0
            break
        qds[k], twists[k] = ws.x, out[OUT_TWIST[0]:OUT_TWIST[1]]
        if k == total - 1:
            break
        if cancel[0] != 0:
            status, count = PlanStatus.CANCELLED, k + 1
            break
        state, stuck = track_progress(state, k, window, progress, pos_err, rot_err)
        if stuck:
            status, count = PlanStatus.STAGNATION, k + 1
            break
        for j in range(n):
            q[j] = min(max(q[j] + ws.x[j] * dt, robot.lower[j]), robot.upper[j])
            previous[j] = ws.x[j]
    return status, count, qs[:count], qds[:count], positions[:count], quats[:count], twists[:count], \
        clear[:count], step_culprit(owned.out)


@njit(cache=True)
def autonomy_step(q: np.ndarray, previous: np.ndarray, has_prev: bool, robot: RobotArrays, scene: Scene,
                  goal_p: np.ndarray, goal_q: np.ndarray, params: np.ndarray, ws: Workspace) -> int:
    """One whole-body field evaluation at ``q`` for shared control: the start offsets are taken at ``q`` itself
    (pairs already closer than d_s may not approach further: ``hold``), then :func:`velocity_from_segments`."""
    joint_transforms(q, robot.parents, robot.place_rot, robot.place_pos, robot.axes, robot.kinds, ws.rotations,
                     ws.origins)
    _segments_near(robot, scene, ws)
    _task(robot, goal_p, goal_q, params, ws)
    return velocity_from_segments(q, previous, has_prev, robot, scene, params, ws, params[DAMPING], True)
