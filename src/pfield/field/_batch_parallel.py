"""The field over many poses on every core: :func:`batch_twists` / :func:`batch_wrenches` (numba ``prange``).

The poses are cut into chunks of :data:`CHUNK`; numba's threads take chunks (``parallel=True``), and each
chunk runs the same inlined per-pose kernels as one-pose calls (:mod:`pfield.field._evaluate`), so every
pose's value is bit-identical to the serial evaluation whatever the thread count. Below :data:`SERIAL_BELOW`
poses the serial kernels are used (waking the thread pool costs more than it saves).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from pfield.field._evaluate import batch_twists as serial_twists
from pfield.field._evaluate import batch_wrenches as serial_wrenches
from pfield.field._evaluate import constrained_twist, field_wrench
from pfield.field._unowned import unowned, unowned_arrays

__all__ = ["CHUNK", "SERIAL_BELOW", "batch_twists", "batch_wrenches"]

CHUNK = 2048
"""Poses per task: large enough that scheduling is negligible, small enough to balance two to 64 threads."""
SERIAL_BELOW = 8192


@njit(cache=True, parallel=True)
def _parallel_wrenches(
    positions: np.ndarray, orientations: np.ndarray, goal: np.ndarray, params: np.ndarray, aux: np.ndarray,
    kinds: np.ndarray, rows: np.ndarray, triangles: np.ndarray, pseudo_normals: np.ndarray,
    bvh_lower: np.ndarray, bvh_upper: np.ndarray, bvh_nodes: np.ndarray, mesh_table: np.ndarray,
) -> np.ndarray:
    n = positions.shape[0]
    out = np.empty((n, 6))
    for chunk in prange((n + CHUNK - 1) // CHUNK):
        packed = unowned_arrays(kinds, rows, triangles, pseudo_normals, bvh_lower, bvh_upper, bvh_nodes, mesh_table)
        g, p, a, pos, quat = unowned(goal), unowned(params), unowned(aux), unowned(positions), unowned(orientations)
        for k in range(chunk * CHUNK, min(n, (chunk + 1) * CHUNK)):
            out[k, 0], out[k, 1], out[k, 2], out[k, 3], out[k, 4], out[k, 5] = field_wrench(
                pos[k], quat[k, 0], quat[k, 1], quat[k, 2], quat[k, 3], g, p, packed, a)
    return out


@njit(cache=True, parallel=True)
def _parallel_twists(
    positions: np.ndarray, orientations: np.ndarray, goal: np.ndarray, params: np.ndarray, aux: np.ndarray,
    previous: np.ndarray,
    kinds: np.ndarray, rows: np.ndarray, triangles: np.ndarray, pseudo_normals: np.ndarray,
    bvh_lower: np.ndarray, bvh_upper: np.ndarray, bvh_nodes: np.ndarray, mesh_table: np.ndarray,
) -> np.ndarray:
    n = positions.shape[0]
    out = np.empty((n, 6))
    for chunk in prange((n + CHUNK - 1) // CHUNK):
        packed = unowned_arrays(kinds, rows, triangles, pseudo_normals, bvh_lower, bvh_upper, bvh_nodes, mesh_table)
        g, p, a, pos, quat = unowned(goal), unowned(params), unowned(aux), unowned(positions), unowned(orientations)
        scratch = unowned(previous)  # read only (no rate limit): shared by the threads
        for k in range(chunk * CHUNK, min(n, (chunk + 1) * CHUNK)):
            out[k, 0], out[k, 1], out[k, 2], out[k, 3], out[k, 4], out[k, 5], _, _ = constrained_twist(
                pos[k], quat[k, 0], quat[k, 1], quat[k, 2], quat[k, 3], g, p, packed, a, scratch, False, 0.0)
    return out


def batch_wrenches(positions: np.ndarray, orientations: np.ndarray, goal: np.ndarray, params: np.ndarray,
                   aux: np.ndarray, *packed: np.ndarray) -> np.ndarray:
    """Raw wrenches (N, 6) at N poses (C-contiguous positions (N, 3), unit quaternions (N, 4))."""
    kernel = serial_wrenches if positions.shape[0] < SERIAL_BELOW else _parallel_wrenches
    return kernel(positions, orientations, goal, params, aux, *packed)  # type: ignore[no-any-return]


def batch_twists(positions: np.ndarray, orientations: np.ndarray, goal: np.ndarray, params: np.ndarray,
                 aux: np.ndarray, previous: np.ndarray, *packed: np.ndarray) -> np.ndarray:
    """Constrained twists (N, 6) at N poses without rate limit (``previous`` (6,) zeros, read only)."""
    kernel = serial_twists if positions.shape[0] < SERIAL_BELOW else _parallel_twists
    return kernel(positions, orientations, goal, params, aux, previous, *packed)  # type: ignore[no-any-return]
