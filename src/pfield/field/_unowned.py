"""Reference-count-free views of the arrays a compiled hot loop reads (numba).

Numba reference-counts arrays whenever an inlined kernel binds one to a parameter: an atomic increment
and decrement per array, about 10 ns per pair. The field's twist kernel binds the goal, the parameters,
the per-obstacle table and the eight arrays of :class:`~pfield.geometry._packed.PackedObstacles` at every
call, which would cost more than the whole evaluation without obstacles. The top-level kernels therefore
call :func:`unowned_packed` and :func:`unowned` once and pass views without an owner (``numba.carray``
over the same memory) down the hot path; the owning arrays are the kernel's own arguments, so they
outlive the views. The arrays must be C-contiguous.
"""

from __future__ import annotations

import numpy as np
from numba import carray, njit

from pfield.geometry._packed import PackedObstacles
from pfield.geometry._raw import float_pointer, int_pointer


@njit(cache=True, inline="always")
def unowned(array: np.ndarray) -> np.ndarray:
    """A view of a C-contiguous float64 array (any rank) without reference counting."""
    return carray(float_pointer(array.ctypes.data), array.shape)


@njit(cache=True, inline="always")
def unowned_int(array: np.ndarray) -> np.ndarray:
    """:func:`unowned` of a C-contiguous int64 array."""
    return carray(int_pointer(array.ctypes.data), array.shape)


@njit(cache=True, inline="always")
def unowned_packed(packed: PackedObstacles) -> PackedObstacles:
    """:class:`PackedObstacles` whose arrays are views without reference counting."""
    return PackedObstacles(
        unowned_int(packed.kinds),
        unowned(packed.rows),
        unowned(packed.triangles),
        unowned(packed.pseudo_normals),
        unowned(packed.bvh_lower),
        unowned(packed.bvh_upper),
        unowned_int(packed.bvh_nodes),
        unowned_int(packed.mesh_table),
    )


@njit(cache=True, inline="always")
def unowned_arrays(
    kinds: np.ndarray, rows: np.ndarray, triangles: np.ndarray, pseudo_normals: np.ndarray,
    bvh_lower: np.ndarray, bvh_upper: np.ndarray, bvh_nodes: np.ndarray, mesh_table: np.ndarray,
) -> PackedObstacles:
    """:func:`unowned_packed` of a :class:`PackedObstacles` given as its eight arrays.

    Python-facing kernels take the arrays one by one: numba's dispatcher types a named tuple of arrays
    in Python (about 4 µs per call) but single arrays in C (about 0.1 µs each).
    """
    return PackedObstacles(
        unowned_int(kinds), unowned(rows), unowned(triangles), unowned(pseudo_normals), unowned(bvh_lower),
        unowned(bvh_upper), unowned_int(bvh_nodes), unowned_int(mesh_table),
    )
