"""Covering points by capsules, for :func:`pfield.robot._fit.fit_primitives`: Chvátal's greedy set cover, the
dense coverage matrix, the depth in a union of capsules, the inside test of a convex hull and the Bădoiu–Clarkson
circle, all computed by the compiled core (``src/core/robot/cover.hpp`` states each method and its source), and
the side of the grid the cover buckets the points in.

A capsule (segment a–b, radius r) contains a point p when ``|q − t·d|² ≤ r²`` with ``q = p − a``, ``d = b − a``
and ``t = clamp(q·d / |d|², 0, 1)`` (t = 0 for a sphere); the cover and :func:`coverage` decide every point by
that one expression. The functions here hand the core C-contiguous float64 arrays, which it reads in place
without holding the GIL.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pfield._core import cover as _core

__all__ = ["cell_side", "coverage", "enclosing_circle", "greedy_cover", "inside_hull", "min_depth"]

_GRID_CELLS = 64  # at most this many cells along the longest axis of the points' bounding box


def _f64(values: ArrayLike) -> NDArray[np.float64]:
    return np.ascontiguousarray(values, dtype=np.float64)


def coverage(a: ArrayLike, b: ArrayLike, radii: ArrayLike, points: ArrayLike) -> NDArray[np.bool_]:
    """(K, N) booleans: capsule k (segment ``a[k]``–``b[k]``, radius ``radii[k]``) contains point n."""
    covered: NDArray[np.bool_] = _core.coverage(_f64(a), _f64(b), _f64(radii), _f64(points))
    return covered


def greedy_cover(a: ArrayLike, b: ArrayLike, radii: ArrayLike, points: ArrayLike, cell: float) -> NDArray[np.int64]:
    """Indices of the capsules Chvátal's greedy set cover takes to contain every point, in taking order (the most
    points not yet covered, ties to the lowest index); ``cell``: the grid's cell side (m), :func:`cell_side`.
    Every point must lie in some capsule (else the cover stops when the points left lie in none)."""
    picked: NDArray[np.int64] = _core.greedy_cover(_f64(a), _f64(b), _f64(radii), _f64(points), float(cell))
    return picked


def min_depth(a: ArrayLike, b: ArrayLike, radii: ArrayLike, points: ArrayLike, skip: int) -> NDArray[np.float64]:
    """(N,): min over capsules k ≠ ``skip`` of dist(point, segment a_k–b_k) − r_k (≤ 0: inside the union; +inf
    when there is no other capsule; ``skip = -1`` skips none)."""
    depth: NDArray[np.float64] = _core.min_depth(_f64(a), _f64(b), _f64(radii), _f64(points), int(skip))
    return depth


def inside_hull(equations: ArrayLike, inner: ArrayLike, points: ArrayLike, tolerance: float) -> NDArray[np.bool_]:
    """(N,) booleans: the point satisfies every facet inequality n·x + c ≤ ``tolerance`` of a convex hull
    (``scipy.spatial.ConvexHull.equations``, outward unit normals).

    ``inner``: the facets of the hull of some of its vertices, a polytope inside it with fewer facets (the
    UR5's force-torque sensor: 8184 facets, 500 inside). A point inside that one (tolerance 0) is inside the
    hull; only the others are tested against every facet."""
    inside: NDArray[np.bool_] = _core.inside_hull(_f64(equations), _f64(inner), _f64(points), float(tolerance))
    return inside


def enclosing_circle(points: ArrayLike, iterations: int) -> NDArray[np.float64]:
    """Approximate centre of the smallest ball (any dimension) enclosing ``points`` (N ≥ 1, D): Bădoiu–Clarkson,
    ``c ← c + (p_far − c)/(k + 1)`` for k = 1 … ``iterations`` from the bounding box's centre (p_far: the first
    farthest point)."""
    centre: NDArray[np.float64] = _core.enclosing_circle(_f64(points), int(iterations))
    return centre


def cell_side(points: NDArray[np.float64], smallest: float) -> float:
    """The grid cell side (m) for :func:`greedy_cover`: half ``smallest`` (the least candidate radius; the
    fastest on the UR5's gripper meshes) unless the points' extent would then need more than 64 cells along
    an axis."""
    extent = float(np.max(points.max(axis=0) - points.min(axis=0))) if len(points) else 0.0
    return max(smallest / 2, extent / _GRID_CELLS, 1e-6)
