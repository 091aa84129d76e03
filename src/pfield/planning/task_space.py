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
    poses, twists, clearances = np.empty((iterations + 1, 7)), np.empty((iterations + 1, 6)), np.empty(iterations + 1)
    start_array = np.concatenate([start.position, start.orientation])
    cancel = cancel_flag(settings.cancel)
    count, code, obstacle = field._core.plan(start_array, step, settings.goal_tolerance, settings.rotation_tolerance,
                                             iterations, window, settings.stagnation_progress, cancel, poses, twists,
                                             clearances)
    status = PlanStatus(code)
    if status == PlanStatus.COLLISION and count == 1 and field.clearances(poses[:1, :3])[0] <= 0.0:
        status = PlanStatus.START_INVALID
    reason = "" if status == PlanStatus.REACHED else _reason(field, status, obstacle, poses[count - 1],
                                                             clearances[count - 1], count, step, window)
    planner = FIELD_PLANNER
    # --- global fallback: the field stopped short; search positions, then let the field run to each vertex
    if settings.global_fallback and status in (PlanStatus.STAGNATION, PlanStatus.ITERATION_LIMIT):
        # imported here: the global search's kernels load only for the plans that need them, so a plan the
        # field completes alone never waits for them
        from pfield.planning.fallback import task_space_fallback
        from pfield.planning.global_search import GlobalOptions
        from pfield.planning.whole_body import make_scene

        global_options = GlobalOptions(time_limit=settings.global_time_limit)
        tolerance, angle, progress = settings.goal_tolerance, settings.rotation_tolerance, settings.stagnation_progress

        def run_to(state: np.ndarray, target: Pose, final: bool) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
            sub_poses, sub_twists, sub_clear = np.empty_like(poses), np.empty_like(twists), np.empty_like(clearances)
            sub_tolerance = tolerance if final else max(2.0 * tolerance, 0.5 * global_options.point_step)
            # the field toward this vertex: its goal, the plan's obstacles and circulation axes (those of the
            # plan's own goal, so the field turns around each obstacle the same way at every vertex)
            toward = _core_field.Field(np.concatenate([target.position, target.orientation]), params, aux, *packed)
            sub_count, sub_status, _ = toward.plan(
                state, step, sub_tolerance, angle if final else math.pi - 1e-6, iterations, window, progress, cancel,
                sub_poses, sub_twists, sub_clear)
            return (int(sub_status), sub_poses[:sub_count].copy(), sub_twists[:sub_count].copy(),
                    sub_clear[:sub_count].copy())

        outcome = task_space_fallback(run_to, make_scene(packed), start, field.goal, field.config, global_options,
                                      cancel)
        if outcome.loop is not None:
            poses, twists, clearances = outcome.loop
            count, reason, planner, status = len(poses), "", FALLBACK_PLANNER, PlanStatus.REACHED
        else:
            status = outcome.status  # the root cause first (see ROOT_CAUSES)
            reason = f"{outcome.reason}; {reason}" if status in ROOT_CAUSES else f"{reason}; {outcome.reason}"
    # --- end of the global fallback
    if reason:
        _log.info("task-space plan failed after %d steps: %s", count - 1, reason)
    return PlannedPath(
        success=status == PlanStatus.REACHED, failure_reason=reason, times=np.arange(count, dtype=np.float64) * step,
        positions=poses[:count, :3], orientations=poses[:count, 3:], twists=twists[:count],
        clearances=clearances[:count], iterations=count - 1, status=status, planner=planner,
    )


def _goal_blocked(field: PotentialField) -> str:
    """Why the goal cannot be reached at all (inside or within safety_distance of an obstacle), or ''."""
    if not field.obstacles:
        return ""
    distances = _all_distances(field, field.goal.position)
    nearest = int(np.argmin(distances))
    if distances[nearest] <= field.config.safety_distance:
        return (f"unreachable goal: it lies {distances[nearest]:.4g} m from obstacle '{field.obstacles[nearest].id}', "
                f"within safety_distance ({field.config.safety_distance} m)")
    return ""


def _all_distances(field: PotentialField, point: np.ndarray) -> np.ndarray:
    points = np.array(point, dtype=np.float64).reshape(1, 3)  # a writable copy, as the other callers pass
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
