"""Obstacle points for the 2D field from a ``sensor_msgs/LaserScan`` or from a point list.

Beam i of a scan points at θ_i = angle_min + i·angle_increment in the sensor frame and, when its range r_i
is finite and within [range_min, range_max], hits at ``R(yaw)·r_i·(cos θ_i, sin θ_i) + (x, y)`` where
(x, y, yaw) is the sensor pose in the output frame. Other beams are ignored (ROS REP 117: ``inf`` means "no
return", ``nan`` "invalid").

**Weighting.** The original node summed one repulsive hill per beam, so a wall seen by a 0.25° lidar pushed
four times harder than the same wall seen by a 1° lidar, and the stopping distance depended on the sensor.
Three weightings are offered (``scan_weighting``):

* ``sector`` (default): the nearest return in each angular sector of ``scan_sector_angle`` rad (5° by
  default; sectors tile [−π, π) in the sensor frame), weight 1. Independent of the beam spacing as long as
  each sector holds at least one beam; a wall acts like a few of the seed's point obstacles, so the seed's
  parameters keep their meaning, and the field sums over ≤ 72 points instead of every beam.
* ``arc_length``: every valid beam weighted by the surface length it covers, r_i·|angle_increment| (m):
  the sum approximates a line integral over the seen surface (resolution-independent, smooth, but the
  gains then act per metre of surface).
* ``sum``: every valid beam, weight 1 — the original node's behaviour.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple, Protocol

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from pfield._validation import as_vector, finite, nonnegative, positive
from pfield.errors import InvalidInput
from pfield.mobile.field2d import obstacle_arrays

__all__ = ["SCAN_WEIGHTINGS", "LaserScanLike", "ObstaclePoints", "compose_pose2d", "point_obstacles", "scan_obstacles",
           "scan_ranges_obstacles"]

SCAN_WEIGHTINGS = ("sector", "arc_length", "sum")
_SECTOR, _ARC_LENGTH, _SUM = 0, 1, 2
_MAX_BEAMS = 1_000_000


class LaserScanLike(Protocol):
    """The fields of ``sensor_msgs/LaserScan`` this module reads (``pfield.interfaces.sensor_msgs.LaserScan``
    or an rclpy message); a protocol so that the core does not depend on the interface layer."""

    @property
    def angle_min(self) -> float: ...
    @property
    def angle_increment(self) -> float: ...
    @property
    def range_min(self) -> float: ...
    @property
    def range_max(self) -> float: ...
    @property
    def ranges(self) -> Sequence[float]: ...


class ObstaclePoints(NamedTuple):
    """Obstacle points (M, 2) in the output frame (m) and their weights (M,) for the repulsive sum."""

    points: NDArray[np.float64]
    weights: NDArray[np.float64]


_ANCHOR = 32  # beams between exact cos/sin evaluations of the rotation recurrence


@njit(cache=True)
def _select(ranges: NDArray[np.float64], angle_min: float, angle_increment: float, range_min: float,
            range_max: float, weighting: int, sector_angle: float) -> NDArray[np.bool_]:
    """Which beams become points: all valid ones, or the nearest valid one per sector."""
    n = ranges.shape[0]
    keep = np.zeros(n, dtype=np.bool_)
    if weighting != _SECTOR:
        for i in range(n):
            keep[i] = range_min <= ranges[i] <= range_max  # False for NaN and for inf > range_max
        return keep
    n_sectors = max(1, math.ceil(2.0 * math.pi / sector_angle))
    best = np.full(n_sectors, np.inf)
    best_index = np.full(n_sectors, -1)
    inverse = 1.0 / sector_angle
    for i in range(n):
        r = ranges[i]
        if range_min <= r <= range_max:
            offset = angle_min + i * angle_increment + math.pi  # wrapped into [0, 2π) without a float modulo
            offset -= 2.0 * math.pi * math.floor(offset * (0.5 / math.pi))
            sector = min(int(offset * inverse), n_sectors - 1)
            if r < best[sector]:
                best[sector] = r
                best_index[sector] = i
    for k in range(n_sectors):
        if best_index[k] >= 0:
            keep[best_index[k]] = True
    return keep


@njit(cache=True)
def scan_points_kernel(ranges: NDArray[np.float64], angle_min: float, angle_increment: float,
                       range_min: float, range_max: float, sx: float, sy: float, syaw: float, weighting: int,
                       sector_angle: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Valid beams → (points (M, 2), weights (M,)) in the output frame, weighted as in the module docstring.

    Beam directions come from the rotation recurrence (cos, sin)(θ + Δ) = R(Δ)·(cos, sin)(θ), re-anchored
    with exact cos/sin every ``_ANCHOR`` beams (error ≲ 1e-14), which is several times cheaper than libm.
    """
    keep = _select(ranges, angle_min, angle_increment, range_min, range_max, weighting, sector_angle)
    count = int(keep.sum())
    points = np.empty((count, 2))
    weights = np.ones(count)
    c_yaw, s_yaw = math.cos(syaw), math.sin(syaw)
    c_step, s_step = math.cos(angle_increment), math.sin(angle_increment)
    c = s = 0.0
    k = 0
    for i in range(ranges.shape[0]):
        if i % _ANCHOR == 0:
            theta = angle_min + i * angle_increment
            c, s = math.cos(theta), math.sin(theta)
        if keep[i]:
            lx = ranges[i] * c
            ly = ranges[i] * s
            points[k, 0] = sx + c_yaw * lx - s_yaw * ly
            points[k, 1] = sy + s_yaw * lx + c_yaw * ly
            if weighting == _ARC_LENGTH:
                weights[k] = ranges[i] * abs(angle_increment)
            k += 1
        c, s = c * c_step - s * s_step, s * c_step + c * s_step
    return points, weights


def compose_pose2d(parent: ArrayLike, child: ArrayLike) -> NDArray[np.float64]:
    """Pose (x, y, yaw) of ``child`` (given in ``parent``'s frame) in the frame ``parent`` is given in."""
    px, py, pyaw = as_vector("pose", parent, 3)
    cx, cy, cyaw = as_vector("sensor_pose", child, 3)
    c, s = math.cos(pyaw), math.sin(pyaw)
    return np.array([px + c * cx - s * cy, py + s * cx + c * cy, math.atan2(math.sin(pyaw + cyaw),
                                                                             math.cos(pyaw + cyaw))])


def scan_ranges_obstacles(ranges: ArrayLike, angle_min: float, angle_increment: float, range_min: float,
                          range_max: float, sensor_pose: ArrayLike = (0.0, 0.0, 0.0),
                          weighting: str = "sector", sector_angle: float = math.radians(5.0)) -> ObstaclePoints:
    """Obstacle points from raw scan arrays (the fields of ``LaserScan``); ``sensor_pose`` = (x, y, yaw)."""
    values = np.ascontiguousarray(ranges, dtype=np.float64).reshape(-1)
    if values.size > _MAX_BEAMS:
        raise InvalidInput("ranges", f"{values.size} beams", f"at most {_MAX_BEAMS} beams")
    a_min = finite("angle_min", angle_min)
    inc = finite("angle_increment", angle_increment)
    if inc == 0.0 and values.size > 1:
        raise InvalidInput("angle_increment", angle_increment, "must be non-zero for more than one beam")
    r_min = nonnegative("range_min", range_min)
    r_max = positive("range_max", range_max)
    if r_max < r_min:
        raise InvalidInput("range_max", range_max, f"must be >= range_min ({range_min})")
    if weighting not in SCAN_WEIGHTINGS:
        raise InvalidInput("scan_weighting", weighting, f"must be one of {SCAN_WEIGHTINGS}")
    sector = positive("scan_sector_angle", sector_angle)
    sx, sy, syaw = as_vector("sensor_pose", sensor_pose, 3)
    points, weights = scan_points_kernel(values, a_min, inc, r_min, r_max, sx, sy, syaw,
                                         SCAN_WEIGHTINGS.index(weighting), sector)
    return ObstaclePoints(points, weights)


def scan_obstacles(scan: LaserScanLike, sensor_pose: ArrayLike = (0.0, 0.0, 0.0), weighting: str = "sector",
                   sector_angle: float = math.radians(5.0)) -> ObstaclePoints:
    """Obstacle points from a ``LaserScan`` message; see :func:`scan_ranges_obstacles`."""
    return scan_ranges_obstacles(scan.ranges, scan.angle_min, scan.angle_increment, scan.range_min,
                                 scan.range_max, sensor_pose, weighting, sector_angle)


def point_obstacles(points: ArrayLike | None, weights: ArrayLike | None = None) -> ObstaclePoints:
    """Obstacle points from a point list (M, 2), weight 1 each unless ``weights`` (M,) are given."""
    return ObstaclePoints(*obstacle_arrays(points, weights))
