"""Signed distances of points to a packed obstacle set, computed by the compiled core (``src/core/geometry``).

:func:`signed_distances` is the batch Python code calls (``Obstacle.signed_distance``, the field's clearances, the
planners' goal checks); it runs the core outside the GIL. :func:`obstacle_signed_distance`,
:func:`obstacle_signed_distance_within` and :func:`min_signed_distance` answer for one point (and one obstacle, or
the nearest) through the same core, with the same bits; :func:`distances` and :func:`nearest_distances` are the
batches without normals (into a caller's buffer when given one).

Conventions
-----------
``d`` is the exact Euclidean signed distance in metres, negative inside. The normal is the unit
gradient ∇d in the world frame: outside it points from the closest surface point to ``p``, inside it
is the outward surface normal at the closest surface point. Where ∇d is undefined (the medial axis:
several closest points) the normal is chosen by this deterministic rule, in the obstacle's local frame:

* among equally near faces the lower axis wins (x before y before z), and the + side wins when the
  coordinate is exactly 0 (``sign(0) = +1``);
* a point with no preferred direction (sphere centre) gets local +z; a point on a cylinder's or capsule's
  axis whose closest points form a circle gets local +x;
* a cylinder point equally near the cap and the side wall gets the cap normal (±z);
* ellipsoid points on a symmetry plane with mirror-image closest points take the + side;
* meshes: the first closest triangle in BVH traversal order (``src/core/geometry/mesh_bvh``); a mesh that is not
  watertight has an unsigned distance.
"""

from __future__ import annotations

import math
import operator

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pfield._core import geometry as _geometry
from pfield._validation import as_points
from pfield.errors import InvalidInput
from pfield.geometry.packed import PackedObstacles

__all__ = ["distances", "min_signed_distance", "nearest_distances", "obstacle_signed_distance",
           "obstacle_signed_distance_within", "signed_distances"]


def signed_distances(
    packed: PackedObstacles, points: ArrayLike, cutoff: float = math.inf
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Signed distances ``(N, M)`` (m, negative inside) and unit normals ``(N, M, 3)`` of N world points to all
    M obstacles of ``packed``; ``points`` is (N, 3) or one (3,) point, finite.

    Exact wherever ``d ≤ cutoff``; beyond it an entry may be a lower bound ``d'`` with ``cutoff < d' ≤ d`` (as
    :func:`obstacle_signed_distance_within`). Raises ``InvalidInput`` for points that are not finite (N, 3) and
    ``ValueError`` for a hand-built ``packed`` whose mesh indices leave its arrays or whose kinds hold a code that is
    no shape.
    """
    return _signed_distances(packed.kinds, packed.rows, packed, points, cutoff)


def _signed_distances(kinds: NDArray[np.int64], rows: NDArray[np.float64], packed: PackedObstacles,
                      points: ArrayLike, cutoff: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`signed_distances` to the obstacles ``kinds`` and ``rows`` with the mesh arrays of ``packed``."""
    array = as_points("points", points, check_finite=False)  # the core checks finiteness in its pass
    try:
        return _geometry.signed_distances(kinds, rows, *packed[2:], array, cutoff)  # type: ignore[no-any-return]
    except _geometry.NonFinitePoints:
        raise InvalidInput("points", "array", "must be finite (no NaN or inf)") from None


def _out(out: NDArray[np.float64] | None, shape: tuple[int, ...]) -> NDArray[np.float64]:
    """``out`` when it is a writable C-contiguous float64 array of ``shape`` (the caller's buffer, reused from call
    to call), a new one for None; else ``InvalidInput`` naming ``out``."""
    if out is None:
        return np.empty(shape)
    if not (isinstance(out, np.ndarray) and out.dtype == np.float64 and out.shape == shape
            and out.flags.c_contiguous and out.flags.writeable):
        described = f"array{out.shape} of {out.dtype}" if isinstance(out, np.ndarray) else out
        raise InvalidInput("out", described, f"expected a writable C-contiguous float64 array of shape {shape}")
    return out


def distances(packed: PackedObstacles, points: ArrayLike, cutoff: float = math.inf,
              out: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """:func:`signed_distances`' distances ``(N, M)`` (m, negative inside) alone, the same bits, without the
    normals: for loops that need no gradient. ``out`` (N, M), when given, receives them and is returned (a
    buffer reused from call to call allocates nothing). Errors as :func:`signed_distances`'s, and
    ``InvalidInput`` for an ``out`` of another shape, dtype or layout, or read-only."""
    array = as_points("points", points, check_finite=False)  # the core checks finiteness in its pass
    target = _out(out, (array.shape[0], packed.kinds.shape[0]))
    try:
        _geometry.distances(*packed, array, float(cutoff), target)
    except _geometry.NonFinitePoints:
        raise InvalidInput("points", "array", "must be finite (no NaN or inf)") from None
    return target


def nearest_distances(packed: PackedObstacles, points: ArrayLike,
                      out: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """Each point's smallest signed distance (m) over all obstacles ``(N,)``: :func:`min_signed_distance`'s ``d``
    to the bit (``inf`` with no obstacles), with no normal and no (N, M) table. ``out`` (N,) as :func:`distances`'s."""
    array = as_points("points", points, check_finite=False)
    target = _out(out, (array.shape[0],))
    try:
        _geometry.nearest_distances(*packed, array, target)
    except _geometry.NonFinitePoints:
        raise InvalidInput("points", "array", "must be finite (no NaN or inf)") from None
    return target


def obstacle_signed_distance(packed: PackedObstacles, i: int, p: ArrayLike) -> tuple[float, float, float, float]:
    """Exact signed distance ``d`` (m, negative inside) of the world point ``p`` (3,) to obstacle ``i`` of
    ``packed``, and the unit outward normal ``n = ∇d`` in the world frame: ``(d, nx, ny, nz)``.

    The point is taken into the obstacle frame, ``q = Rᵀ(p − c)``, the shape's local distance is evaluated there,
    and the normal is rotated back, ``n = R n_local`` (distances are invariant under rigid motion). For many
    points, :func:`signed_distances` answers in one call. Raises ``IndexError`` for an ``i`` beyond the obstacles.
    """
    return obstacle_signed_distance_within(packed, i, p, math.inf)


def obstacle_signed_distance_within(
    packed: PackedObstacles, i: int, p: ArrayLike, cutoff: float
) -> tuple[float, float, float, float]:
    """:func:`obstacle_signed_distance`, exact whenever ``d ≤ cutoff``; beyond, possibly a cheaper bound.

    When the true distance exceeds ``cutoff`` (m) the result may instead be a lower bound ``d'`` with
    ``cutoff < d' ≤ d`` and a unit normal pointing away from the obstacle (ellipsoids: the distance to
    their bounding sphere; meshes: to their bounding box). Consumers that ignore obstacles beyond an
    influence distance (Khatib repulsion) get identical results, faster.
    """
    count = len(packed.kinds)
    index = operator.index(i)
    if not -count <= index < count:
        raise IndexError(f"obstacle index {i} out of range: the set has {count} obstacles")
    index %= count
    # the one obstacle's row; the mesh arrays stay whole (a mesh row names its mesh by its index among them)
    distances, normals = _signed_distances(packed.kinds[index:index + 1], packed.rows[index:index + 1], packed, p,
                                           cutoff)
    nx, ny, nz = normals[0, 0].tolist()
    return float(distances[0, 0]), nx, ny, nz


def min_signed_distance(packed: PackedObstacles, p: ArrayLike) -> tuple[float, float, float, float, int]:
    """Smallest signed distance over all obstacles: ``(d, nx, ny, nz, index)``.

    Ties go to the lowest index; with no obstacles the answer is ``(inf, 0, 0, 0, −1)``.
    """
    distances, normals = signed_distances(packed, p)
    best, best_i = math.inf, -1
    for k, d in enumerate(distances[0].tolist()):
        if d < best:  # the first of equal distances stays; a NaN never wins
            best, best_i = d, k
    if best_i < 0:
        return math.inf, 0.0, 0.0, 0.0, -1
    nx, ny, nz = normals[0, best_i].tolist()
    return best, nx, ny, nz, best_i
