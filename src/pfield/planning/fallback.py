"""The planners' global fallback, end to end: goal check, search, shortcut, tracking by the field.

:func:`whole_body_fallback` and :func:`task_space_fallback` are called by the whole-body and task-space
planners when the field alone ends in stagnation or at the iteration limit (and ``global_fallback`` is
on); see :mod:`pfield.planning.global_search` for the method. Each returns a :class:`FallbackOutcome`:
the tracked motion (in the planner's own loop format) when it reached the goal and passed the certificate
(:func:`pfield.planning.certify.certify_path`: exact meshes, every waypoint and every 0.01 rad), else why not.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pfield.field.config import FieldConfig
from pfield.geometry import Obstacle
from pfield.planning import _whole_body_layout as _wb
from pfield.planning.certify import certify_path
from pfield.planning.global_search import (
    GlobalOptions,
    SearchResult,
    goal_configurations,
    joint_space_search,
    orientations_along,
    point_space_search,
    search_margin,
    track,
)
from pfield.planning.result import PLANNERS
from pfield.planning.status import PlanStatus
from pfield.robot.model import RobotModel
from pfield.spatial import Pose

__all__ = ["FALLBACK_PLANNER", "FIELD_PLANNER", "FallbackOutcome", "task_space_fallback", "whole_body_fallback"]

_LOG = logging.getLogger(__name__)
FIELD_PLANNER, FALLBACK_PLANNER = PLANNERS
"""Values of :attr:`PlannedPath.planner`: the field alone, or the field tracking the global search's path."""


@dataclass(frozen=True, eq=False)
class FallbackOutcome:
    """``loop``: the tracked plan (the planner's loop outputs) when it reached the goal, else None and
    ``status`` says why (GOAL_INVALID, START_INVALID, GLOBAL_NO_PATH, GLOBAL_TIME_LIMIT, or how the
    tracking ended: COLLISION, SELF_COLLISION, STAGNATION, ITERATION_LIMIT, CANCELLED), ``reason`` in words."""

    loop: tuple[Any, ...] | None
    status: PlanStatus
    reason: str
    search: SearchResult | None


def whole_body_fallback(robot: RobotModel, arrays: _wb.RobotArrays, scene: _wb.Scene, start: NDArray[np.float64],
                        last: NDArray[np.float64], goal: Pose, params: NDArray[np.float64], max_iterations: int,
                        config: FieldConfig, obstacles: Sequence[Obstacle] | None,
                        options: GlobalOptions, cancel: NDArray[np.uint8] | None = None,
                        goal_configuration: NDArray[np.float64] | None = None) -> FallbackOutcome:
    """Joint-space fallback from ``start`` (``last``: the field's final configuration, the first IK seed);
    ``cancel`` (a :class:`~pfield.planning.CancelToken`'s flag) stops the search and the tracking.
    ``goal_configuration``: the caller's joint goal at ``goal``, searched to instead of IK solutions.

    The search runs first with the goal's pairs allowed ``options.endpoint_band`` deeper than at the goal (a grasp
    goal's fitted model overlaps the object its meshes hold clear, and without the band hardly any motion leaves
    it); when the motion found that way fails the tracking or the certificate (the fingers swept into the object),
    once more without the band, within what is left of ``options.time_limit``. Measured on 20 problems of each of
    four MotionBenchMaker UR5 scenes (table_pick, table_under_pick, bookshelf_small, bookshelf_thin): without the
    band 72/80 solved (the failures: time limits), with it alone 72/80 (7 of the 8 failures: certificate
    contacts), both in turn 78/80."""
    margin = search_margin(config, options)
    # twice the joint-limit dampers' stop: the tracking's target keeps some room from it
    joint_margin = 2.0 * float(params[_wb.JOINT_SAFETY])
    goals, why = goal_configurations(robot, goal, (last, start), arrays, scene, margin, obstacles, options,
                                     joint_margin, goal_configuration, start=start)
    if not goals:
        _LOG.info("global fallback: %s", why)
        return FallbackOutcome(None, PlanStatus.GOAL_INVALID, why, None)
    deadline = time.perf_counter() + options.time_limit
    outcome = FallbackOutcome(None, PlanStatus.GLOBAL_TIME_LIMIT, "global fallback: no time left", None)
    for goal_band in (options.endpoint_band, 0.0):  # the goal's band first, then none (endpoint_scene)
        remaining = deadline - time.perf_counter()
        if remaining <= 0.0:
            break
        outcome = _search_and_track(robot, arrays, scene, start, goals, goal, params, max_iterations, margin,
                                    obstacles, replace(options, time_limit=remaining), cancel, goal_band)
        if outcome.loop is not None or outcome.search is None or not outcome.search.found:
            break  # reached, or the search itself failed (without the band it is no easier)
    return outcome


def _search_and_track(robot: RobotModel, arrays: _wb.RobotArrays, scene: _wb.Scene, start: NDArray[np.float64],
                      goals: list[NDArray[np.float64]], goal: Pose, params: NDArray[np.float64], max_iterations: int,
                      margin: float, obstacles: Sequence[Obstacle] | None, options: GlobalOptions,
                      cancel: NDArray[np.uint8] | None, goal_band: float) -> FallbackOutcome:
    """One search to ``goals`` (``goal_band``: :func:`~pfield.planning.global_search.endpoint_scene`'s), the
    field's tracking of its path and the certificate of the tracked motion."""
    search, search_scene = joint_space_search(robot, arrays, scene, start, goals, margin, options, cancel, goal_band)
    _log_search(search)
    if not search.found:
        _LOG.info("global fallback: %s", search.reason)
        return FallbackOutcome(None, search.status, search.reason, search)
    loop = track(robot, arrays, search_scene, search.path, goal, params, max_iterations, options, cancel)
    tracked = PlanStatus(loop[0])
    if tracked != PlanStatus.REACHED:
        reason = f"global fallback: tracking the searched path ended with {tracked.name}"
        _LOG.info(reason)
        return FallbackOutcome(None, tracked, reason, search)
    certificate = certify_path(robot, list(obstacles or ()), loop[2], options.exact_resolution)
    if not certificate.clear:
        reason = f"global fallback: the tracked path fails the certificate ({certificate.describe()})"
        _LOG.info(reason)
        status = PlanStatus.SELF_COLLISION if certificate.self_collision else PlanStatus.COLLISION
        return FallbackOutcome(None, status, reason, search)
    return FallbackOutcome(loop, PlanStatus.REACHED, "", search)


def task_space_fallback(run_to: Any, scene: _wb.Scene, start: Pose, goal: Pose, config: FieldConfig,
                        options: GlobalOptions, cancel: NDArray[np.uint8] | None = None) -> FallbackOutcome:
    """R³ fallback from ``start``; ``run_to(state, waypoint, final)`` runs the field's compiled loop from the
    7-vector ``state`` to the ``waypoint`` pose and returns ``(status, poses, twists, clearances)``.

    Intermediate vertices count as reached within ``max(2 · goal tolerance, point_step / 2)``; the last one
    with the plan's own tolerances."""
    margin = search_margin(config, options)
    search = point_space_search(scene, np.asarray(start.position), np.asarray(goal.position), margin, options,
                                cancel)
    _log_search(search)
    if not search.found:
        _LOG.info("global fallback: %s", search.reason)
        return FallbackOutcome(None, search.status, search.reason, search)
    targets = orientations_along(search.path, start, goal)[1:]
    state = np.concatenate([start.position, start.orientation])
    pieces: list[tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]] = []
    for k, target in enumerate(targets):
        status, poses, twists, clearances = run_to(state, target, k == len(targets) - 1)
        pieces.append((poses, twists, clearances) if not pieces else (poses[1:], twists[1:], clearances[1:]))
        if status != PlanStatus.REACHED:
            reason = (f"global fallback: the field could not follow the searched path to vertex {k + 1} "
                      f"({PlanStatus(status).name})")
            _LOG.info(reason)
            return FallbackOutcome(None, PlanStatus(status), reason, search)
        state = poses[-1].copy()
    poses = np.concatenate([p for p, _, _ in pieces])
    twists = np.concatenate([t for _, t, _ in pieces])
    clearances = np.concatenate([c for _, _, c in pieces])
    return FallbackOutcome((poses, twists, clearances), PlanStatus.REACHED, "", search)


def _log_search(search: SearchResult) -> None:
    """One debug record per search; ``states_checked`` and ``seconds`` are attributes of the record."""
    _LOG.debug("global search: %s after %d state checks in %.4f s", "found a path" if search.found else "no path",
               search.states_checked, search.seconds,
               extra={"states_checked": search.states_checked, "seconds": search.seconds})
