"""The field over many poses on every core: :func:`batch_twists` / :func:`batch_wrenches` (numba ``prange``).

From :data:`PARALLEL_FROM` poses on, the poses are cut into chunks of :data:`CHUNK` that numba's threads
take (``parallel=True``); smaller batches run in a plain loop on the calling thread (waking the thread pool
costs more than it saves). Either way each pose runs the same inlined kernels as a one-pose call
(:mod:`pfield.field._evaluate`): the threaded and the plain loop give the same bits, so a value does not
depend on the thread count or the batch size (and equals ``twist_at`` / ``wrench_at`` to rounding: LLVM
may contract a multiply-add differently in another function). The entry points take the eight arrays of
PackedObstacles one by one (see :mod:`pfield.field._unowned`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit, prange

from pfield.field._evaluate import constrained_twist, field_wrench
from pfield.field._unowned import unowned, unowned_arrays

__all__ = ["CHUNK", "PARALLEL_FROM", "batch_twists", "batch_wrenches"]

CHUNK = 2048
"""Poses per task: large enough that scheduling is negligible, small enough to balance two to 64 threads."""
PARALLEL_FROM = 8192


@njit(cache=True, inline="always")
def _wrench_range(out: np.ndarray, start: int, stop: int, positions: np.ndarray, orientations: np.ndarray,
                  goal: np.ndarray, params: np.ndarray, aux: np.ndarray, packed: Any) -> None:
    for k in range(start, stop):
        q = orientations[k]
        out[k, 0], out[k, 1], out[k, 2], out[k, 3], out[k, 4], out[k, 5] = field_wrench(
            positions[k], q[0], q[1], q[2], q[3], goal, params, packed, aux)


@njit(cache=True, inline="always")
def _twist_range(out: np.ndarray, start: int, stop: int, positions: np.ndarray, orientations: np.ndarray,
                 goal: np.ndarray, params: np.ndarray, aux: np.ndarray, previous: np.ndarray,
                 packed: Any) -> None:
    for k in range(start, stop):
        q = orientations[k]
        out[k, 0], out[k, 1], out[k, 2], out[k, 3], out[k, 4], out[k, 5], _, _ = constrained_twist(
            positions[k], q[0], q[1], q[2], q[3], goal, params, packed, aux, previous, False, 0.0)


@njit(cache=True, parallel=True)
def batch_wrenches(
    positions: np.ndarray, orientations: np.ndarray, goal: np.ndarray, params: np.ndarray, aux: np.ndarray,
    kinds: np.ndarray, rows: np.ndarray, triangles: np.ndarray, pseudo_normals: np.ndarray,
    bvh_lower: np.ndarray, bvh_upper: np.ndarray, bvh_nodes: np.ndarray, mesh_table: np.ndarray,
) -> np.ndarray:
    """Raw wrenches (N, 6) at N poses (C-contiguous positions (N, 3), unit quaternions (N, 4))."""
    n = positions.shape[0]
    out = np.empty((n, 6))
    if n < PARALLEL_FROM:
        packed = unowned_arrays(kinds, rows, triangles, pseudo_normals, bvh_lower, bvh_upper, bvh_nodes, mesh_table)
        _wrench_range(out, 0, n, unowned(positions), unowned(orientations), unowned(goal), unowned(params),
                      unowned(aux), packed)
        return out
    for chunk in prange((n + CHUNK - 1) // CHUNK):
        packed = unowned_arrays(kinds, rows, triangles, pseudo_normals, bvh_lower, bvh_upper, bvh_nodes, mesh_table)
        _wrench_range(out, chunk * CHUNK, min(n, (chunk + 1) * CHUNK), unowned(positions), unowned(orientations),
                      unowned(goal), unowned(params), unowned(aux), packed)
    return out


@njit(cache=True, parallel=True)
def batch_twists(
    positions: np.ndarray, orientations: np.ndarray, goal: np.ndarray, params: np.ndarray, aux: np.ndarray,
    previous: np.ndarray,
    kinds: np.ndarray, rows: np.ndarray, triangles: np.ndarray, pseudo_normals: np.ndarray,
    bvh_lower: np.ndarray, bvh_upper: np.ndarray, bvh_nodes: np.ndarray, mesh_table: np.ndarray,
) -> np.ndarray:
    """Constrained twists (N, 6) at N poses without rate limit (``previous`` (6,) zeros, read only: shared)."""
    n = positions.shape[0]
    out = np.empty((n, 6))
    if n < PARALLEL_FROM:
        packed = unowned_arrays(kinds, rows, triangles, pseudo_normals, bvh_lower, bvh_upper, bvh_nodes, mesh_table)
        _twist_range(out, 0, n, unowned(positions), unowned(orientations), unowned(goal), unowned(params),
                     unowned(aux), unowned(previous), packed)
        return out
    for chunk in prange((n + CHUNK - 1) // CHUNK):
        packed = unowned_arrays(kinds, rows, triangles, pseudo_normals, bvh_lower, bvh_upper, bvh_nodes, mesh_table)
        _twist_range(out, chunk * CHUNK, min(n, (chunk + 1) * CHUNK), unowned(positions), unowned(orientations),
                     unowned(goal), unowned(params), unowned(aux), unowned(previous), packed)
    return out
