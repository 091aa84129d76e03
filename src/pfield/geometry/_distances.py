"""Signed distances of many points to a packed obstacle set, computed by the compiled core.

:func:`signed_distances` is the entry Python code calls (``Obstacle.signed_distance``, the field's clearances,
the planners' goal checks); it runs ``src/core/geometry`` (:mod:`pfield._core`) outside the GIL. The numba
kernels of :mod:`._sdf`, :mod:`._ellipsoid` and :mod:`._bvh` compute the same bits for the compiled consumers
that still inline them (tests/geometry/test_core_sdf.py holds the two to each other).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pfield._core import geometry as _geometry
from pfield._validation import as_points
from pfield.errors import InvalidInput
from pfield.geometry._packed import PackedObstacles

__all__ = ["signed_distances"]


def signed_distances(
    packed: PackedObstacles, points: ArrayLike, cutoff: float = math.inf
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Signed distances ``(N, M)`` (m, negative inside) and unit normals ``(N, M, 3)`` of N world points to all
    M obstacles of ``packed``; ``points`` is (N, 3) or one (3,) point, finite.

    Exact wherever ``d ≤ cutoff``; beyond it an entry may be a lower bound ``d'`` with ``cutoff < d' ≤ d`` (as
    :func:`~pfield.geometry.obstacle_signed_distance_within`). Raises ``InvalidInput`` for points that are not
    finite (N, 3) and ``ValueError`` for a hand-built ``packed`` whose mesh indices leave its arrays.
    """
    array = as_points("points", points, check_finite=False)  # the core checks finiteness in its pass
    try:
        return _geometry.signed_distances(*packed, array, cutoff)  # type: ignore[no-any-return]
    except _geometry.NonFinitePoints:
        raise InvalidInput("points", "array", "must be finite (no NaN or inf)") from None
