"""The compiled task-space planning loop: RK4 on the constrained twist over R³ × SO(3) (numba).

One call plans the whole path; Python is not on the per-step path. The state is the end-effector
position p (m) and unit quaternion q (x, y, z, w), both in the world frame. The twist (v, ω) of
:func:`~pfield.field._evaluate.constrained_twist` is a world-frame point velocity and angular velocity,
so the flow is ṗ = v, q̇ = ½ ω ⊗ q and one step of size h maps (p, q) to (p + h v, exp(h ω) ⊗ q), the
exponential map with left (world-frame) increments. RK4 (Munthe-Kaas 1998 with the first-order dexp
approximation, as in Crouch & Grossman 1993) evaluates the twist at four stage poses reached with those
increments and applies the weighted mean (k1 + 2k2 + 2k3 + k4)/6. All four stages share the previous
step's twist for the rate limit, so the mean — a convex combination — obeys the velocity and
acceleration limits too.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from pfield._spatial_kernels import left_increment
from pfield.field._evaluate import constrained_twist
from pfield.field._unowned import unowned, unowned_packed
from pfield.geometry._packed import PackedObstacles
from pfield.geometry._sdf import min_signed_distance
from pfield.planning._progress import track_progress
from pfield.planning.status import PlanStatus

_SEGMENT_SAMPLES = 16


@njit(cache=True, inline="always")
def rk4_twist(
    p: np.ndarray, q: np.ndarray, goal: np.ndarray, params: np.ndarray, packed: PackedObstacles,
    aux: np.ndarray, previous: np.ndarray, dt: float, scratch: np.ndarray, out: np.ndarray,
) -> tuple[float, int]:
    """out ← RK4 mean twist of one step of ``dt`` from (p, q); returns the clearance at p and its obstacle.

    ``scratch`` is a (5, 6) work array: the stage twists k1…k4 and the stage position. The four
    stages share one call site of the (inlined) twist kernel to keep the compiled code small.
    """
    stage = scratch[4, :3]
    clearance, nearest = math.inf, -1
    for s in range(4):
        h = 0.0 if s == 0 else (dt if s == 3 else 0.5 * dt)
        k = max(s - 1, 0)
        for j in range(3):
            stage[j] = p[j] + h * scratch[k, j]
        sx, sy, sz, sw = left_increment(q[0], q[1], q[2], q[3], scratch[k, 3], scratch[k, 4], scratch[k, 5], h)
        scratch[s, 0], scratch[s, 1], scratch[s, 2], scratch[s, 3], scratch[s, 4], scratch[s, 5], d, i = (
            constrained_twist(stage, sx, sy, sz, sw, goal, params, packed, aux, previous, True, dt))
        if s == 0:
            clearance, nearest = d, i
    for j in range(6):
        out[j] = (scratch[0, j] + 2.0 * scratch[1, j] + 2.0 * scratch[2, j] + scratch[3, j]) / 6.0
    return clearance, nearest


@njit(cache=True, inline="always")
def segment_is_free(
    packed: PackedObstacles, poses: np.ndarray, row: int, b: np.ndarray, clearance_a: float, clearance_b: float,
    point: np.ndarray,
) -> bool:
    """True when the straight segment from a = ``poses[row, :3]`` to b stays outside every obstacle.

    The signed distance is 1-Lipschitz, so the segment is certified free when ‖b − a‖ < d(a) + d(b);
    otherwise it is sampled densely (a failed certificate is rare: steps are far smaller than clearances).
    """
    ax, ay, az = poses[row, 0], poses[row, 1], poses[row, 2]
    length = math.sqrt((b[0] - ax) ** 2 + (b[1] - ay) ** 2 + (b[2] - az) ** 2)
    if clearance_a > 0.0 and clearance_b > 0.0 and length < clearance_a + clearance_b:
        return True
    for s in range(1, _SEGMENT_SAMPLES):
        t = s / _SEGMENT_SAMPLES
        point[0], point[1], point[2] = ax + t * (b[0] - ax), ay + t * (b[1] - ay), az + t * (b[2] - az)
        if min_signed_distance(packed, point)[0] <= 0.0:
            return False
    return True


@njit(cache=True)
def _goal_errors(p: np.ndarray, q: np.ndarray, goal: np.ndarray) -> tuple[float, float]:
    distance = math.sqrt((goal[0] - p[0]) ** 2 + (goal[1] - p[1]) ** 2 + (goal[2] - p[2]) ** 2)
    dot = abs(q[0] * goal[3] + q[1] * goal[4] + q[2] * goal[5] + q[3] * goal[6])
    return distance, 2.0 * math.acos(min(dot, 1.0))


@njit(cache=True, nogil=True)  # another thread may cancel the plan while it runs
def plan_loop(
    start: np.ndarray, goal: np.ndarray, params: np.ndarray, packed: PackedObstacles, aux: np.ndarray,
    dt: float, tolerance: float, rotation_tolerance: float, max_iterations: int, window: int, progress: float,
    cancel: np.ndarray, poses: np.ndarray, twists: np.ndarray, clearances: np.ndarray,
) -> tuple[int, PlanStatus, int]:
    """Plan from ``start`` (7,) toward ``goal`` (7,); fill ``poses`` (max_iterations + 1, 7), ``twists``
    (…, 6) and ``clearances`` (…,) and return (waypoint count, :class:`PlanStatus`, obstacle index or −1).

    Stops at the first waypoint within ``tolerance`` (m) and ``rotation_tolerance`` (rad) of the goal
    (REACHED), before a waypoint that is in collision or whose segment is (COLLISION; the count then
    excludes that waypoint, so the returned path stays free unless the start itself is inside), when the
    stagnation rule of :mod:`pfield.planning._progress` fires for ``window`` steps and ``progress``
    (STAGNATION), when ``cancel[0]`` is set (CANCELLED, read every step) or after ``max_iterations``
    steps (ITERATION_LIMIT).
    """
    state, work = start.copy(), np.zeros((8, 6))
    return _run(state, work, goal, params, packed, aux, dt, tolerance, rotation_tolerance, max_iterations, window,
                progress, cancel, poses, twists, clearances)


@njit(cache=True)
def _run(
    state: np.ndarray, work: np.ndarray, goal: np.ndarray, params: np.ndarray, packed: PackedObstacles,
    aux: np.ndarray, dt: float, tolerance: float, rotation_tolerance: float, max_iterations: int, window: int,
    progress: float, cancel: np.ndarray, poses: np.ndarray, twists: np.ndarray, clearances: np.ndarray,
) -> tuple[int, PlanStatus, int]:
    """The loop of :func:`plan_loop`; ``state`` (7,) is the start pose, ``work`` an (8, 6) scratch array.

    Every array belongs to the caller for the whole call, so the loop works on unowned views of them.
    """
    poses[0, :] = state
    p, q = unowned(state[:3]), unowned(state[3:])
    previous, twist, scratch, point = unowned(work[5]), unowned(work[6]), unowned(work[:5]), unowned(work[7, :3])
    goal, params, aux, packed = unowned(goal), unowned(params), unowned(aux), unowned_packed(packed)
    poses, twists, clearances = unowned(poses), unowned(twists), unowned(clearances)
    errors = (math.inf, math.inf, math.inf, math.inf)
    for i in range(max_iterations + 1):
        clearance, nearest = rk4_twist(p, q, goal, params, packed, aux, previous, dt, scratch, twist)
        for j in range(6):
            twists[i, j] = twist[j]
        clearances[i] = clearance
        if clearance <= 0.0:  # keep only the collision-free waypoints (the start is always kept)
            return max(i, 1), PlanStatus.COLLISION, nearest
        if i > 0 and not segment_is_free(packed, poses, i - 1, p, clearances[i - 1], clearance, point):
            return i, PlanStatus.COLLISION, min_signed_distance(packed, p)[4]
        position_error, rotation_error = _goal_errors(p, q, goal)
        if position_error <= tolerance and rotation_error <= rotation_tolerance:
            return i + 1, PlanStatus.REACHED, -1
        if i == max_iterations:
            return i + 1, PlanStatus.ITERATION_LIMIT, nearest
        if cancel[0] != 0:
            return i + 1, PlanStatus.CANCELLED, nearest
        errors, stuck = track_progress(errors, i, window, progress, position_error, rotation_error)
        if stuck:
            return i + 1, PlanStatus.STAGNATION, nearest
        if not _advance(p, q, twist, previous, dt, poses, i + 1):
            return i + 2, PlanStatus.NOT_FINITE, -1
    return max_iterations + 1, PlanStatus.ITERATION_LIMIT, -1


@njit(cache=True, inline="always")
def _advance(
    p: np.ndarray, q: np.ndarray, twist: np.ndarray, previous: np.ndarray, dt: float, poses: np.ndarray, row: int
) -> bool:
    """Apply ``twist`` for ``dt`` (p += dt v, q ← exp(dt ω) ⊗ q), keep it as the previous twist and record
    the new pose in ``poses[row]``; False when the position is no longer finite."""
    for j in range(3):
        p[j] += dt * twist[j]
    q[0], q[1], q[2], q[3] = left_increment(q[0], q[1], q[2], q[3], twist[3], twist[4], twist[5], dt)
    for j in range(6):
        previous[j] = twist[j]
    for j in range(3):
        poses[row, j] = p[j]
    for j in range(4):
        poses[row, 3 + j] = q[j]
    return math.isfinite(p[0]) and math.isfinite(p[1]) and math.isfinite(p[2])
