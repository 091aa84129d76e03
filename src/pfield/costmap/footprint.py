"""Robot footprints as nav2 defines them: a polygon or a radius, padding, inscribed/circumscribed radii.

A footprint is a simple polygon in the robot frame (x forward, y left, metres), given as nav2's
``footprint`` parameter string ``"[[x, y], [x, y], ...]"`` or, when that is empty (``"[]"``), a
16-gon of ``robot_radius`` (nav2 ``makeFootprintFromRadius``). Padding moves every vertex outwards per
coordinate, ``x += sign(x)·padding``, ``y += sign(y)·padding`` (nav2 ``padFootprint``). The inscribed
radius is the smallest distance from the robot centre to the polygon's edges, the circumscribed radius
the largest distance to a vertex (nav2 ``calculateMinAndMaxDistances``).

Rasterisation onto a grid is exact: a cell is covered when the closed polygon meets the half-open cell
(compiled core: ``src/core/costmap/raster.hpp``). Concave polygons are supported; self-intersecting ones are
rejected.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import yaml
from numpy.typing import ArrayLike, NDArray
from shapely.geometry import LinearRing, Point, Polygon

from pfield._core import costmap as _costmap
from pfield.errors import InvalidInput

__all__ = ["RADIUS_FOOTPRINT_POINTS", "Footprint"]

RADIUS_FOOTPRINT_POINTS = 16
"""Vertices of the polygon nav2 makes from ``robot_radius``."""


def _segment_distance(ax: float, ay: float, bx: float, by: float) -> float:
    """Distance from the origin to the segment A–B."""
    dx, dy = bx - ax, by - ay
    length2 = dx * dx + dy * dy
    t = 0.0 if length2 == 0.0 else min(1.0, max(0.0, -(ax * dx + ay * dy) / length2))
    return math.hypot(ax + t * dx, ay + t * dy)


MAX_RASTER_CELLS: int = _costmap.MAX_RASTER_CELLS
"""Most cells (2^30) the bounding box of one rasterised footprint may span (a 50 m footprint at 2 mm cells)."""
_FAR_CELLS = 2.0**40

MAX_FOOTPRINT_EXTENT = 50.0
"""m: footprint vertices lie within ±50 m of the robot's centre (the largest mobile machines are ~20 m)."""
MAX_FOOTPRINT_POINTS = 1000


@dataclass(frozen=True, eq=False)
class Footprint:
    """A simple polygon in the robot frame: ``points`` (N, 2) in metres, N ≥ 3, counter-clockwise or not.

    Build with :meth:`from_points`, :meth:`from_radius`, :meth:`from_string` or :meth:`from_parameters`;
    the constructor validates (finite, at least 3 vertices, non-zero area, no self-intersection).
    """

    points: NDArray[np.float64]

    def __post_init__(self) -> None:
        try:
            pts = np.array(self.points, dtype=np.float64)
        except (TypeError, ValueError, OverflowError) as exc:  # OverflowError: an integer beyond a double
            raise InvalidInput("footprint", self.points, "expected a list of [x, y] points") from exc
        if pts.ndim != 2 or pts.shape[1] != 2:
            raise InvalidInput("footprint", self.points, "expected a list of [x, y] points")
        if pts.shape[0] < 3:
            raise InvalidInput("footprint", pts.tolist(), "needs at least three points (or use robot_radius)")
        if not np.all(np.isfinite(pts)):
            raise InvalidInput("footprint", pts.tolist(), "must be finite (no NaN or inf)")
        if pts.shape[0] > MAX_FOOTPRINT_POINTS or float(np.max(np.abs(pts))) > MAX_FOOTPRINT_EXTENT:
            raise InvalidInput("footprint", f"{pts.shape[0]} points", f"at most {MAX_FOOTPRINT_POINTS} points "
                               f"within ±{MAX_FOOTPRINT_EXTENT:g} m of the robot's centre")
        ring = LinearRing(pts)
        if not ring.is_simple:
            raise InvalidInput("footprint", pts.tolist(), "polygon is self-intersecting")
        if Polygon(ring).area <= 0.0:
            raise InvalidInput("footprint", pts.tolist(), "polygon has zero area")
        pts.setflags(write=False)
        object.__setattr__(self, "points", pts)

    @classmethod
    def from_points(cls, points: ArrayLike) -> Footprint:
        try:
            return cls(np.asarray(points, dtype=np.float64))
        except (TypeError, ValueError, OverflowError) as exc:  # ragged or nested lists, integers beyond a double
            if isinstance(exc, InvalidInput):
                raise
            raise InvalidInput("footprint", points, "expected a list of [x, y] points") from None

    @classmethod
    def from_radius(cls, radius: float) -> Footprint:
        """nav2's circular footprint: 16 vertices at angles 2πi/16 on a circle of ``radius`` (m)."""
        if not (isinstance(radius, int | float) and math.isfinite(radius) and radius > 0.0):
            raise InvalidInput("robot_radius", radius, "must be > 0 when no footprint polygon is given")
        angles = np.arange(RADIUS_FOOTPRINT_POINTS) * (2.0 * math.pi / RADIUS_FOOTPRINT_POINTS)
        return cls(np.column_stack((np.cos(angles) * radius, np.sin(angles) * radius)))

    @classmethod
    def from_string(cls, text: str) -> Footprint:
        """Parse nav2's footprint string ``"[[x, y], [x, y], ...]"``."""
        try:
            value: Any = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            raise InvalidInput("footprint", text, "expected a string like [[0.4, 0.25], [-0.4, 0.25], ...]") from exc
        if not isinstance(value, list) or not all(
            isinstance(p, list) and len(p) == 2 and all(isinstance(c, int | float) for c in p) for p in value
        ):
            raise InvalidInput("footprint", text, "expected a string like [[0.4, 0.25], [-0.4, 0.25], ...]")
        return cls.from_points(value)

    @classmethod
    def from_parameters(cls, footprint: str, robot_radius: float) -> Footprint:
        """nav2's rule: the ``footprint`` polygon when given (not ``""``/``"[]"``), else ``robot_radius``."""
        if footprint.strip() not in ("", "[]"):
            return cls.from_string(footprint)
        return cls.from_radius(robot_radius)

    def padded(self, padding: float) -> Footprint:
        """Each vertex moved by ``padding`` (m, ≥ 0) along the signs of its coordinates (nav2 ``padFootprint``)."""
        if not (math.isfinite(padding) and padding >= 0.0):
            raise InvalidInput("footprint_padding", padding, "must be finite and >= 0")
        if padding == 0.0:
            return self
        return Footprint(self.points + np.sign(self.points) * padding)

    @property
    def inscribed_radius(self) -> float:
        """Smallest distance (m) from the robot centre to an edge (nav2's inscribed radius)."""
        pts, nxt = self.points, np.roll(self.points, -1, axis=0)
        return min(_segment_distance(a[0], a[1], b[0], b[1]) for a, b in zip(pts, nxt, strict=True))

    @property
    def circumscribed_radius(self) -> float:
        """Largest distance (m) from the robot centre to a vertex."""
        return float(np.max(np.hypot(self.points[:, 0], self.points[:, 1])))

    @property
    def contains_center(self) -> bool:
        """True when the robot centre lies strictly inside the polygon (its inscribed disc is then inside)."""
        return bool(Polygon(self.points).contains(Point(0.0, 0.0)))

    def to_string(self) -> str:
        """nav2 footprint string of the vertices."""
        return "[" + ", ".join(f"[{x!r}, {y!r}]" for x, y in self.points.tolist()) + "]"

    def posed(self, x: float, y: float, yaw: float) -> NDArray[np.float64]:
        """Vertices (N, 2) in the map frame for the robot at ``(x, y)`` with heading ``yaw`` (rad)."""
        c, s = math.cos(yaw), math.sin(yaw)
        px, py = self.points[:, 0], self.points[:, 1]
        return np.column_stack((x + c * px - s * py, y + s * px + c * py))

    def cells(self, x: float, y: float, yaw: float, origin: tuple[float, float], resolution: float
              ) -> NDArray[np.int64]:
        """Cells ``(mx, my)`` (K, 2) covered by the footprint posed at ``(x, y, yaw)`` on a grid.

        ``origin`` is the map frame position (m) of cell (0, 0)'s lower-left corner; cell ``(mx, my)`` is
        ``[ox + mx·r, ox + (mx+1)·r) × [oy + my·r, oy + (my+1)·r)``. Cells may lie outside the grid.
        Raises :class:`~pfield.errors.InvalidInput` for a pose that is not finite or over 2^40 cells from the
        grid's origin, or a footprint spanning more than :data:`MAX_RASTER_CELLS` cells.
        """
        if not all(math.isfinite(value) for value in (x, y, yaw)):
            raise InvalidInput("position", [x, y, yaw], "must be finite")
        world = self.posed(x, y, yaw)
        us = np.ascontiguousarray((world[:, 0] - origin[0]) / resolution)
        vs = np.ascontiguousarray((world[:, 1] - origin[1]) / resolution)
        if not (np.all(np.abs(us) <= _FAR_CELLS) and np.all(np.abs(vs) <= _FAR_CELLS)):
            raise InvalidInput("position", [x, y], "too far from the grid's origin (over 2^40 cells)")
        span = (math.floor(us.max()) - math.floor(us.min()) + 1) * (math.floor(vs.max()) - math.floor(vs.min()) + 1)
        if span > MAX_RASTER_CELLS:
            raise InvalidInput("resolution", resolution, f"the footprint spans ~{span:.3g} cells, above the cap "
                               f"of {MAX_RASTER_CELLS}")
        cells: NDArray[np.int64] = _costmap.rasterize_polygon(us, vs)
        return cells
