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
from numpy.typing import ArrayLike, NDArray

from pfield._core import mobile as _mobile
from pfield._validation import as_vector, finite, nonnegative, positive
from pfield.errors import InvalidInput
from pfield.mobile.field2d import obstacle_arrays

__all__ = ["SCAN_WEIGHTINGS", "LaserScanLike", "ObstaclePoints", "compose_pose2d", "point_obstacles", "scan_obstacles",
           "scan_ranges_obstacles"]

SCAN_WEIGHTINGS = ("sector", "arc_length", "sum")
_CORE_WEIGHTING = {name: _mobile.ScanWeighting(k) for k, name in enumerate(SCAN_WEIGHTINGS)}
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
    core_weighting = _CORE_WEIGHTING.get(weighting) if isinstance(weighting, str) else None
    if core_weighting is None:
        raise InvalidInput("scan_weighting", weighting, f"must be one of {SCAN_WEIGHTINGS}")
    sector = positive("scan_sector_angle", sector_angle)
    sx, sy, syaw = as_vector("sensor_pose", sensor_pose, 3)
    points, weights = _mobile.scan_points(values, a_min, inc, r_min, r_max, float(sx), float(sy), float(syaw),
                                          core_weighting, sector)
    return ObstaclePoints(points, weights)


def scan_obstacles(scan: LaserScanLike, sensor_pose: ArrayLike = (0.0, 0.0, 0.0), weighting: str = "sector",
                   sector_angle: float = math.radians(5.0)) -> ObstaclePoints:
    """Obstacle points from a ``LaserScan`` message; see :func:`scan_ranges_obstacles`."""
    return scan_ranges_obstacles(scan.ranges, scan.angle_min, scan.angle_increment, scan.range_min,
                                 scan.range_max, sensor_pose, weighting, sector_angle)


def point_obstacles(points: ArrayLike | None, weights: ArrayLike | None = None) -> ObstaclePoints:
    """Obstacle points from a point list (M, 2), weight 1 each unless ``weights`` (M,) are given."""
    return ObstaclePoints(*obstacle_arrays(points, weights))
