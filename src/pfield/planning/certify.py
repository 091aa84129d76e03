"""The planner's certificate: a joint trajectory checked on the exact collision meshes before it counts as reached.

:func:`certify_path` verifies a whole-body joint path (the waypoints, joined by straight joint-space segments)
with coal on the robot's collision geometry (:class:`~pfield.robot.collision.CollisionChecker`: every collision
object against every obstacle, and the self pairs that are neither adjacent nor disabled by the SRDF) at every
waypoint and at most ``resolution`` rad (max-norm of the joint change, 0.01 by default) between them: the
*grid*. Every grid configuration is either checked exactly or proven clear by conservative advancement:

* at a grid point with exact distance d_p of pair p, a joint motion Δq brings p at most
  Σ_j w_pj |Δq_j| closer (:attr:`CollisionChecker.motion_weights`; Schwarzer, Saha & Latombe, IEEE T-RO 21(3)
  2005, §III). Along the path the travel Δ_p(s) = Σ_j w_pj ∫|dq_j| is a monotone function of the arc; pair p
  stays clear — continuously, not only at grid points — while Δ_p(s) − Δ_p(s_0) < d_p − ε;
* so pair p is next computed at the first grid point where that no longer holds, and never later: the
  certificate is never weaker than checking every pair at every grid point (whose verdict it returns exactly),
  and where the bound covers a stretch it is continuous there. ε = :data:`~pfield.robot.collision.DISTANCE_TOLERANCE`
  (1e-6 m) covers coal's GJK tolerance;
* the bound holds both ways, so a pair due at grid point k whose last distance was d is first computed further on,
  at the last point t where Δ_p(t) − Δ_p(k) < 0.9 d: if its distance there exceeds Δ_p(t) − Δ_p(k) + ε, every point
  from k to t is clear too, and one computation has answered for both sides of t; else the pair is computed at k
  (a contact is only ever reported from its due point, so it is the first one).

d_p comes in two stages. First, for every pair and the whole grid in one compiled call
(:meth:`CollisionChecker.covering_needed`), a lower bound from covering capsules: each collision object inside its
link's covering capsule (the axis of :mod:`pfield.robot.geometry`'s, the radius reaching the object's hull), so
the capsules' distance (segment–obstacle signed distance, exact for spheres, capsules, boxes and, within
2^-20 of the axis length, cylinders; segment–segment for self pairs) never exceeds the exact one. The same
advancement runs on it; only the grid points it cannot clear go to the second stage, coal on the link meshes'
convex hulls (where two links' hulls touch, one mesh against the other's hull, and where that is not positive
either, the meshes: :meth:`CollisionChecker.pair_distances` with ``lower``), whose distances advance again. A grid
point is declared in contact only by coal, so the verdict, the first contact and its pair are those of coal on
every pair at every grid point.

Contact (distance ≤ 0) at a grid point fails the certificate, naming the pair, the waypoint and where.
"""

from __future__ import annotations

import bisect
import heapq
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pfield._validation import positive
from pfield.errors import InvalidInput
from pfield.geometry import Obstacle
from pfield.robot.collision import DISTANCE_TOLERANCE, UNBOUNDED_WEIGHT, CollisionChecker
from pfield.robot.model import LIMIT_TOLERANCE, RobotModel

__all__ = ["CERTIFICATE_RESOLUTION", "Certificate", "certify_path"]

CERTIFICATE_RESOLUTION = 0.01
"""(rad or m) largest max-norm joint change between two configurations the certificate answers for."""
_REFINE = 0.0  # m: hull distances as they are (refining below 1–10 cm with mesh distances saved no checks)
_AHEAD = 0.9
"""Share of a pair's last distance the certificate looks ahead by (:func:`certify_path`). Measured on the 97
certificates of 25 UR5 MotionBenchMaker plans each of table_pick, bookshelf_thin and cage (the same verdicts, first
contacts and pairs as without looking ahead), with the motion bounds before the axis bounds (collision._axis_bounds):
placements per certificate 130 → 99, 86, 88 at 0.6, 0.9, 1.0; with them, 43 → 31 at 0.9."""


@dataclass(frozen=True)
class Certificate:
    """Outcome of :func:`certify_path`.

    ``clear``: no grid configuration is in contact. Otherwise ``pair`` names the first contact
    (``link object/obstacle id`` or ``object/object``), ``self_collision`` says whether it is between two links,
    ``distance`` (m, ≤ 0) is its exact distance, ``waypoint`` the index k of the last waypoint before it (the
    contact lies on the segment k → k + 1 at ``fraction`` ∈ (0, 1], or at waypoint k itself with fraction 0),
    ``configuration`` the joint angles in contact. ``grid_points`` counts the configurations answered for,
    ``placements`` those at which exact distances were computed, ``distance_calls`` the coal calls,
    ``seconds`` the wall time.
    """

    clear: bool
    pair: str = ""
    self_collision: bool = False
    distance: float = math.inf
    waypoint: int = -1
    fraction: float = 0.0
    configuration: NDArray[np.float64] | None = None
    grid_points: int = 0
    placements: int = 0
    distance_calls: int = 0
    seconds: float = 0.0

    def describe(self) -> str:
        """The sentence beside a failed certificate ("" when clear)."""
        if self.clear:
            return ""
        where = (f"at waypoint {self.waypoint}" if self.fraction == 0.0 else
                 f"between waypoints {self.waypoint} and {self.waypoint + 1} ({self.fraction:.2f} of the way)")
        kind = "self-collision" if self.self_collision else "collision"
        return (f"{kind}: the exact mesh check finds {self.pair} in contact (distance {self.distance * 1e3:.2f} mm) "
                f"{where}")


def resolution_grid(qs: NDArray[np.float64], resolution: float) -> tuple[NDArray[np.float64], NDArray[np.int64],
                                                              NDArray[np.float64]]:
    """Every waypoint and ⌈max|Δq| / resolution⌉ − 1 evenly spaced points inside each segment: the grid's
    configurations (N, n), and for each its segment's first waypoint and the fraction along that segment."""
    if len(qs) == 1:
        return qs.copy(), np.zeros(1, dtype=np.int64), np.zeros(1)
    steps = np.maximum(1, np.ceil(np.max(np.abs(np.diff(qs, axis=0)), axis=1) / resolution - 1e-12)).astype(np.int64)
    segment = np.repeat(np.arange(len(steps)), steps)
    first = np.cumsum(steps) - steps  # each segment's first grid point after its waypoint, in the interior count
    fraction = (np.arange(len(segment)) - first[segment] + 1) / steps[segment]
    points = qs[segment] + fraction[:, None] * (qs[segment + 1] - qs[segment])
    return (np.vstack([qs[:1], points]), np.concatenate([[0], segment]).astype(np.int64),
            np.concatenate([[0.0], fraction]))


def certify_path(robot: RobotModel, obstacles: Sequence[Obstacle], joint_positions: ArrayLike,
                 resolution: float = CERTIFICATE_RESOLUTION, checker: CollisionChecker | None = None) -> Certificate:
    """Certify the joint path ``joint_positions`` ((K, n), tree order, rad or m) against ``obstacles`` and the
    robot itself on the exact collision meshes (module docstring). ``checker``: a
    :class:`CollisionChecker` of the same robot and obstacles, to reuse its shapes across calls."""
    begin = time.perf_counter()
    step = positive("resolution", resolution)
    qs = np.array(joint_positions, dtype=np.float64)
    if qs.ndim != 2 or qs.shape[0] < 1 or qs.shape[1] != robot.n_joints:
        raise InvalidInput("joint_positions", qs.shape, f"expected shape (K >= 1, {robot.n_joints})")
    lower, upper = robot.lower_limits - LIMIT_TOLERANCE, robot.upper_limits + LIMIT_TOLERANCE
    outside = ~np.isfinite(qs) | (qs < lower) | (qs > upper)
    if outside.any():
        k, j = (int(v) for v in np.argwhere(outside)[0])
        robot.check_joint_angles(qs[k], f"joint_positions[{k}]")  # raises the standard message
        raise InvalidInput(f"joint_positions[{k}][{j}]", float(qs[k, j]), "outside the joint limits")
    checker = checker or CollisionChecker(robot, obstacles)
    grid, segment, fraction = resolution_grid(qs, step)
    travel = np.vstack([np.zeros((1, qs.shape[1])), np.cumsum(np.abs(np.diff(grid, axis=0)), axis=0)])
    n_points, n_pairs = len(grid), len(checker.pair_names)
    # the covering capsules first, in one compiled call: a pair goes to coal only at the grid points where neither
    # their bound nor its advancement from an earlier grid point clears it
    needed = checker.covering_needed(grid, travel, DISTANCE_TOLERANCE) if n_pairs else np.zeros((0, n_points), bool)
    # sorted by pair, then by grid index (flat: numpy's 2-D nonzero took 10 times as long on these masks)
    pair_of, point_of = np.divmod(np.flatnonzero(needed), n_points)
    starts = np.searchsorted(pair_of, np.arange(n_pairs + 1))
    # each pair's grid points to answer for, of the pairs that have any (Python lists: bisect is 5x faster on them
    # than numpy's searchsorted on one value)
    pending = {p: point_of[starts[p]:starts[p + 1]].tolist()
               for p in np.flatnonzero(starts[1:] > starts[:-1]).tolist()}
    due = [(points[0], p) for p, points in pending.items()]  # a heap of (next grid point, pair)
    heapq.heapify(due)
    rows: dict[int, list[float]] = {}  # Δ_p at each grid point (monotone in the index), of the pairs computed
    known: dict[int, float] = {}  # each pair's last computed distance (m)
    weights = np.minimum(checker.motion_weights, UNBOUNDED_WEIGHT)
    placements = calls = 0

    def reschedule(p: int, row: list[float], index: int, distance: float) -> None:
        """Pair p is clear from ``index`` on while Δ_p stays below Δ_p(index) + ``distance`` − ε: due again at its
        first grid point past that."""
        clear_to = max(index + 1, bisect.bisect_left(row, row[index] + distance - DISTANCE_TOLERANCE))
        points = pending[p]
        following = bisect.bisect_left(points, clear_to)
        if following < len(points):
            heapq.heappush(due, (points[following], p))

    while due:
        index = due[0][0]
        pairs = []  # the pairs computed at index itself
        while due and due[0][0] == index:
            p = heapq.heappop(due)[1]
            row = rows.get(p)
            if row is None:
                row = rows[p] = (travel @ weights[p]).tolist()
            last = known.get(p, 0.0)
            # looking ahead: a distance d at a grid point t > index clears, besides the points after t, every point k
            # of [index, t] with Δ_p(t) − Δ_p(k) < d − ε (the bound holds both ways), so where a pair's distance
            # holds, one computation at t answers for twice the stretch. t: where the last distance, 90 % of it,
            # would be used up; when d falls short, the pair is computed at index as without looking ahead
            ahead = min(bisect.bisect_left(row, row[index] + _AHEAD * last) - 1, pending[p][-1])
            if last > 0.0 and ahead > index:
                d = float(checker.pair_distances(grid[ahead], (p,), _REFINE, lower=True)[0])
                placements, calls = placements + 1, calls + 1
                if row[ahead] - row[index] < d - DISTANCE_TOLERANCE:
                    known[p] = d
                    reschedule(p, row, ahead, d)
                    continue
            pairs.append(p)
        if not pairs:
            continue
        distances = checker.pair_distances(grid[index], pairs, _REFINE, lower=True).tolist()
        placements, calls = placements + 1, calls + len(pairs)
        # the deepest contact (the first of equal ones); a distance that is not a number counts as a contact too
        failed = [i for i, d in enumerate(distances) if not d > 0.0]
        if failed:  # every grid point before index is clear of every pair: the first contact
            worst = min(failed, key=lambda i: (distances[i] != distances[i], distances[i]))
            pair = pairs[worst]
            return Certificate(False, checker.pair_names[pair], bool(checker.self_pair[pair]), distances[worst],
                               int(segment[index]), float(fraction[index]), grid[index].copy(), index + 1,
                               placements, calls, time.perf_counter() - begin)
        for p, d in zip(pairs, distances, strict=True):
            known[p] = d
            reschedule(p, rows[p], index, d)
    return Certificate(True, grid_points=n_points, placements=placements, distance_calls=calls,
                       seconds=time.perf_counter() - begin)

