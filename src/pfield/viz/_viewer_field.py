"""The field arrows of the 3D viewer: the field's limited linear twist on a horizontal grid."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pfield._validation import finite
from pfield.errors import InvalidInput

__all__ = ["field_slice", "scene_bounds"]


def field_slice(field: Any, bounds: tuple[float, float, float, float], height: float, density: int
                ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Arrow starts (N, 3) on a ``density`` × ``density`` grid over ``bounds`` = (x0, x1, y0, y1) at
    ``z = height`` (m) and the field's limited linear twist there, scaled so the longest arrow is 0.8 of
    a grid cell (N = density²). One batched call of :meth:`PotentialField.twists`."""
    if isinstance(density, bool) or not isinstance(density, int | np.integer) or density < 2:
        raise InvalidInput("density", density, "must be an integer >= 2 (arrows per side)")
    height = finite("height", height)
    x0, x1, y0, y1 = (finite(f"bounds[{i}]", v) for i, v in enumerate(bounds))
    if not (x1 > x0 and y1 > y0):
        raise InvalidInput("bounds", bounds, "expected (x0, x1, y0, y1) with x1 > x0 and y1 > y0")
    xs, ys = np.linspace(x0, x1, density), np.linspace(y0, y1, density)
    gx, gy = np.meshgrid(xs, ys, indexing="xy")
    starts = np.stack([gx.ravel(), gy.ravel(), np.full(gx.size, float(height))], axis=1)
    linear = np.asarray(field.twists(starts))[:, :3]
    longest = float(np.max(np.linalg.norm(linear, axis=1)))
    cell = min((x1 - x0), (y1 - y0)) / max(density - 1, 1)
    return starts, linear * (0.8 * cell / longest if longest > 0 else 0.0)


def scene_bounds(points: Sequence[NDArray[np.float64]], margin: float = 0.15, least: float = 0.6
            ) -> tuple[float, float, float, float]:
    """x/y extents of ``points`` plus ``margin`` (m), at least ``least`` wide on each axis."""
    cloud = np.vstack([np.atleast_2d(p)[:, :3] for p in points] or [np.zeros((1, 3))])
    lo, hi = cloud.min(axis=0)[:2] - margin, cloud.max(axis=0)[:2] + margin
    grow = np.maximum(least - (hi - lo), 0.0) / 2
    lo, hi = lo - grow, hi + grow
    return float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])
