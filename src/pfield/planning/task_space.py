"""Task-space planning: integrate the field's constrained twist from a start pose to the goal.

The path is produced by one call of the compiled core's loop (``src/core/planning/task_space.hpp``: RK4 over
R³ × SO(3) with the exponential map, timestamps i·dt, the start recorded; the GIL is released while it runs).
Every waypoint carries its clearance, and every segment between waypoints is checked against the obstacles. A plan
that stops short says why in ``failure_reason``: stagnation (no progress toward the goal over
``stagnation_window`` seconds), collision, or the iteration limit.
"""

from __future__ import annotations

import logging
import math

import numpy as np
from numpy.typing import NDArray

from pfield._core import field as _core_field
from pfield.errors import InvalidInput
from pfield.field.field import PotentialField
from pfield.geometry import signed_distances
from pfield.planning.cancel import cancel_flag
from pfield.planning.options import DEFAULT_MAX_ITERATIONS, MAX_ITERATIONS_LIMIT, PlanOptions
from pfield.planning.result import PLANNERS, PlannedPath
from pfield.planning.status import ROOT_CAUSES, PlanStatus
from pfield.spatial import Pose

__all__ = ["DEFAULT_MAX_ITERATIONS", "MAX_ITERATIONS_LIMIT", "plan_task_space"]

_log = logging.getLogger(__name__)
FIELD_PLANNER, FALLBACK_PLANNER = PLANNERS
_Buffers = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]
# The compiled loop writes into buffers of max_iterations + 1 rows (poses, twists, clearances) and a path keeps
# only the rows written, copied out. Buffers of the default size serve every plan up to it and are kept for the
# next plans, one set per plan running at once up to _SPARE_SETS (3.4 MB each, resident only where written):
# fresh ones cost an allocation and a page fault per page written at every plan, as much as a short plan takes.
_BUFFER_ROWS = DEFAULT_MAX_ITERATIONS + 1
_SPARE_SETS = 2
_spare_buffers: list[_Buffers] = []  # list.pop and append are atomic: threads share it safely
_POSITION_BYTES, _ORIENTATION_BYTES = np.dtype((np.void, 24)), np.dtype((np.void, 32))  # 3 and 4 doubles
_STATUSES = {int(status): status for status in PlanStatus}  # the loop returns PlanStatus values
# The flag of plans without a cancel token: nobody holds it, so nobody cancels it.
_NEVER_CANCELLED = cancel_flag(None)


def plan_task_space(
    field: PotentialField,
    start: Pose,
    dt: float | None = None,
    goal_tolerance: float | None = None,
    max_iterations: int | None = None,
    rotation_tolerance: float | None = None,
    *,
    global_fallback: bool | None = None,
    global_time_limit: float | None = None,
    options: PlanOptions | None = None,
) -> PlannedPath:
    """Plan from ``start`` to ``field.goal`` by integrating the constrained twist.

    Args:
        field: the potential field (goal, obstacles, parameters).
        start: start pose of the end effector (world frame).
        dt, goal_tolerance, max_iterations, rotation_tolerance: shorthands for the :class:`PlanOptions`
            fields of those names; given, they override ``options``'s.
        options: every planning setting (default ``PlanOptions()``: dt 0.01 s, tolerance 0.01 m, 30000
            steps, the config's rotation tolerance and stagnation window), and the cancel token.

    Returns a :class:`PlannedPath` whose ``status`` says how it ended; ``success`` is True when the last
    waypoint is within both tolerances. Bad arguments raise :class:`~pfield.errors.InvalidInput` naming the
    argument.
    """
    if not isinstance(start, Pose):
        raise InvalidInput("start", start, "expected a pfield.Pose")
    settings = PlanOptions.build(options, dt=dt, goal_tolerance=goal_tolerance, max_iterations=max_iterations,
                                 rotation_tolerance=rotation_tolerance, global_fallback=global_fallback,
                                 global_time_limit=global_time_limit).resolved(field.config)
    assert settings.rotation_tolerance is not None and settings.stagnation_progress is not None
    blocked = _goal_blocked(field)
    if blocked:
        return _single_point(field, start, blocked, PlanStatus.GOAL_INVALID)
    _, params, packed, aux = field.arrays
    iterations, step, window = settings.max_iterations, settings.dt, settings.stagnation_steps
    buffers = _take_buffers(iterations + 1)
    poses, twists, clearances = buffers
    start_array = np.concatenate([start.position, start.orientation])
    cancel = _NEVER_CANCELLED if settings.cancel is None else settings.cancel.flag
    count, code, obstacle = field.compiled.plan(start_array, step, settings.goal_tolerance,
                                                settings.rotation_tolerance, iterations, window,
                                                settings.stagnation_progress, cancel, poses, twists, clearances)
    status = _STATUSES[code]
    if status is PlanStatus.COLLISION and count == 1 and field.clearances(poses[:1, :3])[0] <= 0.0:
        status = PlanStatus.START_INVALID
    reason = "" if status is PlanStatus.REACHED else _reason(field, status, obstacle, poses[count - 1],
                                                             clearances[count - 1], count, step, window)
    # the path's own arrays (C-contiguous copies of the rows written); the buffers go back for the next plan
    path_arrays = (*_pose_columns(poses, count), twists[:count].copy(), clearances[:count].copy())
    _give_back(buffers)
    planner = FIELD_PLANNER
    # --- global fallback: the field stopped short; search positions, then let the field run to each vertex
    if settings.global_fallback and status in (PlanStatus.STAGNATION, PlanStatus.ITERATION_LIMIT):
        # imported here: the global search's kernels load only for the plans that need them, so a plan the
        # field completes alone never waits for them
        from pfield.planning.fallback import task_space_fallback
        from pfield.planning.global_search import GlobalOptions
        from pfield.planning.whole_body import make_scene

        global_options = GlobalOptions(time_limit=settings.global_time_limit, seed=settings.global_seed)
        tolerance, angle, progress = settings.goal_tolerance, settings.rotation_tolerance, settings.stagnation_progress

        def run_to(state: np.ndarray, target: Pose, final: bool) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
            sub_buffers = _take_buffers(iterations + 1)
            sub_poses, sub_twists, sub_clear = sub_buffers
            sub_tolerance = tolerance if final else max(2.0 * tolerance, 0.5 * global_options.point_step)
            # the field toward this vertex: its goal, the plan's obstacles and circulation axes (those of the
            # plan's own goal, so the field turns around each obstacle the same way at every vertex)
            toward = _core_field.Field(np.concatenate([target.position, target.orientation]), params, aux, *packed)
            sub_count, sub_status, _ = toward.plan(
                state, step, sub_tolerance, angle if final else math.pi - 1e-6, iterations, window, progress, cancel,
                sub_poses, sub_twists, sub_clear)
            out = (int(sub_status), sub_poses[:sub_count].copy(), sub_twists[:sub_count].copy(),
                   sub_clear[:sub_count].copy())
            _give_back(sub_buffers)
            return out

        outcome = task_space_fallback(run_to, make_scene(packed), start, field.goal, field.config, global_options,
                                      cancel)
        if outcome.loop is not None:
            loop_poses, loop_twists, loop_clearances = outcome.loop
            count, reason, planner, status = len(loop_poses), "", FALLBACK_PLANNER, PlanStatus.REACHED
            path_arrays = (np.array(loop_poses[:, :3], dtype=np.float64), np.array(loop_poses[:, 3:], dtype=np.float64),
                           np.array(loop_twists, dtype=np.float64), np.array(loop_clearances, dtype=np.float64))
        else:
            status = PlanStatus(outcome.status)  # the root cause first (see ROOT_CAUSES)
            reason = f"{outcome.reason}; {reason}" if status in ROOT_CAUSES else f"{reason}; {outcome.reason}"
    # --- end of the global fallback
    if reason:
        _log.info("task-space plan failed after %d steps: %s", count - 1, reason)
    positions, orientations, path_twists, path_clearances = path_arrays
    times = np.arange(count, dtype=np.float64)
    times *= step  # i·dt
    return PlannedPath._owned(status, reason, times, positions, orientations, path_twists, path_clearances, planner)


def _pose_columns(poses: NDArray[np.float64], count: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """New C-contiguous copies of the first ``count`` rows' positions (:, :3) and orientations (:, 3:) of the
    C-contiguous (N, 7) ``poses``. Each row's part is copied as one 24- or 32-byte item (the same bytes): numpy copies
    a float column slice three or four doubles at a time, 2-3 times slower for a plan's hundreds of rows."""
    positions, orientations = np.empty((count, 3)), np.empty((count, 4))
    positions.view(_POSITION_BYTES)[:, 0] = np.ndarray((count,), _POSITION_BYTES, poses, 0, (56,))
    orientations.view(_ORIENTATION_BYTES)[:, 0] = np.ndarray((count,), _ORIENTATION_BYTES, poses, 24, (56,))
    return positions, orientations


def _take_buffers(rows: int) -> _Buffers:
    """Output buffers of at least ``rows`` rows for the compiled loop: kept ones when ``rows`` fits them."""
    if rows <= _BUFFER_ROWS:
        try:
            return _spare_buffers.pop()
        except IndexError:
            rows = _BUFFER_ROWS
    return np.empty((rows, 7)), np.empty((rows, 6)), np.empty(rows)


def _give_back(buffers: _Buffers) -> None:
    """Keep ``buffers`` for the next plan (when of the kept size and fewer than _SPARE_SETS are kept); nothing
    may refer to them afterwards."""
    if len(buffers[2]) == _BUFFER_ROWS and len(_spare_buffers) < _SPARE_SETS:
        _spare_buffers.append(buffers)


def _goal_blocked(field: PotentialField) -> str:
    """Why the goal cannot be reached at all (inside or within safety_distance of an obstacle), or ''."""
    if not field.obstacles:
        return ""
    distances = _all_distances(field, field.goal.position)
    nearest = int(distances.argmin())
    distance = float(distances[nearest])
    if distance <= field.config.safety_distance:
        return (f"unreachable goal: it lies {distance:.4g} m from obstacle '{field.obstacles[nearest].id}', "
                f"within safety_distance ({field.config.safety_distance} m)")
    return ""


def _all_distances(field: PotentialField, point: np.ndarray) -> np.ndarray:
    points = np.array(point, dtype=np.float64, ndmin=2)  # (1, 3), a writable copy, as the other callers pass
    distances, _ = signed_distances(field.arrays.packed, points)
    return np.asarray(distances[0])


def _single_point(field: PotentialField, start: Pose, reason: str, status: PlanStatus) -> PlannedPath:
    clearance = field.clearances(start.position[None, :])
    return PlannedPath(
        success=False, failure_reason=reason, times=np.zeros(1), positions=start.position[None, :],
        orientations=start.orientation[None, :], twists=np.zeros((1, 6)), clearances=clearance, iterations=0,
        status=status,
    )


def _reason(field: PotentialField, status: PlanStatus, obstacle: int, last: np.ndarray, clearance: float,
            count: int, dt: float, window: int) -> str:
    """The sentence beside ``status``: what blocks (the nearest obstacle's id and distance) and where."""
    goal = field.goal
    position_error = float(np.linalg.norm(last[:3] - goal.position))
    rotation_error = goal.rotation_distance(Pose(last[:3], last[3:]))
    where = (f"{position_error:.4g} m and {rotation_error:.4g} rad from the goal at "
             f"({last[0]:.3f}, {last[1]:.3f}, {last[2]:.3f}) m")
    known = 0 <= obstacle < len(field.obstacles)
    name = f"'{field.obstacles[obstacle].id}'" if known else "an obstacle"
    nearest = f"nearest: {name}, {clearance:.4g} m away" if known else "no obstacle within reach"
    if status == PlanStatus.STAGNATION:
        return f"stagnation: no progress toward the goal for {window * dt:.3g} s, stopped {where} ({nearest})"
    if status == PlanStatus.START_INVALID:
        return f"collision: the start pose is inside {name}"
    if status == PlanStatus.COLLISION:
        return f"collision: the next step would enter {name} after t = {(count - 1) * dt:.4g} s, {where}"
    if status == PlanStatus.ITERATION_LIMIT:
        return f"iteration limit: {count - 1} steps without reaching the goal, stopped {where}"
    if status == PlanStatus.CANCELLED:
        return f"cancelled after {count - 1} steps, stopped {where}"
    if status == PlanStatus.NOT_FINITE:
        return "numerical failure: the state became non-finite"
    return f"unknown planner status {status!r}"
