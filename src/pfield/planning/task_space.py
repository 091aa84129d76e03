"""Task-space planning: integrate the field's constrained twist from a start pose to the goal.

The path is produced by one call of the compiled loop :func:`~pfield.planning._task_space_loop.plan_loop`
(RK4 over R³ × SO(3) with the exponential map, timestamps i·dt, the start recorded). Every waypoint
carries its clearance, and every segment between waypoints is checked against the obstacles. A plan
that stops short says why in ``failure_reason``: stagnation (no progress toward the goal over
``stagnation_window`` seconds), collision, or the iteration limit.
"""

from __future__ import annotations

import logging
import math
from typing import Any

import numpy as np

from pfield._validation import positive
from pfield.errors import InvalidInput
from pfield.field.field import PotentialField
from pfield.geometry import signed_distances
from pfield.planning._task_space_loop import (
    COLLISION,
    ITERATION_LIMIT,
    NOT_FINITE,
    REACHED,
    STAGNATION,
    plan_loop,
)
from pfield.planning.fallback import FALLBACK_PLANNER, FIELD_PLANNER, task_space_fallback
from pfield.planning.global_search import check_global_options
from pfield.planning.result import PlannedPath
from pfield.planning.whole_body import make_scene
from pfield.spatial import Pose

__all__ = ["DEFAULT_MAX_ITERATIONS", "MAX_ITERATIONS_LIMIT", "plan_task_space"]

DEFAULT_MAX_ITERATIONS = 30000
"""Used when ``max_iterations`` is 0 or negative (the PlanPath service's "0 or missing")."""
MAX_ITERATIONS_LIMIT = 2_000_000
"""Upper bound of ``max_iterations`` (the path buffers take 112 bytes per iteration)."""

_log = logging.getLogger(__name__)


def _check_iterations(value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise InvalidInput("max_iterations", value, "must be an integer")
    count = int(value)
    if count <= 0:
        return DEFAULT_MAX_ITERATIONS
    if count > MAX_ITERATIONS_LIMIT:
        raise InvalidInput("max_iterations", value, f"must be <= {MAX_ITERATIONS_LIMIT}")
    return count


def plan_task_space(
    field: PotentialField,
    start: Pose,
    dt: float = 0.01,
    goal_tolerance: float = 0.01,
    max_iterations: int = DEFAULT_MAX_ITERATIONS,
    rotation_tolerance: float | None = None,
    *,
    global_fallback: bool = True,
    global_time_limit: float | None = None,
) -> PlannedPath:
    """Plan from ``start`` to ``field.goal`` by integrating the constrained twist.

    Args:
        field: the potential field (goal, obstacles, parameters).
        start: start pose of the end effector (world frame).
        dt: integration step (s), > 0; waypoint i is at time i·dt.
        goal_tolerance: position tolerance (m), > 0.
        max_iterations: step limit; 0 or negative means 30000.
        rotation_tolerance: orientation tolerance (rad) in (0, π); None uses the config's.

        global_fallback: when the field stagnates or reaches the iteration limit, search a path of
            positions globally (R³, orientation slerped) and let the field run to its vertices in turn
            (:mod:`pfield.planning.fallback`); ``planner`` says which produced the path.
        global_time_limit: wall-clock limit of that search (s); None: 2 s.

    Returns a :class:`PlannedPath`; ``success`` is True when the last waypoint is within both
    tolerances. Bad arguments raise :class:`~pfield.errors.InvalidInput` naming the argument.
    """
    if not isinstance(start, Pose):
        raise InvalidInput("start", start, "expected a pfield.Pose")
    step = positive("dt", dt)
    tolerance = positive("goal_tolerance", goal_tolerance)
    iterations = _check_iterations(max_iterations)
    fallback, global_options = check_global_options(global_fallback, global_time_limit)
    angle = field.config.rotation_tolerance if rotation_tolerance is None else rotation_tolerance
    angle = positive("rotation_tolerance", angle)
    if angle >= math.pi:
        raise InvalidInput("rotation_tolerance", rotation_tolerance, "must be < pi rad")
    blocked = _goal_blocked(field)
    if blocked:
        return _single_point(field, start, blocked)
    goal, params, packed, aux = field.arrays
    window = max(10, round(field.config.stagnation_window / step))
    poses, twists, clearances = np.empty((iterations + 1, 7)), np.empty((iterations + 1, 6)), np.empty(iterations + 1)
    start_array = np.concatenate([start.position, start.orientation])
    count, status, obstacle = plan_loop(start_array, goal, params, packed, aux, step, tolerance, angle, iterations,
                                        window, poses, twists, clearances)
    reason = "" if status == REACHED else _reason(field, status, obstacle, poses[count - 1], count, step, window)
    planner = FIELD_PLANNER
    # --- global fallback: the field stopped short; search positions, then let the field run to each vertex
    if fallback and status in (STAGNATION, ITERATION_LIMIT):
        def run_to(state: np.ndarray, target: Pose, final: bool) -> tuple[bool, np.ndarray, np.ndarray, np.ndarray]:
            goal_arrays = field.with_goal(target).arrays
            sub_poses, sub_twists, sub_clear = np.empty_like(poses), np.empty_like(twists), np.empty_like(clearances)
            sub_tolerance = tolerance if final else max(2.0 * tolerance, 0.5 * global_options.point_step)
            sub_count, sub_status, _ = plan_loop(
                state, goal_arrays.goal, params, packed, aux, step, sub_tolerance, angle if final else math.pi - 1e-6,
                iterations, window, sub_poses, sub_twists, sub_clear)
            return (sub_status == REACHED, sub_poses[:sub_count].copy(), sub_twists[:sub_count].copy(),
                    sub_clear[:sub_count].copy())

        outcome = task_space_fallback(run_to, make_scene(packed), start, field.goal, field.config, global_options)
        if outcome.loop is not None:
            found_poses, found_twists, found_clear = outcome.loop
            count, reason, planner, status = len(found_poses), "", FALLBACK_PLANNER, REACHED
            poses, twists, clearances = found_poses, found_twists, found_clear
        else:
            reason = f"{reason}; {outcome.reason}"
    # --- end of the global fallback
    if reason:
        _log.info("task-space plan failed after %d steps: %s", count - 1, reason)
    return PlannedPath(
        success=status == REACHED, failure_reason=reason, times=np.arange(count, dtype=np.float64) * step,
        positions=poses[:count, :3], orientations=poses[:count, 3:], twists=twists[:count],
        clearances=clearances[:count], iterations=count - 1, planner=planner,
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
    distances, _ = signed_distances(field.arrays.packed, np.ascontiguousarray(point, dtype=np.float64)[None, :])
    return np.asarray(distances[0])


def _single_point(field: PotentialField, start: Pose, reason: str) -> PlannedPath:
    clearance = field.clearances(start.position[None, :])
    return PlannedPath(
        success=False, failure_reason=reason, times=np.zeros(1), positions=start.position[None, :],
        orientations=start.orientation[None, :], twists=np.zeros((1, 6)), clearances=clearance, iterations=0,
    )


def _reason(
    field: PotentialField, status: int, obstacle: int, last: np.ndarray, count: int, dt: float, window: int
) -> str:
    goal = field.goal
    position_error = float(np.linalg.norm(last[:3] - goal.position))
    rotation_error = goal.rotation_distance(Pose(last[:3], last[3:]))
    where = f"{position_error:.4g} m and {rotation_error:.4g} rad from the goal"
    name = f"'{field.obstacles[obstacle].id}'" if 0 <= obstacle < len(field.obstacles) else "an obstacle"
    if status == STAGNATION:
        return f"stagnation: no progress toward the goal for {window * dt:.3g} s, stopped {where} (nearest: {name})"
    if status == COLLISION:
        if count == 1 and field.clearances(last[None, :3])[0] <= 0.0:
            return f"collision: the start pose is inside {name}"
        return f"collision: the next step would enter {name} after t = {(count - 1) * dt:.4g} s, {where}"
    if status == ITERATION_LIMIT:
        return f"iteration limit: {count - 1} steps without reaching the goal, stopped {where}"
    if status == NOT_FINITE:
        return "numerical failure: the state became non-finite"
    return f"unknown planner status {status}"
