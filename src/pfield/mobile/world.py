"""A 2D world of circles and polygons for the simulation: laser ray casting and clearance (compiled core).

Obstacles are packed once: circles (K, 3) rows (cx, cy, radius) and polygon edges (E, 4) rows
(x1, y1, x2, y2). A ray from o along unit d hits a circle where ‖o + t·d − c‖ = r (smallest t ≥ 0) and
an edge where o + t·d = a + u·(b − a), u ∈ [0, 1], t ≥ 0 (solved with 2D cross products).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pfield._core import mobile as _mobile
from pfield._validation import as_points
from pfield.errors import InvalidInput

__all__ = ["World2D"]


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
        beams = np.ascontiguousarray(angles, dtype=np.float64)
        ranges: NDArray[np.float64] = _mobile.raycast(float(x), float(y), beams, float(range_max), self.circles,
                                                      self.segments)
        return ranges

    def clearance(self, position: ArrayLike) -> float:
        """Distance (m) from ``position`` (x, y) to the nearest obstacle (circles negative inside)."""
        x, y = np.asarray(position, dtype=np.float64)[:2]
        return float(_mobile.clearance(float(x), float(y), self.circles, self.segments, self.points))
