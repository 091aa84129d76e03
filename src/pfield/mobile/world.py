"""A 2D world of circles and polygons for the simulation: compiled laser ray casting and clearance.

Obstacles are packed once: circles (K, 3) rows (cx, cy, radius) and polygon edges (E, 4) rows
(x1, y1, x2, y2). A ray from o along unit d hits a circle where ‖o + t·d − c‖ = r (smallest t ≥ 0) and
an edge where o + t·d = a + u·(b − a), u ∈ [0, 1], t ≥ 0 (solved with 2D cross products).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from pfield._validation import as_points
from pfield.errors import InvalidInput

__all__ = ["World2D", "clearance_kernel", "raycast_kernel"]


@njit(cache=True)
def _ray_circle(ox: float, oy: float, dx: float, dy: float, cx: float, cy: float, r: float) -> float:
    fx = ox - cx
    fy = oy - cy
    b = fx * dx + fy * dy
    disc = b * b - (fx * fx + fy * fy - r * r)
    if disc < 0.0:
        return np.inf
    root = math.sqrt(disc)
    t = -b - root
    if t < 0.0:
        t = -b + root  # origin inside the circle: the exit point
    return t if t >= 0.0 else np.inf


@njit(cache=True)
def _ray_segment(ox: float, oy: float, dx: float, dy: float, seg: NDArray[np.float64]) -> float:
    ex = seg[2] - seg[0]
    ey = seg[3] - seg[1]
    denom = dx * ey - dy * ex
    if abs(denom) < 1e-15:
        return np.inf
    wx = seg[0] - ox
    wy = seg[1] - oy
    t = (wx * ey - wy * ex) / denom
    u = (wx * dy - wy * dx) / denom
    if t >= 0.0 and 0.0 <= u <= 1.0:
        return t
    return np.inf


@njit(cache=True)
def raycast_kernel(ox: float, oy: float, angles: NDArray[np.float64], range_max: float,
                   circles: NDArray[np.float64], segments: NDArray[np.float64]) -> NDArray[np.float64]:
    """Range (m) of each beam from (ox, oy) at world ``angles``; ``inf`` where nothing is within range_max."""
    out = np.empty(angles.shape[0])
    for i in range(angles.shape[0]):
        dx = math.cos(angles[i])
        dy = math.sin(angles[i])
        best = np.inf
        for k in range(circles.shape[0]):
            best = min(best, _ray_circle(ox, oy, dx, dy, circles[k, 0], circles[k, 1], circles[k, 2]))
        for k in range(segments.shape[0]):
            best = min(best, _ray_segment(ox, oy, dx, dy, segments[k]))
        out[i] = best if best <= range_max else np.inf
    return out


@njit(cache=True)
def clearance_kernel(px: float, py: float, circles: NDArray[np.float64], segments: NDArray[np.float64],
                     points: NDArray[np.float64]) -> float:
    """Distance (m) from (px, py) to the nearest circle boundary (negative inside), edge or point."""
    best = np.inf
    for k in range(circles.shape[0]):
        best = min(best, math.hypot(px - circles[k, 0], py - circles[k, 1]) - circles[k, 2])
    for k in range(segments.shape[0]):
        ex = segments[k, 2] - segments[k, 0]
        ey = segments[k, 3] - segments[k, 1]
        length2 = ex * ex + ey * ey
        u = 0.0 if length2 == 0.0 else ((px - segments[k, 0]) * ex + (py - segments[k, 1]) * ey) / length2
        u = min(max(u, 0.0), 1.0)
        best = min(best, math.hypot(px - segments[k, 0] - u * ex, py - segments[k, 1] - u * ey))
    for k in range(points.shape[0]):
        best = min(best, math.hypot(px - points[k, 0], py - points[k, 1]))
    return best


def _segments(polygons: tuple[NDArray[np.float64], ...]) -> NDArray[np.float64]:
    rows = [np.hstack([poly, np.roll(poly, -1, axis=0)]) for poly in polygons]
    return np.ascontiguousarray(np.vstack(rows)) if rows else np.empty((0, 4))


@dataclass(frozen=True)
class World2D:
    """Obstacles of a 2D scene in the world frame (m): point obstacles, circles and closed polygons."""

    points: NDArray[np.float64] = field(default_factory=lambda: np.empty((0, 2)))
    circles: NDArray[np.float64] = field(default_factory=lambda: np.empty((0, 3)))
    polygons: tuple[NDArray[np.float64], ...] = ()

    @classmethod
    def build(cls, points: ArrayLike = (), circles: ArrayLike = (),
              polygons: tuple[ArrayLike, ...] | list[ArrayLike] = ()) -> World2D:
        """Validated world: points (M, 2), circles (K, 3) with radius > 0, polygons of ≥ 3 vertices (V, 2)."""
        pts = as_points("points", points, dim=2) if np.size(points) else np.empty((0, 2))
        circ = as_points("circles", circles, dim=3) if np.size(circles) else np.empty((0, 3))
        if np.any(circ[:, 2] <= 0.0):
            raise InvalidInput("circles", circ[:, 2].tolist(), "radii must be > 0")
        polys = []
        for i, poly in enumerate(polygons):
            vertices = as_points(f"polygons[{i}]", poly, dim=2)
            if vertices.shape[0] < 3:
                raise InvalidInput(f"polygons[{i}]", vertices.tolist(), "a polygon needs >= 3 vertices")
            polys.append(vertices)
        return cls(pts, circ, tuple(polys))

    @cached_property
    def segments(self) -> NDArray[np.float64]:
        """Polygon edges (E, 4): x1, y1, x2, y2 (each polygon closed); packed once per world."""
        return _segments(self.polygons)

    def raycast(self, origin: ArrayLike, angles: ArrayLike, range_max: float) -> NDArray[np.float64]:
        """Simulated laser: ranges (m) of beams from ``origin`` (x, y) at world ``angles`` (rad)."""
        x, y = np.asarray(origin, dtype=np.float64)[:2]
        return raycast_kernel(float(x), float(y), np.ascontiguousarray(angles, dtype=np.float64), range_max,
                              self.circles, self.segments)

    def clearance(self, position: ArrayLike) -> float:
        """Distance (m) from ``position`` (x, y) to the nearest obstacle (circles negative inside)."""
        x, y = np.asarray(position, dtype=np.float64)[:2]
        return float(clearance_kernel(float(x), float(y), self.circles, self.segments, self.points))
