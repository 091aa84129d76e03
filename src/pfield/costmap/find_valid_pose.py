"""FindValidPose: the closest pose to a requested one where a footprint fits (Move Base Flex's service).

Candidates (Move Base Flex ``mbf_msgs/FindValidPose``, with the contract kept exactly):

* positions ``p₀ + (i, j)·res`` on the costmap's lattice through the requested position, with
  ``res·√(i² + j²) ≤ dist_tolerance``; yaws ``ψ₀ + δ`` with ``δ = 0, +Δ, −Δ, +2Δ, −2Δ, …``,
  ``|δ| ≤ min(angle_tolerance, π)`` (``Δ = angle_increment``; +π and −π are the same yaw, kept once);
* **order**: distance ``√(i² + j²)``, then ``|δ|``, then the tie-break: +δ before −δ, then the polar
  angle ``atan2(j, i)`` of the offset in [0, 2π) (counter-clockwise from the map's +x axis). The
  requested pose is first.

Each candidate's footprint (``footprint`` padded by ``safety_dist``) is rasterised exactly and given the
state OUTSIDE (a covered cell is outside the map) > LETHAL > UNKNOWN > INSCRIBED > FREE, and the cost =
the **sum** of the covered in-map cells' costs. Answer: among FREE and INSCRIBED candidates those at the
smallest distance, FREE ones preferred, the first in order; failing that the first UNKNOWN; failing that
the first OUTSIDE; otherwise LETHAL with no pose.

Speed: one rasterised kernel per yaw, shared by every position (the sub-cell offset is the same for all
lattice positions); rings of equal distance evaluated in order, stopping at the first ring holding a FREE
or INSCRIBED candidate; a lethal-distance prefilter; all compiled (``src/core/costmap/find_valid_pose.hpp``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from pfield._core import costmap as _costmap
from pfield._enums import NamedIntEnum
from pfield._validation import nonnegative, positive
from pfield.costmap.costmap import Costmap2D
from pfield.costmap.footprint import Footprint
from pfield.errors import InvalidInput
from pfield.spatial import Pose, quaternion_multiply

__all__ = [
    "DEFAULT_ANGLE_INCREMENT",
    "MAX_CANDIDATES",
    "MAX_CANDIDATE_POSITIONS",
    "MAX_KERNEL_CELLS",
    "PoseState",
    "SearchTrace",
    "ValidPoseResult",
    "candidate_offsets",
    "find_valid_pose",
    "pose_state",
    "yaw_offsets",
]

DEFAULT_ANGLE_INCREMENT = math.radians(5.0)
MAX_CANDIDATE_POSITIONS = 4_000_000
"""Most lattice positions one search considers (``π·(dist_tolerance/res)²``)."""
MAX_CANDIDATES = 20_000_000
"""Most candidates (positions × yaws) one search may hold: its state table is one byte per candidate."""
MAX_KERNEL_CELLS = 4_000_000
"""Most rasterised footprint cells over all yaws (footprint cells × yaws, 16 bytes each): a 1 m robot at
5 cm and 5° is ~3·10⁴; a 20 m ``safety_dist`` at 0.1° would be ~10⁹ (gigabytes)."""
_SLACK = 1e-9
_FAR_CELLS = 2.0**40
_NOT_EVALUATED: int = _costmap.PoseState.NOT_EVALUATED.value


class PoseState(NamedIntEnum):
    """The response's state constants (``FindValidPose.srv``); prints its name (``INSCRIBED``), compares and
    serialises as its number."""

    FREE = 0
    INSCRIBED = 1
    LETHAL = 2
    UNKNOWN = 3
    OUTSIDE = 4


@dataclass(frozen=True, eq=False)
class SearchTrace:
    """The candidates of one search: ``positions`` (P, 2) map-frame xy in answer order, ``yaw_offsets``
    (A,) in order, and ``states[p, a]`` (uint8: a :class:`PoseState`; 5 = rejected, i.e. neither FREE
    nor INSCRIBED and not needed as a fallback; 255 = not evaluated)."""

    positions: NDArray[np.float64]
    yaw_offsets: NDArray[np.float64]
    states: NDArray[np.uint8]

    @property
    def evaluated(self) -> int:
        """Number of candidates whose state was computed."""
        return int(np.count_nonzero(self.states != _NOT_EVALUATED))


@dataclass(frozen=True, eq=False)
class ValidPoseResult:
    """FindValidPose's answer: ``state``, ``cost`` (sum over covered cells) and ``pose`` (None if LETHAL).

    ``distance`` (m) and ``yaw_offset`` (rad) locate the answer relative to the requested pose.
    """

    state: PoseState
    cost: int
    pose: Pose | None
    distance: float | None
    yaw_offset: float | None
    trace: SearchTrace


@lru_cache(maxsize=16)
def candidate_offsets(max_ring: int) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
    """Lattice offsets ``(i, j)`` with ``i² + j² ≤ max_ring`` in answer order, and ring starts.

    Returns ``(pos_i, pos_j, ring_ptr)``: positions sorted by ``i² + j²`` then polar angle in [0, 2π);
    ring ``r`` is ``ring_ptr[r]:ring_ptr[r+1]`` (equal ``i² + j²``).
    """
    reach = math.isqrt(max_ring)
    grid = np.arange(-reach, reach + 1, dtype=np.int64)
    pos_i, pos_j = (a.reshape(-1) for a in np.meshgrid(grid, grid, indexing="xy"))
    r2 = pos_i * pos_i + pos_j * pos_j
    keep = r2 <= max_ring
    pos_i, pos_j, r2 = pos_i[keep], pos_j[keep], r2[keep]
    polar = np.mod(np.arctan2(pos_j, pos_i), 2.0 * math.pi)
    order = np.lexsort((polar, r2))
    pos_i, pos_j, r2 = pos_i[order], pos_j[order], r2[order]
    starts = np.flatnonzero(np.diff(r2)) + 1
    ring_ptr = np.concatenate(([0], starts, [r2.size])).astype(np.int64)
    for array in (pos_i, pos_j, ring_ptr):
        array.setflags(write=False)
    return np.ascontiguousarray(pos_i), np.ascontiguousarray(pos_j), ring_ptr


def yaw_offsets(angle_tolerance: float, angle_increment: float) -> NDArray[np.float64]:
    """Yaw offsets ``0, +Δ, −Δ, +2Δ, −2Δ, …`` within ``min(angle_tolerance, π)`` (rad), ±π kept once."""
    limit = min(angle_tolerance, math.pi) * (1.0 + _SLACK)
    offsets = [0.0]
    k = 1
    while k * angle_increment <= limit:
        delta = k * angle_increment
        offsets.append(min(delta, math.pi))
        if delta < math.pi - 1e-12:
            offsets.append(-delta)
        k += 1
    return np.array(offsets)


def _kernels(costmap: Costmap2D, footprint: Footprint, pose: Pose, yaws: NDArray[np.float64]
             ) -> tuple[int, int, _costmap.YawKernels]:
    """Base cell of the requested pose and the footprint rasterised at each yaw, relative to that cell."""
    u0 = (float(pose.position[0]) - costmap.origin_x) / costmap.resolution
    v0 = (float(pose.position[1]) - costmap.origin_y) / costmap.resolution
    if max(abs(u0), abs(v0)) > _FAR_CELLS:
        raise InvalidInput("pose.position", pose.position.tolist(), "too far from the map (over 2^40 cells)")
    base_m, base_n = math.floor(u0), math.floor(v0)
    points = footprint.points
    kernels = _costmap.rasterize_yaws(np.ascontiguousarray(points[:, 0]), np.ascontiguousarray(points[:, 1]),
                                      u0 - base_m, v0 - base_n, yaws, 1.0 / costmap.resolution)
    return base_m, base_n, kernels


def _answer_pose(pose: Pose, costmap: Costmap2D, i: int, j: int, delta: float) -> Pose:
    if i == 0 and j == 0 and delta == 0.0:
        return pose
    turn = np.array([0.0, 0.0, math.sin(0.5 * delta), math.cos(0.5 * delta)])
    position = pose.position + np.array([i * costmap.resolution, j * costmap.resolution, 0.0])
    return Pose(position, quaternion_multiply(turn, pose.orientation))


def _max_ring(costmap: Costmap2D, base_m: int, base_n: int, kernel_reach: int, dist_tolerance: float) -> int:
    """Largest ``i² + j²`` to search: the tolerance, capped where every candidate lies entirely outside the map
    (a position that far out is OUTSIDE and nearer to the request than anything beyond it); ``kernel_reach``
    is the largest cell offset of the rasterised footprints."""
    reach = kernel_reach + 2
    corner = max(abs(base_m), abs(base_n), abs(base_m - costmap.size_x), abs(base_n - costmap.size_y))
    limit = 2 * (corner + reach) ** 2
    ratio = dist_tolerance / costmap.resolution  # compared before squaring: 1e308 must not overflow
    max_ring = limit if ratio > math.sqrt(limit) + 1.0 else math.floor(ratio**2 * (1.0 + _SLACK) + _SLACK)
    max_ring = min(max_ring, limit)
    if math.pi * max_ring > MAX_CANDIDATE_POSITIONS:
        raise InvalidInput("dist_tolerance", dist_tolerance,
                           f"too large for resolution {costmap.resolution} (over {MAX_CANDIDATE_POSITIONS} positions)")
    return max_ring


def _check_kernel_work(costmap: Costmap2D, robot: Footprint, yaws: int, safety_dist: float) -> None:
    """Refuse a search whose rasterised footprints (cells of the bounding square of the footprint's reach,
    times the yaws) exceed :data:`MAX_KERNEL_CELLS`, before any is built."""
    reach = float(np.max(np.hypot(robot.points[:, 0], robot.points[:, 1]))) / costmap.resolution
    cells = (2.0 * reach + 3.0) ** 2 * yaws
    if cells > MAX_KERNEL_CELLS:
        field, value = ("safety_dist", safety_dist) if safety_dist > 0.0 else ("angle_increment", yaws)
        raise InvalidInput(field, value, f"the footprint (reach {reach * costmap.resolution:.3g} m) at {yaws} "
                           f"yaws covers ~{cells:.3g} cells, above the cap of {MAX_KERNEL_CELLS}")


def _prefilter_limit(costmap: Costmap2D, robot: Footprint, pose: Pose, base_m: int, base_n: int) -> float:
    """Lethal distance (cells, from a base cell centre) below which a position is LETHAL for every yaw.

    With c the pose's offset from its cell centre and L a lethal cell centre at distance D from the base
    cell centre, the candidate centre is within D + |c| of L, and the lethal cell holds the disc of radius
    ½ around L (minus its top/right rim). If D + |c| − ½ < r_i the cell meets the inscribed disc, which the
    footprint contains when the robot centre is inside it: D < r_i + ½ − |c| (a margin of 1e-6 cells).
    """
    if not robot.contains_center:
        return -1.0
    offset = math.hypot((pose.position[0] - costmap.origin_x) / costmap.resolution - base_m - 0.5,
                        (pose.position[1] - costmap.origin_y) / costmap.resolution - base_n - 0.5)
    return robot.inscribed_radius / costmap.resolution + 0.5 - offset - 1e-6


def find_valid_pose(
    costmap: Costmap2D, footprint: Footprint, pose: Pose, *, safety_dist: float = 0.0,
    dist_tolerance: float = 0.0, angle_tolerance: float = 0.0, angle_increment: float = DEFAULT_ANGLE_INCREMENT,
) -> ValidPoseResult:
    """The closest valid pose to ``pose`` (in the costmap's frame) for ``footprint`` padded by ``safety_dist``.

    Distances in m, angles in rad; see the module docstring for the candidate order and the answer rule.
    Raises :class:`~pfield.errors.InvalidInput` for negative or non-finite tolerances or safety distance.
    """
    safety_dist = nonnegative("safety_dist", safety_dist)
    dist_tolerance = nonnegative("dist_tolerance", dist_tolerance)
    angle_tolerance = nonnegative("angle_tolerance", angle_tolerance)
    angle_increment = positive("angle_increment", angle_increment)
    try:
        robot = footprint.padded(safety_dist) if safety_dist > 0.0 else footprint
    except InvalidInput as exc:  # the padded polygon is out of the footprint's range: say which input did it
        raise InvalidInput("safety_dist", safety_dist, f"the padded footprint is refused: {exc.reason}") from None
    deltas = yaw_offsets(angle_tolerance, angle_increment)
    _check_kernel_work(costmap, robot, deltas.size, safety_dist)
    base_m, base_n, kernels = _kernels(costmap, robot, pose, np.ascontiguousarray(pose.yaw + deltas))
    max_ring = _max_ring(costmap, base_m, base_n, kernels.reach, dist_tolerance)
    if (math.pi * max_ring + 4 * math.sqrt(max_ring) + 1) * deltas.size > MAX_CANDIDATES:
        raise InvalidInput("dist_tolerance", dist_tolerance, f"with {deltas.size} yaws (angle_tolerance "
                           f"{angle_tolerance:g}, angle_increment {angle_increment:g}) the search exceeds "
                           f"{MAX_CANDIDATES} candidates")
    pos_i, pos_j, ring_ptr = candidate_offsets(max_ring)
    states = np.full((pos_i.size, deltas.size), _NOT_EVALUATED, dtype=np.uint8)
    found = _costmap.find_valid_pose(costmap.costs, costmap.lethal_distance, base_m, base_n, kernels, pos_i, pos_j,
                                     ring_ptr, _prefilter_limit(costmap, robot, pose, base_m, base_n), states)
    positions = np.column_stack((pose.position[0] + pos_i * costmap.resolution,
                                 pose.position[1] + pos_j * costmap.resolution))
    trace = SearchTrace(positions, deltas, states)
    if not found.found:
        return ValidPoseResult(PoseState.LETHAL, 0, None, None, None, trace)
    i, j, delta = int(pos_i[found.position]), int(pos_j[found.position]), float(deltas[found.yaw])
    return ValidPoseResult(PoseState(found.state.value), int(found.cost), _answer_pose(pose, costmap, i, j, delta),
                           costmap.resolution * math.hypot(i, j), delta, trace)


def pose_state(costmap: Costmap2D, footprint: Footprint, x: float, y: float, yaw: float) -> tuple[PoseState, int]:
    """State and cost (sum of covered in-map cells' costs) of the footprint at ``(x, y, yaw)`` in the map frame."""
    cells = footprint.cells(x, y, yaw, (costmap.origin_x, costmap.origin_y), costmap.resolution)
    placement = _costmap.evaluate_cells(costmap.costs, cells)
    return PoseState(placement.state.value), int(placement.cost)
