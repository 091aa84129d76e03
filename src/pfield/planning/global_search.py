"""The global fallback of the field planners: search, shorten, then let the field track the result.

A potential field is local: it stops in a local minimum (``stagnation``) or runs out of steps. When
that happens and ``global_fallback`` is on, the planners call this module:

1. **Goal configurations** (whole body): the goal is a pose, so the IK (:func:`pfield.robot.ik.solve_ik`)
   runs from several seeds — the start, the field's last configuration, then uniform samples from a
   generator seeded by ``seed`` — and keeps up to ``goal_configurations`` distinct solutions within the
   joint limits: those whose link capsules keep the search margin first, then those the exact mesh
   check (coal) clears; each moved by whole turns to its equivalent nearest the start, and nearest the
   start first. None found → ``goal invalid`` at once, never a long search.
2. **Search**: compiled RRT-Connect (the core's ``planning/rrt``, ``pfield._core.rrt``) in joint space against the
   fitted link model and the packed obstacles (whole body; the goal tree is rooted at every goal
   configuration; the self pairs on the fitted primitives, not the covering capsules the field's own steps use;
   most samples from :func:`sampling_window`), or in R³ against the obstacles' signed distance (task space).
   Task space searches positions only: its collision model is the end-effector *point*, so the orientation
   cannot make a state valid or invalid; the orientation is interpolated by slerp along the path, in
   proportion to the distance travelled, and the field's rotational attraction follows it.
3. **Shortening** of the found path (same compiled checks): random vertex shortcuts and a greedy pass, then
   partial shortcuts between random points of the path whose new segments keep ``smoothing_clearance`` more
   (the core's ``planning::shorten``), never longer. When the path reached a goal configuration but is longer
   than the straight distance to another one, a bounded second search to those (:func:`_search`).
4. **Tracking by the field**: whole body, the damper-constrained QP follows a moving joint-space
   attractor (the core's ``planning/track``); task space, the field's own compiled loop runs to
   each path vertex in turn as its goal. The motion keeps the dampers' clearance.

Search margin: a state is valid when every capsule keeps ``safety_distance + GlobalOptions.extra_margin``;
pairs that the start or the goal configuration hold closer (conservative capsules often touch the
objects of a grasp) may go ``GlobalOptions.endpoint_band`` deeper than at the start, and as deep as at the goal
or that band deeper (the fallback tries the band first, :func:`endpoint_scene`), no deeper; the fallback lets the
self pairs' fitted primitives touch (:func:`self_contact_slack`). The capsules are
the search's model, not its certificate: the tracked motion is verified on the exact collision meshes (coal) at
every waypoint and every ≤ 0.01 rad between them (:func:`pfield.planning.certify.certify_path`); a contact is
never returned. The contacts that check finds become regions the next search avoids (:func:`contact_region`, lazy
collision checking; :func:`pfield.planning.fallback.whole_body_fallback` runs it).
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from pfield._core import rrt as _core
from pfield._validation import nonnegative, positive
from pfield.errors import InvalidInput
from pfield.field.config import FieldConfig
from pfield.geometry import Obstacle
from pfield.planning._whole_body_core import core_obstacles, core_scene, culprit, pair_distances
from pfield.planning.cancel import cancel_flag
from pfield.planning.certify import Certificate
from pfield.planning.options import DEFAULT_GLOBAL_TIME_LIMIT
from pfield.planning.retime import path_length
from pfield.planning.status import PlanStatus
from pfield.robot.collision import UNBOUNDED_WEIGHT, CollisionChecker
from pfield.robot.ik import solve_ik
from pfield.robot.model import RobotModel
from pfield.spatial import Pose, quaternion_exp, quaternion_inverse, quaternion_log, quaternion_multiply

if TYPE_CHECKING:
    from pfield.planning import _whole_body_layout as _wb

__all__ = ["GlobalOptions", "SearchResult", "goal_configurations", "joint_space_search",
           "point_space_search"]

_LOG = logging.getLogger(__name__)
_ROUNDING = 1e-9  # m: an endpoint must pass its own offset test despite rounding


@dataclass(frozen=True)
class GlobalOptions:
    """Settings of the global search (documented defaults; times in s, angles in rad, lengths in m).

    Attributes:
        time_limit: wall-clock limit of the search (s).
        seed: seed of the random samples (IK restarts, RRT-Connect, shortcutting): same seed, same path.
        joint_step: largest joint-space extension of a tree per iteration (rad, Euclidean norm).
        joint_resolution: edges are checked every ``joint_resolution`` rad (max over the joints).
        exact_resolution: the exact mesh check of the tracked motion interpolates every ``exact_resolution`` rad.
        point_step, point_resolution: the same in R³ (m) for task-space searches.
        extra_margin: clearance kept by the search beyond ``safety_distance`` (m).
        endpoint_band: how much deeper than at the start a pair that is closer than the margin there may go
            (m; see :func:`endpoint_scene`).
        capacity: nodes per tree.
        shortcut_attempts: random shortcuts tried on the found path.
        smoothing_attempts: partial shortcuts between random points of the path tried next (the core's
            ``planning::shorten``; it stops early after a quarter of them in a row shorten nothing).
        smoothing_clearance: clearance (m) beyond the search margin that those new segments keep from the
            obstacles (not between the robot's own links: :func:`_clearance_scene`): a path pulled taut
            against an obstacle is hard for the tracking's dampers to follow.
        ik_restarts: random IK seeds tried for goal configurations (after the given seeds).
        goal_configurations: most goal configurations the search starts from (its second tree's roots).
        tracking_gain: k_p (1/s) of the joint-space moving attractor; tracking_lead: largest lag (rad).
        search_threads: seeds a search races, each on its own thread, when its first seed has found no path in
            :data:`RACE_AFTER` state checks (:class:`_Race`); the path kept is the one found with the fewest state
            checks, so the plan is the same with one core or many, only its time differs (unless the time limit or
            a cancel ends the search first). 1: one seed, no thread.

    ``joint_resolution`` 0.03 rad: finer than OMPL's default (1 % of the space's extent, about 0.13 rad for
    a Panda) and MoveIt's (0.5 %); the searched path is a guide, the tracking's dampers keep the clearance
    and the exact mesh check verifies the whole tracked motion (:mod:`pfield.planning.certify`). On the
    MotionBenchMaker table scenes 0.01 rad cost twice the states for the same success (table_under_pick:
    median search 8.5 → 4.7 ms at 0.02, 20/20 both). From 0.02 to 0.03 (every valid MotionBenchMaker problem,
    pfield alone, one process, 2026-12-06): UR5 (700) median 19.9 → 20.2 ms, p95 163 → 95 ms (cage 460 → 262,
    bookshelf_small 192 → 123, bookshelf_tall 96 → 92, bookshelf_thin 91 → 73), Panda (399) median 6.3 → 6.4 ms,
    p95 18.1 → 16.2 ms; every problem solved and none claimed in collision with either (at 0.03 with a second
    search seed, :data:`pfield.planning.fallback.SEARCH_SEEDS`). At 0.04 the UR5's bookshelf tails grew again
    (p95 small 174, tall 166 ms).

    ``joint_step`` 0.35 rad (1.0 before, 2026-12-08): measured on every valid MotionBenchMaker problem, pfield alone,
    one process, each planned with the search's seeds 0, 1 and 2 (``PlanOptions.global_seed``; the figures pool the
    three seeds' plans, median / p95 ms):

    ========================  ==============  ===============
    scene                     step 1.0        step 0.35
    ========================  ==============  ===============
    UR5 table_pick            9.7 / 13.9      9.0 / 12.7
    UR5 table_under_pick      10.5 / 17.0     11.4 / 16.8
    UR5 box                   5.9 / 10.0      6.0 / 10.6
    UR5 bookshelf_small       11.7 / 71.2     10.6 / 65.9
    UR5 bookshelf_tall        16.1 / 91.4     14.3 / 74.6
    UR5 bookshelf_thin        16.7 / 109.0    14.8 / 74.4
    UR5 cage                  48.8 / 264.8    44.2 / 99.6
    UR5, all 2100 plans       11.9 / 96.0     11.7 / 72.3
    Panda bookshelf_small     8.5 / 72.6      8.5 / 38.9
    Panda, all 1197 plans     7.1 / 25.8      7.2 / 18.9
    ========================  ==============  ===============

    Every plan solved at 0.35 (2 of the UR5's 2100 failed at 1.0), none claimed in collision, median joint paths up
    to 4 % shorter (the same on the UR5's bookshelf_tall and the Panda's box). The cage alone at 0.7, 0.5, 0.35 and
    0.25: median 51.6, 47.5, 44.3, 43.7 ms, p95 159, 112, 101, 107 ms. Through a narrow passage (into the cage,
    between shelves) a long extension is refused where a short one gets through; 1.0 looked best when measured with
    seed 0 alone (cage median 22.8 ms), a lucky seed: 63.7 and 49.8 ms with seeds 1 and 2.

    ``tracking_lead`` 0.05 rad: at 0.02 the target waited for the
    arm (whose lag correction is capped at the speed it can brake from) so often that the tracked motions
    took 1.3–2.6 times their profile's duration (table_under_pick: 1150 steps for a 437-step profile).

    ``smoothing_attempts`` 100 and ``smoothing_clearance`` 0.01 m (issue 34), measured on the first 10
    problems of the Panda MotionBenchMaker table_pick and table_under_pick scenes (17 through the fallback):
    median joint path of the fallback's plans 6.77 rad with the vertex shortcuts alone, 6.00 / 5.89 / 5.55 /
    5.55 rad after 25 / 50 / 100 / 200 partial shortcuts, for about 10 / 16 / 27 / 50 ms of shortening per
    plan on a shared 2-core machine. Without the clearance, one of the 10 table_under_pick plans was pulled so
    close to the table that its tracking stalled (ITERATION_LIMIT); with 1 cm all 40 sampled problems of the
    four dev scenes are solved. The partial shortcuts check their new segment and its first end, not the cut pieces
    (parts of checked segments, ``planning::shorten``): on 15 UR5 table problems the same paths (one of 15 differs in
    its states checked, not its length) for 35–45 % less shortening time; and a partial shortcut is checked only when
    it would save at least 0.5 % of the path (``planning::kLeastShortening``): on every valid UR5 MotionBenchMaker
    problem the median plan 27.0 → 21.6 ms, median path lengths per scene +0–2.5 %.
    """

    time_limit: float = DEFAULT_GLOBAL_TIME_LIMIT
    seed: int = 0
    joint_step: float = 0.35
    joint_resolution: float = 0.03
    exact_resolution: float = 0.01
    point_step: float = 0.1
    point_resolution: float = 0.005
    extra_margin: float = 0.001
    endpoint_band: float = 0.005
    capacity: int = 20000
    shortcut_attempts: int = 50
    smoothing_attempts: int = 100
    smoothing_clearance: float = 0.01
    ik_restarts: int = 48
    goal_configurations: int = 4
    tracking_gain: float = 4.0
    tracking_lead: float = 0.05
    search_threads: int = 2

    def __post_init__(self) -> None:
        for name in ("time_limit", "joint_step", "joint_resolution", "exact_resolution", "point_step",
                     "point_resolution", "tracking_gain", "tracking_lead"):
            positive(name, getattr(self, name))
        nonnegative("extra_margin", self.extra_margin)
        nonnegative("smoothing_clearance", self.smoothing_clearance)
        nonnegative("endpoint_band", self.endpoint_band)
        least = {"capacity": 2, "goal_configurations": 1, "search_threads": 1}
        for name in ("seed", "capacity", "shortcut_attempts", "smoothing_attempts", "ik_restarts",
                     "goal_configurations", "search_threads"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < least.get(name, 0):
                raise InvalidInput(name, value, f"must be an integer >= {least[name]}" if name in least
                                   else "must be a non-negative integer")


@dataclass(frozen=True, eq=False)
class SearchResult:
    """Outcome of a global search: ``path`` (K, n) from start to goal when ``found``; otherwise ``status``
    says why (START_INVALID, GOAL_INVALID, GLOBAL_TIME_LIMIT, CANCELLED) and ``reason`` in words.

    ``states_checked`` counts the compiled validity checks, of every seed of a race (how far a losing seed got
    depends on when it learnt it lost, so a raced search's count varies from run to run, its path does not);
    ``seconds`` the search's wall time.
    """

    found: bool
    path: NDArray[np.float64]
    status: PlanStatus
    reason: str
    states_checked: int
    seconds: float


# ---- whole body ---------------------------------------------------------------------------------------

def endpoint_scene(scene: _wb.Scene, arrays: _wb.RobotArrays, ends: Sequence[NDArray[np.float64]],
                   margin: float, band: float, goal_band: float = 0.0,
                   measured: Sequence[tuple[NDArray[np.float64], NDArray[np.float64]]] | None = None) -> _wb.Scene:
    """``scene`` with the offsets min(0, d(end) − margin − b) over the ``ends``: a pair closer than
    ``margin`` at the start (b = ``band``) or at a goal (b = ``goal_band``) may go that much deeper than there, no
    deeper.

    Why the band at the start: such a pair sits exactly on the boundary of its constraint there, and with
    several of them (conservative capsules of neighbouring links often overlap where the meshes do not)
    almost every direction out of the start would be refused. A grasp goal is the same (issue 34: a UR5's fitted
    finger primitives overlap the object its meshes hold clear, and with no band 1–9 % of the short motions out of
    such a goal passed the search's test where 33–60 % are clear on the meshes), but a band there also lets the
    fingers sweep into the object the meshes hold: :func:`pfield.planning.fallback.whole_body_fallback` tries the
    goal with the band first, then, when that motion fails, without.

    ``measured``: the ends' :func:`~pfield.planning._whole_body_core.pair_distances` in ``scene``, when the caller
    has them (:func:`end_distances`)."""
    obstacle_offsets, self_offsets = np.zeros_like(scene.obstacle_offsets), np.zeros_like(scene.self_offsets)
    for index, (obstacle, own) in enumerate(measured or end_distances(arrays, scene, ends, margin)):
        extra = band if index == 0 else goal_band
        obstacle_offsets = np.minimum(obstacle_offsets, np.where(obstacle < margin, obstacle - margin - extra, 0.0))
        self_offsets = np.minimum(self_offsets, np.where(own < margin, own - margin - extra, 0.0))
    return scene._replace(obstacle_offsets=obstacle_offsets - _ROUNDING * (obstacle_offsets < 0.0),
                          self_offsets=self_offsets - _ROUNDING * (self_offsets < 0.0))


def end_distances(arrays: _wb.RobotArrays, scene: _wb.Scene, ends: Sequence[NDArray[np.float64]],
                  cutoff: float = np.inf) -> list[tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """The fitted model's pair distances (link × obstacle, self pairs) at each of ``ends`` in ``scene``, exact
    below ``cutoff`` (:func:`~pfield.planning._whole_body_core.pair_distances`)."""
    return [pair_distances(np.ascontiguousarray(q), arrays, scene, cutoff) for q in ends]


def _joint_checker(arrays: _wb.RobotArrays, scene: _wb.Scene, margin: float, resolution: float) -> _core.Checker:
    return _core.Checker(core_scene(arrays, scene), float(margin), float(resolution))


def _capsules_clear(arrays: _wb.RobotArrays, scene: _wb.Scene, q: NDArray[np.float64], margin: float) -> bool:
    obstacle, own = pair_distances(q, arrays, scene, margin)
    return bool(np.all(obstacle >= margin) and np.all(own >= margin))


def goal_configurations(robot: RobotModel, goal: Pose, seeds: Sequence[NDArray[np.float64]],
                        arrays: _wb.RobotArrays, scene: _wb.Scene, margin: float,
                        obstacles: Sequence[Obstacle] | None, options: GlobalOptions, joint_margin: float = 0.0,
                        given: NDArray[np.float64] | None = None, *,
                        start: NDArray[np.float64] | None = None,
                        checker: CollisionChecker | None = None) -> tuple[list[NDArray[np.float64]], str]:
    """Up to ``options.goal_configurations`` distinct collision-free joint configurations at ``goal`` (module
    docstring, step 1), or ([], why): the goal is invalid. Preferred first: those whose link model keeps
    ``margin`` and whose joints stay ``joint_margin`` (rad or m) inside their limits — the joint-limit
    dampers stop a joint ``joint_safety`` short of its limit, so a goal configuration on the limit cannot be
    tracked; then those that keep ``margin`` at a limit; then those that only the exact mesh check clears.
    Every configuration returned has passed the exact mesh check.

    ``start``: the configuration the motion starts from (default: the last of ``seeds``, which is the start
    in the fallback's call). The IK runs from it first, then from the other seeds; each solution is moved to
    its equivalent nearest the start (:func:`nearest_equivalent`), and within each preference the solutions
    come nearest the start first (Euclidean joint distance): the search reaches whichever goal root it meets
    first, so a far one (another wrist branch: the UR5 that flipped its wrist, issue 34) must not be offered
    when a near one exists.

    ``given``: the caller's own goal configuration (a joint goal, as in a MoveIt request), already checked
    to be within the limits and at ``goal``. It is the only one: no IK runs, and when the exact mesh check
    finds a contact (obstacles or the robot's own links) the goal is invalid. It is
    searched to as given even on a joint limit: the tracking's last stretch is the field's approach to the
    pose, which gets there (moving such joints ``joint_margin`` inside lost 3 of 80 MotionBenchMaker
    problems to stagnation, all solved as given).

    ``checker``: the exact check of ``robot`` among ``obstacles`` (the plan's, whose shapes and bounds are built
    already); by default one is made."""
    checker = checker or CollisionChecker(robot, list(obstacles or ()))
    if given is not None:
        if _exactly_clear(checker, [given], 1):
            return [given], ""
        return [], "goal invalid: the given goal configuration collides (exact mesh check)"
    rng = np.random.default_rng(options.seed)
    lower, upper = _sampling_box(robot)
    origin = np.asarray(seeds[-1] if start is None else start, dtype=np.float64)
    others = [seed for seed in seeds if not np.array_equal(seed, origin)]
    candidates = [origin, *others, *(rng.uniform(lower, upper) for _ in range(options.ik_restarts))]
    inner_lower, inner_upper = robot.lower_limits + joint_margin, robot.upper_limits - joint_margin
    reachable = 0
    clear: list[NDArray[np.float64]] = []
    at_limit: list[NDArray[np.float64]] = []
    unverified: list[NDArray[np.float64]] = []  # the link model overlaps: the exact check decides, if needed
    for seed in candidates:
        result = solve_ik(robot, goal, np.clip(seed, robot.lower_limits, robot.upper_limits))
        q = nearest_equivalent(robot, result.q, origin) if result.success else result.q
        if not result.success or any(np.max(np.abs(q - other)) < 1e-3 for other in clear + at_limit + unverified):
            reachable += int(result.success)
            continue
        reachable += 1
        if _capsules_clear(arrays, scene, q, margin):
            inside = bool(np.all(q >= inner_lower) and np.all(q <= inner_upper))
            (clear if inside else at_limit).append(q)
        else:
            unverified.append(q)
        if len(clear) >= options.goal_configurations:
            break
    for tier in (clear, at_limit, unverified):
        tier.sort(key=lambda q: float(np.linalg.norm(q - origin)))
    found = (clear + at_limit)[:options.goal_configurations]
    found = _exactly_clear(checker, found, len(found))  # the link model may miss a pair: the meshes decide
    if len(found) < options.goal_configurations and unverified:
        found += _exactly_clear(checker, unverified, options.goal_configurations - len(found))
    if found:
        return found, ""
    if reachable == 0:
        return [], (f"goal invalid: no inverse-kinematics solution within the joint limits reaches the goal pose "
                    f"({len(candidates)} seeds)")
    return [], f"goal invalid: every inverse-kinematics solution of the goal pose collides ({reachable} found)"


def nearest_equivalent(robot: RobotModel, q: NDArray[np.float64], reference: NDArray[np.float64],
                       continuous_only: bool = False) -> NDArray[np.float64]:
    """``q`` with each revolute joint moved by the multiple of 2π that brings it nearest ``reference`` while
    it stays within the joint's limits (continuous joints: any multiple). q_j + 2πm is the same joint
    rotation, so the pose and every link's placement are those of ``q``; only the way there is shorter.
    Prismatic joints are kept; with ``continuous_only``, so are the revolute joints that have limits (a joint goal
    asks for their value itself, as MoveIt reads it)."""
    out = np.array(q, dtype=np.float64)
    turn = 2.0 * math.pi
    lower, upper = robot.lower_limits, robot.upper_limits
    moved = np.asarray(robot.kinematics.kinds) == 0
    if continuous_only:
        moved &= np.isinf(lower) & np.isinf(upper)
    for j in np.flatnonzero(moved):
        nearest = round((float(reference[j]) - float(out[j])) / turn)
        options = [float(out[j]) + m * turn for m in (nearest - 1, nearest, nearest + 1)]
        inside = [value for value in options if lower[j] <= value <= upper[j]]
        if inside:
            best = min(inside, key=lambda value: abs(value - float(reference[j])))
            if abs(best - float(reference[j])) < abs(float(out[j]) - float(reference[j])):
                out[j] = best
    return out


def _exactly_clear(checker: CollisionChecker, qs: Sequence[NDArray[np.float64]],
                   count: int) -> list[NDArray[np.float64]]:
    """The first ``count`` of ``qs`` that the exact mesh check (coal, ``checker``) clears: no obstacle and no self
    pair (not adjacent, not disabled by the SRDF) in contact."""
    if not qs or count <= 0:
        return []
    found: list[NDArray[np.float64]] = []
    for q in qs:
        if len(found) == count:
            break
        if checker.contact(q) is None:
            found.append(q)
    return found


def _sampling_box(robot: RobotModel) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Joint limits, with [−π, π] for continuous joints."""
    lower = np.where(np.isfinite(robot.lower_limits), robot.lower_limits, -math.pi)
    upper = np.where(np.isfinite(robot.upper_limits), robot.upper_limits, math.pi)
    return np.ascontiguousarray(lower, dtype=np.float64), np.ascontiguousarray(upper, dtype=np.float64)


def _search(checkers: Callable[[], _core.Checker], clearance: _core.Checker, start: NDArray[np.float64],
            goals: NDArray[np.float64], lower: NDArray[np.float64], upper: NDArray[np.float64], step: float,
            options: GlobalOptions, cancel: NDArray[np.uint8] | None,
            wide: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None) -> SearchResult:
    """RRT-Connect from ``start`` to any row of ``goals`` (nearest the start first) in chunks of compiled work
    (the GIL released; ``cancel`` read every iteration) until found or ``options.time_limit`` (restarting after a
    budget of checks or with a full tree); then shortening (:func:`_shortened`).

    ``checkers`` makes the validity test (one per seed). Seeds race (``options.search_threads``, :class:`_Race`): when
    :data:`RACE_AFTER` checks found no path, further searches with other seeds start on their own threads, and the
    path kept is the one found with the fewest state checks, so the outcome is the same on any machine and whatever
    the threads' timing.

    Which goal: the goal tree is rooted at every goal, and RRT-Connect ends at whichever it meets first.
    When the shortened path is longer than the straight distance to another goal (a lower bound of any path
    there), a search rooted at that goal alone runs for at most ``NEARER_GOAL_SHARE`` of the states the first
    one checked (at least one chunk) within the time limit, nearest goal first, while the shortest path so far
    is longer than the next goal's distance, and the shortest of the shortened paths is kept (the UR5 whose
    wrist flipped, issue 34: its search met a goal 5.3 rad away first, where one 1.05 rad away was reachable;
    a second search rooted at all the nearer goals at once met another far one with seed 0 and a 0.35 rad
    step, and the wrist flipped again).

    Without a path after :data:`RESTART_STATES` state checks, or with a tree full, the search starts again with
    fresh trees (then after twice as many, and so on) until the time limit.

    ``wide``: a larger sampling box that every :data:`WIDE_EVERY`-th chunk samples instead of [lower, upper] (the
    joint-space window of :func:`sampling_window`): any state of it can still be sampled."""
    begin = time.perf_counter()
    checker = checkers()
    if not checker.state_valid(start):
        return SearchResult(False, start[None], PlanStatus.START_INVALID,
                            "start invalid: the start violates the search margin",
                            checker.states_checked, time.perf_counter() - begin)
    valid = np.array([g for g in goals if checker.state_valid(g)])
    if not len(valid):
        return SearchResult(False, start[None], PlanStatus.GOAL_INVALID,
                            "goal invalid: the goal violates the search margin",
                            checker.states_checked, time.perf_counter() - begin)
    before = checker.states_checked
    race = _Race()

    def run(lane: _Lane, after_chunk: Callable[[], None] | None = None) -> object:
        return _run_lane(lane, race, start, valid, lower, upper, step, options, cancel, begin, wide, after_chunk)

    def spread() -> None:  # after each chunk: past RACE_AFTER checks, the other seeds start, counted from here
        if len(race.lanes) > 1 or checker.states_checked - before < RACE_AFTER:
            return
        for index in range(1, options.search_threads):
            race.start(race.add(checkers(), checker.states_checked, int(options.seed) + _LANE_SEED * index), run)

    try:
        status = run(race.add(checker, 0, int(options.seed)), spread if options.search_threads > 1 else None)
    except BaseException:
        race.stop()
        raise
    finally:
        race.join()
    checked = race.states_checked()
    winner = race.winner()
    if winner is None and (status == _CANCELLED or (cancel is not None and cancel[0] != 0)):
        return SearchResult(False, start[None], PlanStatus.CANCELLED, "cancelled during the global search",
                            checked, time.perf_counter() - begin)
    if winner is None:  # the time limit: a full tree starts the search again until then
        return SearchResult(False, start[None], PlanStatus.GLOBAL_TIME_LIMIT, "global search: no path within the "
                            f"time limit ({options.time_limit:g} s, {options.capacity} nodes per tree)",
                            checked, time.perf_counter() - begin)
    best, path, trees = winner.checker, winner.path, winner.trees
    assert path is not None and trees is not None
    shortening = best.states_checked
    short = _shortened(best, clearance, path, trees, options)
    spent = winner.found_at - before + best.states_checked - shortening  # the search's checks and its shortening's
    length = path_length(short)
    reached = int(np.argmin(np.max(np.abs(valid - short[-1]), axis=1)))
    others = sorted((float(np.linalg.norm(g - start)), k) for k, g in enumerate(valid) if k != reached)
    budget = max(int(NEARER_GOAL_SHARE * spent), _CHUNK)
    for distance, k in others:  # nearest first, each alone: rooted at several, the search may meet a far one again
        if distance >= length:
            break
        again = _core.Trees(start, valid[k][None], int(options.capacity), int(options.seed) + 1 + k)
        status, path = _connect(best, again, lower, upper, step, options, cancel, begin, budget, wide)
        if status == _core.SearchStatus.FOUND:
            other = _shortened(best, clearance, path, again, options)
            if (other_length := path_length(other)) < length:
                short, length = other, other_length
    return SearchResult(True, short, PlanStatus.REACHED, "", race.states_checked(), time.perf_counter() - begin)


RESTART_STATES = 200_000
"""State checks after which a search starts again with fresh trees (a new seed), then after twice as many each
time, within its time limit (:func:`_search`); a search whose tree is full starts again too. RRT-Connect's time to a
path is heavy-tailed: on six UR5 MotionBenchMaker problems that failed within 2 s, seeds 0, 1, 2 found paths in
0.11–3 s or not within 4 s, problem by problem (bookshelf_small 22: 3.0 s, 0.11 s, none); restarts cut that tail
(Luby, Sinclair & Zuckerman, "Optimal speedup of Las Vegas algorithms", 1993). But a narrow passage needs a large
tree, and a restart throws it away: on the UR5 cage problems 5, 60, 62, 70, 80 and 95, restarts after 40 000 checks
(about 0.3 s) solved none within 2 s; with 80 000, 3; with 120 000, 3; with 200 000, 4 (the 700 UR5 problems: 692
solved with 40 000, 696 with 200 000, 0 claims in collision either way; each of the six solved in 2.4–4.3 s with a
15 s limit). 200 000 checks: about 1.6 s on the UR5 when this was measured (8 µs per check, the numba engine); with
the compiled core about 0.5 s (2.7 µs per check on the cage problems, 2026-12-06), so within the default 2 s a
search restarts at most three times, and with a longer limit the tail is still cut."""
_RESTART_SEED = 7919  # seed offset of each restart's trees (the nearer-goal search takes seed + 1)
RACE_AFTER = 10_000
"""State checks of a search's first seed after which the others join the race (``GlobalOptions.search_threads``,
:class:`_Race`): most searches end sooner, and a thread started for them only costs time."""
_LANE_SEED = 15_485_863  # seed offset of each further lane of a race (a prime, far from the others' offsets)
NEARER_GOAL_SHARE = 1.0
"""Budget of each search for a nearer goal, as a share of the states the first search checked (:func:`_search`):
each nearer goal searched at most doubles the work where it ran (with ``GlobalOptions.goal_configurations`` 4, at
most three such searches; a joint goal, as in MoveIt's requests, has none)."""
_CHUNK = 2000  # state checks per compiled chunk of the search
WIDE_EVERY = 4
"""Every this many chunks of a joint-space search sample the whole joint box instead of the window
(:func:`sampling_window`)."""
_CANCELLED = -1
_BEATEN = -2  # a lane of a race stopped: another found a path with fewer state checks


@dataclass(eq=False)
class _Lane:
    """One seed of a :class:`_Race`: its checker, the race's count when it started (``offset``), its seed, the int64
    ``bound`` on its own count that the core reads every iteration, and what it found."""

    index: int
    checker: _core.Checker
    offset: int
    seed: int
    bound: NDArray[np.int64]
    found_at: int = 0  # the race's count (offset + own checks) when it found its path
    path: NDArray[np.float64] | None = None
    trees: _core.Trees | None = None


class _Race:
    """Seeds of one search racing on threads, with a deterministic winner.

    RRT-Connect's time to a path is heavy-tailed and differs from seed to seed by orders of magnitude (UR5 cage
    problems, 2026-12-07: 2 500 to 350 000 state checks for one problem across six seeds), so two seeds on two cores
    find a path about as soon as the luckier one (Luby, Sinclair & Zuckerman 1993; OMPL's ``ParallelPlan`` races
    planners the same way). Taking the first path to arrive would make the plan depend on the threads' timing;
    instead each lane's checks are counted on one clock (lane ``k`` starts at ``offset``: the first lane's count
    when it joined), the path found at the lowest count wins (ties: the lower lane), and a lane stops as soon as it
    can no longer win (its ``bound``). The outcome is that of running the lanes one check at a time in turn, on any
    machine, with one core or many, unless the time limit or a cancel ends the search before the lanes' counts
    decide it (as they would end a search of one seed)."""

    def __init__(self) -> None:
        self.lanes: list[_Lane] = []
        self._lock = threading.Lock()
        self._best: tuple[int, int] | None = None  # (count, lane index) of the best path found so far
        self._threads: list[threading.Thread] = []
        self._errors: list[BaseException] = []
        self._stopped = False

    def add(self, checker: _core.Checker, offset: int, seed: int) -> _Lane:
        with self._lock:
            lane = _Lane(len(self.lanes), checker, offset, seed, np.full(1, np.iinfo(np.int64).max, np.int64))
            self.lanes.append(lane)
            if self._stopped:
                lane.bound[0] = -1
            elif self._best is not None:
                self._limit(lane, *self._best)
        return lane

    def start(self, lane: _Lane, run: Callable[[_Lane], object]) -> None:
        """``run(lane)`` on a thread of its own; an error it raises stops the race and is raised again by join()."""
        def thread_body() -> None:
            try:
                run(lane)
            except BaseException as error:  # raised again by join(), on the caller's thread
                self._errors.append(error)
                self.stop()
        thread = threading.Thread(target=thread_body, name=f"pfield-search-{lane.index}", daemon=True)
        self._threads.append(thread)
        thread.start()

    def offer(self, lane: _Lane, path: NDArray[np.float64], trees: _core.Trees) -> None:
        """``lane`` found ``path``: it wins unless a lane found one at a lower count; the others' bounds follow."""
        with self._lock:
            lane.found_at, lane.path, lane.trees = lane.offset + lane.checker.states_checked, path, trees
            if self._best is None or (lane.found_at, lane.index) < self._best:
                self._best = (lane.found_at, lane.index)
                for other in self.lanes:
                    self._limit(other, *self._best)

    @staticmethod
    def _limit(lane: _Lane, count: int, index: int) -> None:
        # lane may start an iteration while offset + its count < count (<= count when it is the lower lane)
        lane.bound[0] = min(int(lane.bound[0]), count - lane.offset + (1 if lane.index < index else 0))

    def beaten(self, lane: _Lane) -> bool:
        return lane.checker.states_checked >= int(lane.bound[0])

    def stop(self) -> None:
        """Every lane, and any added later, ends at its next iteration (an error or an interrupt)."""
        with self._lock:
            self._stopped = True
            for lane in self.lanes:
                lane.bound[0] = -1

    def join(self) -> None:
        for thread in self._threads:
            thread.join()
        if self._errors:
            raise self._errors[0]

    def winner(self) -> _Lane | None:
        return None if self._best is None else self.lanes[self._best[1]]

    def states_checked(self) -> int:
        """Every lane's checks so far."""
        return sum(lane.checker.states_checked for lane in self.lanes)


def _run_lane(lane: _Lane, race: _Race, start: NDArray[np.float64], valid: NDArray[np.float64],
              lower: NDArray[np.float64], upper: NDArray[np.float64], step: float, options: GlobalOptions,
              cancel: NDArray[np.uint8] | None, begin: float,
              wide: tuple[NDArray[np.float64], NDArray[np.float64]] | None,
              after_chunk: Callable[[], None] | None = None) -> object:
    """One lane's RRT-Connect with restarts (:func:`_search`) until it finds a path (offered to ``race``), is
    beaten, cancelled or out of time; returns the last chunk's status. ``after_chunk``: called after every chunk
    that found nothing."""
    checker = lane.checker
    trees = _core.Trees(start, valid, int(options.capacity), lane.seed)
    budget, attempt = RESTART_STATES, 0
    again = (_core.SearchStatus.SEARCHING, _core.SearchStatus.EXHAUSTED)
    while True:  # restarts with fresh trees after RESTART_STATES, then twice as many each time, or when a tree is full
        status, path = _connect(checker, trees, lower, upper, step, options, cancel, begin, budget, wide,
                                lane.bound, after_chunk)
        if status == _core.SearchStatus.FOUND:
            race.offer(lane, path, trees)
            return status
        if race.beaten(lane):
            return _BEATEN
        if status not in again or time.perf_counter() - begin > options.time_limit:
            return status
        attempt, budget = attempt + 1, 2 * budget
        trees = _core.Trees(start, valid, int(options.capacity), lane.seed + _RESTART_SEED * attempt)


def _connect(checker: _core.Checker, trees: _core.Trees, lower: NDArray[np.float64], upper: NDArray[np.float64],
             step: float, options: GlobalOptions, cancel: NDArray[np.uint8] | None, begin: float,
             budget: int | None, wide: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
             bound: NDArray[np.int64] | None = None, after_chunk: Callable[[], None] | None = None
             ) -> tuple[object, NDArray[np.float64]]:
    """RRT-Connect chunks on ``trees`` until found, full, cancelled (status ``_CANCELLED``), the time limit
    (from ``begin``), ``budget`` more state checks (None: no budget) or the checker's count reaching ``bound[0]``
    (read by the core every iteration): (status, path). Every :data:`WIDE_EVERY`-th chunk samples ``wide`` (when
    given) instead of [lower, upper]. ``after_chunk``: called after every chunk that found nothing."""
    searching = _core.SearchStatus.SEARCHING
    status: object = searching
    path = np.empty((0, len(lower)))
    stop = None if budget is None else checker.states_checked + budget
    chunk = 0
    while status == searching:
        chunk += 1
        box = wide if wide is not None and chunk % WIDE_EVERY == 0 else (lower, upper)
        status, path = checker.connect(trees, box[0], box[1], step, _CHUNK, cancel, bound)
        if status == searching and cancel is not None and cancel[0] != 0:
            return _CANCELLED, path
        if status == searching and (time.perf_counter() - begin > options.time_limit
                                    or (stop is not None and checker.states_checked >= stop)
                                    or (bound is not None and checker.states_checked >= bound[0])):
            break
        if after_chunk is not None and status == searching:
            after_chunk()
    return status, path


def _shortened(checker: _core.Checker, clearance: _core.Checker, path: NDArray[np.float64], trees: _core.Trees,
               options: GlobalOptions) -> NDArray[np.float64]:
    """``path`` after ``shortcut_attempts`` random vertex shortcuts and the greedy pass, then
    ``smoothing_attempts`` partial shortcuts between random points of the path and the greedy pass again
    (the core's ``planning::shortcut`` and ``planning::shorten``, drawing from the search's stream), their new
    segments checked by ``clearance`` (the margin plus ``smoothing_clearance``). Every segment of the result
    passed one of the two edge tests; the length never grows."""
    short = checker.shortcut(path, int(options.shortcut_attempts), trees)
    return np.asarray(checker.shorten(short, int(options.smoothing_attempts), trees, clearance))


def joint_space_search(robot: RobotModel, arrays: _wb.RobotArrays, scene: _wb.Scene, start: NDArray[np.float64],
                       goals: Sequence[NDArray[np.float64]], margin: float,
                       options: GlobalOptions, cancel: NDArray[np.uint8] | None = None, goal_band: float = 0.0,
                       forbidden: Sequence[Region] = (), self_slack: NDArray[np.float64] | None = None
                       ) -> tuple[SearchResult, _wb.Scene]:
    """Search a capsule-valid joint path from ``start`` to one of ``goals``; returns it and the scene with the
    endpoint offsets (which the tracking must use too). The self pairs are on the fitted primitives (the scene's
    ``fitted_self``), not the covering capsules; ``goal_band``: :func:`endpoint_scene`'s. ``forbidden``: regions
    (:func:`contact_region`) whose states are invalid whatever the link model says. ``self_slack`` (P,) (m): every
    self pair may go that much deeper than the margin (:func:`self_contact_slack`), in the search and the
    tracking."""
    scene = scene._replace(fitted_self=True)  # self pairs on the fitted primitives (module docstring)
    ends = (start, *goals)
    # for both scenes below, which compare them with margins up to the clearance checker's
    measured = end_distances(arrays, scene, ends, margin + options.smoothing_clearance)
    search_scene = endpoint_scene(scene, arrays, ends, margin, options.endpoint_band, goal_band, measured)
    if self_slack is not None:
        search_scene = search_scene._replace(self_offsets=np.minimum(search_scene.self_offsets, -self_slack))
    def checkers() -> _core.Checker:  # the search's test, one per seed (_search)
        checker = _joint_checker(arrays, search_scene, margin, options.joint_resolution)
        for region in forbidden:  # contact_region's arrays: contiguous float64
            checker.forbid(*region)
        return checker

    clearance = _joint_checker(arrays, _clearance_scene(scene, search_scene, arrays, ends, margin, options,
                                                        goal_band, measured), margin + options.smoothing_clearance,
                               options.joint_resolution)
    for region in forbidden:
        clearance.forbid(*region)
    box = _sampling_box(robot)
    lower, upper = sampling_window(robot, box, start, goals, options.joint_step)
    wide = None if np.array_equal(lower, box[0]) and np.array_equal(upper, box[1]) else box
    return _search(checkers, clearance, start, np.array(goals), lower, upper, options.joint_step, options,
                   cancel, wide), search_scene


Region = tuple[NDArray[np.float64], NDArray[np.float64], float]
"""(centre (n,), weights w_j (n,), radius r): the states q with Σ_j w_j |q_j − centre_j| < r (the core's
``planning::ForbiddenRegions``; :func:`in_region` in Python)."""


def in_region(q: NDArray[np.float64], region: Region) -> NDArray[np.bool_]:
    """Whether ``region`` holds each configuration of ``q`` ((n,) or (N, n)): Σ_j w_j |q_j − c_j| < r."""
    centre, weights, radius = region
    return np.abs(q - centre) @ weights < radius


def contact_region(checker: CollisionChecker, certificate: Certificate, margin: float,
                   ends: Sequence[NDArray[np.float64]]) -> Region:
    """The region around ``certificate``'s contact that the next searches of a plan avoid: centre the configuration
    in contact, weights the pair's :attr:`~pfield.robot.collision.CollisionChecker.motion_weights` (its mesh
    distance changes by at most Σ_j w_j |Δq_j| where it is positive), radius margin − distance, less where that would
    hold one of the ``ends`` (the start, the goals: exactly clear, but possibly within the margin).

    The contact's distance (≤ 0) is the depth of the two links' convex hulls, which contain the meshes and reach
    deeper than they do: so only the region's core, Σ_j w_j |Δq_j| < margin, is closer than the margin on the meshes
    for certain (from a contact, the distance must grow past 0 and then by the margin); the rest is where the hulls'
    depth says the contact goes on, and may hold configurations that are clear. The region only narrows the
    searches of one plan; every motion is still certified. Measured (2026-12-07) on the 100 problems each of the
    UR5's bookshelf_small, bookshelf_tall and table_under_pick: the core alone as the region solved every problem
    too, but its tails grew (bookshelf_small p95 64 → 89 ms; bookshelf_tall 97 0.33 → 1.68 s, bookshelf_small 30
    0.18 → 1.16 s: more contacts to find one at a time).

    Why (issue 34): where the link model over-covers a pair in one place and under-covers it in another (the UR5's
    forearm_link and wrist_2_link: 13–18 mm deep on the fitted primitives where the meshes are 0–8 mm apart, and
    18 mm deep where the meshes are 20 mm deep, for wrist_1 between 1.0 and 2.1 rad), an end that holds the pair
    deeper than the margin (:func:`endpoint_scene`'s offsets) lets the search through both, and no link-model test
    tells them apart; the exact mesh check of the searched path does, and each contact it finds forbids a region
    the next search avoids (lazy collision checking: Bohlin & Kavraki, "Path planning using lazy PRM", ICRA 2000).
    The weights count only the joints that move one body of the pair and not the other, so the region is a slab
    across the joints that do not change the pair's relative pose."""
    assert certificate.configuration is not None
    pair = checker.pair_names.index(certificate.pair)
    weights = np.minimum(checker.motion_weights[pair], UNBOUNDED_WEIGHT)
    centre = np.array(certificate.configuration, dtype=np.float64)
    return centre, np.ascontiguousarray(weights), region_radius(centre, weights, margin - certificate.distance, ends)


def region_radius(centre: NDArray[np.float64], weights: NDArray[np.float64], radius: float,
                  ends: Sequence[NDArray[np.float64]]) -> float:
    """``radius``, less where a region of that radius about ``centre`` would hold one of ``ends``: then each end's
    weighted distance Σ_j w_j |end_j − centre_j| less :data:`_ROUNDING`, so that the core's test (a sum in its own
    order) still finds the end outside. (Cut to the distance itself, the UR5's bookshelf_tall problem 58 with seed 1
    lost its goal to a region whose radius numpy's sum made 2 ulp larger than the core's: GOAL_INVALID.)"""
    return min([radius, *(float(weights @ np.abs(end - centre)) - _ROUNDING for end in ends)])


def self_contact_slack(arrays: _wb.RobotArrays, margin: float) -> NDArray[np.float64]:
    """(P,) m: how much deeper than ``margin`` the search lets each self pair go (``joint_space_search``'s
    ``self_slack``): the whole margin, so the fitted primitives of two links may touch but not overlap. The
    primitives contain their link's collision surface with up to the fit's gap to spare
    (:attr:`pfield.robot.geometry.LinkFitReport.max_gap`, 14–15 mm on the UR5), so touching primitives keep the
    meshes apart; the margin is for the obstacles, whose dampers the tracking needs room for.

    Why (issue 34): for wrist_1 between 1.2 and 1.8 rad, the UR5's fitted forearm_link and wrist_2_link are at
    most 2 mm apart at every wrist_2 angle (their meshes up to 14 mm), so with a 3 mm margin the search could not
    turn the wrist through there: table_under_pick 5, 27, 53, 58, 79, 83 and 86 (goals with wrist_1 at 2.9–3.0 rad,
    starts at about −1) ended at the time limit (5 and 27: not within 6 s with three seeds), where OMPL on the
    meshes solves them. With the slack, 7 of 7; the exact check of the tracked motion still decides
    (:func:`contact_region`)."""
    return np.full(len(arrays.self_pairs), float(margin))


def sampling_window(robot: RobotModel, box: tuple[NDArray[np.float64], NDArray[np.float64]],
                    start: NDArray[np.float64], goals: Sequence[NDArray[np.float64]], step: float
                    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The box most of a joint-space search samples: for each revolute joint, the interval ``[min − pad, max + pad]``
    over the start's and the goals' values, with pad = max(0, (2π − (max − min)) / 2) + step / 2 (a turn, centred on
    them, and half an extension beyond), clipped to ``box`` (the joint limits); other joints sample ``box``.

    Why: a sample more than half a turn from the start and the goals in some joint pulls a tree the long way round
    (on a UR5, ±π per joint: the upper arm under its base, the wrist turned past the goal), where no path that
    matters goes. On the MotionBenchMaker UR5 cage, 8 problems of which the whole box solved 4 within 3 s (2.8–3 s)
    were all solved within 0.07–0.9 s (with no half step of pad: 0.08–1.7 s). Every :data:`WIDE_EVERY`-th chunk of
    the search still samples the whole box (:func:`_search`), so every configuration can still be sampled."""
    lower, upper = (np.array(b, dtype=np.float64) for b in box)
    ends = np.vstack([start, *goals])
    low, high = ends.min(axis=0), ends.max(axis=0)
    turn = 2.0 * math.pi
    revolute = np.asarray(robot.kinematics.kinds) == 0
    pad = np.maximum(0.0, (turn - (high - low)) / 2.0) + step / 2.0
    lower = np.where(revolute, np.maximum(lower, low - pad), lower)
    upper = np.where(revolute, np.minimum(upper, high + pad), upper)
    return np.ascontiguousarray(lower), np.ascontiguousarray(upper)


def _clearance_scene(scene: _wb.Scene, search_scene: _wb.Scene, arrays: _wb.RobotArrays,
                     ends: Sequence[NDArray[np.float64]], margin: float, options: GlobalOptions,
                     goal_band: float = 0.0,
                     measured: Sequence[tuple[NDArray[np.float64], NDArray[np.float64]]] | None = None) -> _wb.Scene:
    """The offsets under which a checker of margin ``margin + smoothing_clearance`` keeps that much more from
    the obstacles only: link–obstacle pairs get :func:`endpoint_scene`'s offsets at the larger margin (a pair
    closer than it at an end may go as deep as there, no deeper), self pairs their search offsets less the
    clearance (the search's own test). Conservative capsules of neighbouring links are often within a
    centimetre of each other everywhere (the UR5's forearm and wrist): a clearance between them would refuse
    every shortcut."""
    wide = endpoint_scene(scene, arrays, ends, margin + options.smoothing_clearance, options.endpoint_band,
                          goal_band, measured)
    return wide._replace(self_offsets=search_scene.self_offsets - options.smoothing_clearance)


def track(robot: RobotModel, arrays: _wb.RobotArrays, scene: _wb.Scene, path: NDArray[np.float64], goal: Pose,
          params: NDArray[np.float64], max_iterations: int, options: GlobalOptions,
          cancel: NDArray[np.uint8] | None = None) -> tuple:  # type: ignore[type-arg]
    """The field's damper QP following ``path`` (the core's ``planning/track``; the GIL is released); ``cancel`` is
    a :class:`~pfield.planning.CancelToken`'s flag, polled every step.

    Returns ``(status, count, q, qdot, positions, quaternions, twists, clearances, culprit)`` as the field's loop
    (:func:`pfield.planning._whole_body_core.plan_loop`)."""
    flag = cancel_flag(None) if cancel is None else cancel
    waypoints = np.ascontiguousarray(path, dtype=np.float64)
    n, total = waypoints.shape[1], max_iterations + 1
    qs, qds = np.empty((total, n)), np.empty((total, n))
    positions, quats, twists, clear = np.empty((total, 3)), np.empty((total, 4)), np.empty((total, 6)), np.empty(total)
    result = _core.track_path(core_scene(arrays, scene), waypoints[0].copy(), waypoints,
                              np.array(goal.position, dtype=np.float64), np.array(goal.orientation, dtype=np.float64),
                              params, max_iterations, float(options.tracking_gain), float(options.tracking_lead), flag,
                              qs, qds, positions, quats, twists, clear)
    count = result.count
    return PlanStatus(result.status), count, qs[:count], qds[:count], positions[:count], quats[:count], \
        twists[:count], clear[:count], culprit(result.last)


def exact_contact(robot: RobotModel, arrays: _wb.RobotArrays, scene: _wb.Scene, qs: NDArray[np.float64],
                  obstacles: Sequence[Obstacle] | None, resolution: float) -> str:
    """The first contact ("" if none) on the joint path ``qs``: the planner's certificate
    (:func:`pfield.planning.certify.certify_path`: every waypoint and every ``resolution`` rad between, exact
    meshes, obstacles and self pairs). ``arrays`` and ``scene`` are no longer needed (the link model is not
    trusted to preselect waypoints: it missed contacts, issue 34); kept for the callers' signature."""
    from pfield.planning.certify import certify_path

    del arrays, scene
    certificate = certify_path(robot, list(obstacles or ()), qs, resolution)
    return "" if certificate.clear else certificate.pair


# ---- task space ---------------------------------------------------------------------------------------

def point_space_search(scene: _wb.Scene, start: NDArray[np.float64], goal: NDArray[np.float64], margin: float,
                       options: GlobalOptions, cancel: NDArray[np.uint8] | None = None) -> SearchResult:
    """Search a path of end-effector positions start → goal keeping ``margin`` (m) from every obstacle of
    ``scene`` (its packed obstacles and their bounding spheres).

    The sampling box is the bounding box of start, goal and the obstacles' bounding spheres, grown by
    ``10 · point_step`` (a detour around an obstacle needs room beyond it)."""
    centres, radii = scene.centres, scene.bounds
    points = np.vstack([start[None], goal[None], centres - radii[:, None], centres + radii[:, None]])
    pad = 10.0 * options.point_step
    lower, upper = points.min(axis=0) - pad, points.max(axis=0) + pad
    obstacles = core_obstacles(scene)
    clearance = _core.Checker(obstacles, float(margin + options.smoothing_clearance), float(options.point_resolution))
    return _search(lambda: _core.Checker(obstacles, float(margin), float(options.point_resolution)), clearance,
                   np.array(start, dtype=np.float64), np.array(goal, dtype=np.float64)[None],
                   np.ascontiguousarray(lower, dtype=np.float64), np.ascontiguousarray(upper, dtype=np.float64),
                   options.point_step, options, cancel)


def orientations_along(path: NDArray[np.float64], start: Pose, goal: Pose) -> list[Pose]:
    """Poses at the vertices of a position ``path``: the orientation q(s) = exp(s log(q_g ⊗ q_0⁻¹)) ⊗ q_0
    (the world-frame geodesic, i.e. slerp) with s the share of the path's length travelled."""
    lengths = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))])
    total = lengths[-1] if lengths[-1] > 0 else 1.0
    rotation = quaternion_log(quaternion_multiply(goal.orientation, quaternion_inverse(start.orientation)))
    poses = [Pose(p, quaternion_multiply(quaternion_exp(rotation * (s / total)), start.orientation))
             for p, s in zip(path, lengths, strict=True)]
    poses[-1] = Pose(path[-1], goal.orientation)
    return poses


def search_margin(config: FieldConfig, options: GlobalOptions) -> float:
    """Clearance (m) every searched state keeps: ``safety_distance + extra_margin``."""
    return float(config.safety_distance + options.extra_margin)
