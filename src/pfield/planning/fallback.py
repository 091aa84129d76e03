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
from pfield.planning.certify import Certificate, certify_path, resolution_grid
from pfield.planning.global_search import (
    GlobalOptions,
    Region,
    SearchResult,
    contact_region,
    goal_configurations,
    in_region,
    joint_space_search,
    orientations_along,
    point_space_search,
    search_margin,
    self_contact_slack,
    track,
)
from pfield.planning.result import PLANNERS
from pfield.planning.status import PlanStatus
from pfield.robot.collision import CollisionChecker
from pfield.robot.model import RobotModel
from pfield.spatial import Pose

__all__ = ["FALLBACK_PLANNER", "FIELD_PLANNER", "FallbackOutcome", "task_space_fallback", "whole_body_fallback"]

_LOG = logging.getLogger(__name__)
FIELD_PLANNER, FALLBACK_PLANNER = PLANNERS
"""Values of :attr:`PlannedPath.planner`: the field alone, or the field tracking the global search's path."""


@dataclass(frozen=True, eq=False)
class FallbackOutcome:
    """``loop``: the tracked plan (the planner's loop outputs) when it reached the goal, else None and
    ``status`` says why (GOAL_INVALID, START_INVALID, GLOBAL_TIME_LIMIT, or how the
    tracking ended: COLLISION, SELF_COLLISION, STAGNATION, ITERATION_LIMIT, CANCELLED), ``reason`` in words."""

    loop: tuple[Any, ...] | None
    status: PlanStatus
    reason: str
    search: SearchResult | None


def whole_body_fallback(robot: RobotModel, arrays: _wb.RobotArrays, scene: _wb.Scene, start: NDArray[np.float64],
                        last: NDArray[np.float64], goal: Pose, params: NDArray[np.float64], max_iterations: int,
                        config: FieldConfig, obstacles: Sequence[Obstacle] | None,
                        options: GlobalOptions, cancel: NDArray[np.uint8] | None = None,
                        goal_configuration: NDArray[np.float64] | None = None,
                        checker: CollisionChecker | None = None) -> FallbackOutcome:
    """Joint-space fallback from ``start`` (``last``: the field's final configuration, the first IK seed);
    ``cancel`` (a :class:`~pfield.planning.CancelToken`'s flag) stops the search and the tracking.
    ``goal_configuration``: the caller's joint goal at ``goal``, searched to instead of IK solutions. ``checker``:
    the exact check of ``robot`` among ``obstacles`` (the plan's own; by default one is made).

    The search runs first with the goal's pairs allowed ``options.endpoint_band`` deeper than at the goal (a grasp
    goal's fitted model overlaps the object its meshes hold clear, and without the band hardly any motion leaves
    it); when the motion found that way fails the tracking or the certificate (the fingers swept into the object),
    once more without the band, within what is left of ``options.time_limit``. Measured on 20 problems of each of
    four MotionBenchMaker UR5 scenes (table_pick, table_under_pick, bookshelf_small, bookshelf_thin): without the
    band 72/80 solved (the failures: time limits), with it alone 72/80 (7 of the 8 failures: certificate
    contacts), both in turn 78/80.

    Lazy exact checking (issue 34): when the tracked motion fails the certificate (or the tracking stops) and the
    exact check finds contacts on the searched path or the tracked motion, each becomes a region of certain contact
    (:func:`~pfield.planning.global_search.contact_region`) that every later search of this call avoids, and the
    search runs again with the same band while time is left; the band is dropped when an attempt finds no new
    contact. On the UR5 bookshelf_small problems 9, 30 and 33, every path both bands searched went 13–20 mm into
    the meshes of forearm_link and wrist_2_link (a pair the fitted primitives over-cover by up to 20 mm in one place
    and under-cover by 2 mm in another, so the link model cannot tell their passage from their contact); with the
    regions, 2–7 searches of 0.06–0.5 s each found clear paths. The search's self pairs may touch on the fitted
    model (:func:`~pfield.planning.global_search.self_contact_slack`; the obstacles keep the margin)."""
    margin = search_margin(config, options)
    # twice the joint-limit dampers' stop: the tracking's target keeps some room from it
    joint_margin = 2.0 * float(params[_wb.JOINT_SAFETY])
    listed = list(obstacles or ())
    exact = checker or CollisionChecker(robot, listed)
    goals, why = goal_configurations(robot, goal, (last, start), arrays, scene, margin, obstacles, options,
                                     joint_margin, goal_configuration, start=start, checker=exact)
    if not goals:
        _LOG.info("global fallback: %s", why)
        return FallbackOutcome(None, PlanStatus.GOAL_INVALID, why, None)
    deadline = time.perf_counter() + options.time_limit
    outcome = FallbackOutcome(None, PlanStatus.GLOBAL_TIME_LIMIT, "global fallback: no time left", None)
    forbidden: list[Region] = []  # contacts the exact check found, kept across the attempts (contact_region)
    slack = self_contact_slack(arrays, margin)  # the self pairs may touch on the fitted model
    for attempt in range(SEARCH_SEEDS):
        seeded = replace(options, seed=options.seed + _SEED_STEP * attempt)
        for goal_band in (options.endpoint_band, 0.0):  # the goal's band first, then none (endpoint_scene)
            while (remaining := deadline - time.perf_counter()) > 0.0:
                outcome, regions = _search_and_track(robot, arrays, scene, start, goals, goal, params,
                                                     max_iterations, margin, listed, exact,
                                                     replace(seeded, time_limit=remaining), cancel, goal_band,
                                                     forbidden, slack)
                fresh = [r for r in regions if not any(in_region(r[0], known) for known in forbidden)]
                if not fresh:
                    break  # no contact, or one the search's resolution stepped over (a forbidden region holds it)
                forbidden += fresh  # contacts: search again around them, with the same band
            if _settled(outcome):
                break  # reached, or the search itself failed (without the band it is no easier)
        if _settled(outcome):
            break  # else a path was found and its motion failed with nothing new to forbid: another seed
    return outcome


def _settled(outcome: FallbackOutcome) -> bool:
    """Whether another band or seed cannot help: the motion was reached, or the search itself found no path."""
    return outcome.loop is not None or outcome.search is None or not outcome.search.found


SEARCH_SEEDS = 3
"""Seeds the fallback searches with, one after the other, while a path is found whose tracked motion fails (the
tracking stops, or the exact check finds a contact a forbidden region already holds) with both bands: a search
is a function of its seed, so the same seed finds the same path again, where another seed finds another.
Measured (issue 34) with edges checked every 0.03 rad: on the Panda's MotionBenchMaker bookshelf_small 5 both
bands' searches found one path whose tracking stalled 2 mm under the top shelf (STAGNATION), the second seed's
was tracked."""
_SEED_STEP = 104_729  # seed offset of each further attempt (a prime; the searches' restarts step by 7919)


def _search_and_track(robot: RobotModel, arrays: _wb.RobotArrays, scene: _wb.Scene, start: NDArray[np.float64],
                      goals: list[NDArray[np.float64]], goal: Pose, params: NDArray[np.float64], max_iterations: int,
                      margin: float, obstacles: list[Obstacle], exact: CollisionChecker, options: GlobalOptions,
                      cancel: NDArray[np.uint8] | None, goal_band: float, forbidden: Sequence[Region],
                      self_slack: NDArray[np.float64] | None = None) -> tuple[FallbackOutcome, list[Region]]:
    """One search to ``goals`` (``goal_band``: :func:`~pfield.planning.global_search.endpoint_scene`'s; states in
    ``forbidden`` invalid), the field's tracking of its path and the certificate of the tracked motion. When that
    fails, also the regions to forbid (:func:`_contact_regions`) around the contacts of the searched path and of the
    tracked motion on the exact meshes."""
    search, search_scene = joint_space_search(robot, arrays, scene, start, goals, margin, options, cancel, goal_band,
                                              forbidden, self_slack)
    _log_search(search)
    if not search.found:
        _LOG.info("global fallback: %s", search.reason)
        return FallbackOutcome(None, search.status, search.reason, search), []
    loop = track(robot, arrays, search_scene, search.path, goal, params, max_iterations, options, cancel)
    tracked = PlanStatus(loop[0])
    certificate = certify_path(robot, obstacles, loop[2], options.exact_resolution, exact) \
        if tracked == PlanStatus.REACHED else None
    if certificate is not None and certificate.clear:
        return FallbackOutcome(loop, PlanStatus.REACHED, "", search), []
    # the tracking keeps the dampers' clearance, so a searched path that grazes a contact may still be tracked clear;
    # when it is not, the contacts of the searched path and of the tracked motion are the regions to avoid
    searched = certify_path(robot, obstacles, search.path, options.exact_resolution, exact)
    regions = [] if searched.clear else _contact_regions(robot, obstacles, exact, search.path, searched, margin,
                                                         (start, *goals), options)
    if certificate is None:
        reason = f"global fallback: tracking the searched path ended with {tracked.name}"
        _LOG.info(reason)
        return FallbackOutcome(None, tracked, reason, search), regions
    regions += _contact_regions(robot, obstacles, exact, loop[2], certificate, margin, (start, *goals), options)
    return _refused(f"the tracked path fails the certificate ({certificate.describe()})", certificate, search), regions


CONTACTS_PER_PATH = 8
"""Most contacts of one path turned into forbidden regions (:func:`_contact_regions`)."""


def _contact_regions(robot: RobotModel, obstacles: list[Obstacle], exact: CollisionChecker, path: NDArray[np.float64],
                     first: Certificate, margin: float, ends: Sequence[NDArray[np.float64]], options: GlobalOptions
                     ) -> list[Region]:
    """Regions to forbid (:func:`~pfield.planning.global_search.contact_region`) around ``first`` (``path``'s
    certificate at ``exact_resolution``) and the next contacts along ``path``, at most :data:`CONTACTS_PER_PATH`: after
    each, the rest of the path (interpolated every ``exact_resolution``: the certificate's own grid) is certified from
    the first configuration past the region. One search then avoids every contact its path met, not the first only
    (a path through a contact of the UR5's forearm and wrist_2 meets it along a stretch).

    The scan begins at ``first``'s own grid point: the certificate found no contact before it. (It began at the
    path's start until issue 34's last measures, certifying that clear stretch again and finding ``first`` a second
    time: on the UR5 bookshelf_thin problem 42, 4 certificates of 5-9 ms each out of 24, and the duplicate took one of
    the path's regions.) A contact's own grid point counts as held even where its region is empty (an end at the
    contact), so no contact is scanned twice."""
    dense = resolution_grid(path, options.exact_resolution)[0]
    regions = [contact_region(exact, first, margin, ends)]
    covered = in_region(dense, regions[0])  # the grid points some region holds
    index = first.grid_points - 1  # the first contact's grid point, when first is path's certificate on this grid
    if not (0 <= index < len(dense) and first.configuration is not None
            and np.array_equal(dense[index], first.configuration)):
        index = 0
    covered[index] = True
    while len(regions) < CONTACTS_PER_PATH:
        outside = np.flatnonzero(~covered[index:])
        if len(outside) == 0 or index + outside[0] >= len(dense) - 1:
            break
        index += int(outside[0])
        certificate = certify_path(robot, obstacles, dense[index:], options.exact_resolution, exact)
        if certificate.clear:
            break
        regions.append(contact_region(exact, certificate, margin, ends))
        covered |= in_region(dense, regions[-1])
        index += certificate.grid_points - 1  # the contact's grid point (dense[index:] is its own grid)
        covered[min(index, len(dense) - 1)] = True
    return regions


def _refused(what: str, certificate: Certificate, search: SearchResult) -> FallbackOutcome:
    reason = f"global fallback: {what}"
    _LOG.info(reason)
    status = PlanStatus.SELF_COLLISION if certificate.self_collision else PlanStatus.COLLISION
    return FallbackOutcome(None, status, reason, search)


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
