"""Arrays bound once, called many times: one int64 table of addresses and shapes for a compiled entry point.

Calling a numba function from Python costs about 0.1 µs per array argument (typing and unboxing), which is
more than a whole field evaluation with a few obstacles. A prepared call (:class:`pfield.field.PreparedTwist`,
:class:`pfield.planning.WholeBodyStepper`, :class:`pfield.robot.ik.IKSolver`) therefore binds the arrays it
reads and writes once, in a :class:`BoundArrays` table (slot k: address, shape[0], shape[1], shape[2]), and
passes that one array; compiled code re-views slot k with :func:`float_view1` … :func:`int_view2`
(``numba.carray`` over the same memory, no reference counting). The :class:`BoundArrays` object keeps every
bound array alive; bound arrays must be C-contiguous float64 or int64 and are never reallocated.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numba import carray, njit
from numpy.typing import NDArray

from pfield.geometry._raw import float_pointer, int_pointer

__all__ = ["BoundArrays", "float_view1", "float_view2", "float_view3", "int_view1", "int_view2"]

SLOT = 4  # address, shape[0], shape[1], shape[2]


class BoundArrays:
    """The table of ``arrays`` (C-contiguous float64/int64, rank ≤ 3) for :func:`float_view1` etc."""

    def __init__(self, arrays: Sequence[NDArray[np.float64] | NDArray[np.int64]]) -> None:
        self.arrays = tuple(arrays)
        self.table = np.zeros(SLOT * len(self.arrays), dtype=np.int64)
        for k, array in enumerate(self.arrays):
            if array.dtype not in (np.float64, np.int64) or not array.flags.c_contiguous or array.ndim > 3:
                raise ValueError(f"bound array {k} must be C-contiguous float64/int64 of rank <= 3, "
                                 f"got {array.dtype} {array.shape}")
            shape = (*array.shape, 1, 1, 1)[:3]
            # an empty array may have a null address; give it its own 1-element buffer (never read)
            self.table[SLOT * k] = array.ctypes.data if array.size else _EMPTY.ctypes.data
            self.table[SLOT * k + 1:SLOT * k + 4] = shape


_EMPTY = np.zeros(8)


@njit(cache=True, inline="always")
def float_view1(table: np.ndarray, k: int) -> np.ndarray:
    """Slot ``k`` of a :class:`BoundArrays` table as a float64 array of rank 1."""
    return carray(float_pointer(table[SLOT * k]), (table[SLOT * k + 1],))


@njit(cache=True, inline="always")
def float_view2(table: np.ndarray, k: int) -> np.ndarray:
    """Slot ``k`` as a float64 array of rank 2."""
    return carray(float_pointer(table[SLOT * k]), (table[SLOT * k + 1], table[SLOT * k + 2]))


@njit(cache=True, inline="always")
def float_view3(table: np.ndarray, k: int) -> np.ndarray:
    """Slot ``k`` as a float64 array of rank 3."""
    return carray(float_pointer(table[SLOT * k]), (table[SLOT * k + 1], table[SLOT * k + 2], table[SLOT * k + 3]))


@njit(cache=True, inline="always")
def int_view1(table: np.ndarray, k: int) -> np.ndarray:
    """Slot ``k`` as an int64 array of rank 1."""
    return carray(int_pointer(table[SLOT * k]), (table[SLOT * k + 1],))


@njit(cache=True, inline="always")
def int_view2(table: np.ndarray, k: int) -> np.ndarray:
    """Slot ``k`` as an int64 array of rank 2."""
    return carray(int_pointer(table[SLOT * k]), (table[SLOT * k + 1], table[SLOT * k + 2]))
