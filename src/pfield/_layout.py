"""Named layouts of packed float/int arrays: one (name, shape) spec per structure, everything else derived.

The compiled core takes packed arrays (a parameter vector it reads as a struct, a result row it writes). A
:class:`Layout` describes such an array once, as ordered ``(name, shape)`` entries whose shape items are ints or
dimension names (``("n", 3, 3)``), and derives from that one spec:

* the offsets — :meth:`Layout.index` (a scalar slot) and :meth:`Layout.span` (a constant-size entry), which
  tests hold equal to the offsets of the core's structs;
* the packing — :meth:`Layout.pack` (name → values into one flat array) and :meth:`Layout.size`;
* the views — :meth:`Layout.unpack` (name → reshaped view) and :meth:`Layout.read` (a row's values in order), so
  the offsets are never kept in step by hand.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["Layout"]

Shape = tuple[int | str, ...]


class Layout:
    """An ordered spec of named entries ``(name, shape)`` packed back to back into one 1-D array."""

    def __init__(self, name: str, entries: Sequence[tuple[str, Shape]], dtype: type = np.float64) -> None:
        names = [entry[0] for entry in entries]
        if len(set(names)) != len(names):
            raise ValueError(f"layout {name}: duplicate entry names")
        self.name, self.entries, self.dtype = name, tuple((n, tuple(s)) for n, s in entries), dtype
        self._position = {n: k for k, n in enumerate(names)}
        self._all_scalars = all(shape == () for _, shape in self.entries)
        self._slices: tuple[tuple[int, int, Shape], ...] | None = None
        self._fixed_size = 0

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(entry[0] for entry in self.entries)

    @property
    def dims(self) -> tuple[str, ...]:
        """The dimension names used by the shapes, in order of first use."""
        seen: list[str] = []
        for _, shape in self.entries:
            seen += [d for d in shape if isinstance(d, str) and d not in seen]
        return tuple(seen)

    def _extent(self, shape: Shape, dims: Mapping[str, int]) -> int:
        return math.prod(int(dims[d]) if isinstance(d, str) else d for d in shape)

    def offsets(self, **dims: int) -> dict[str, tuple[int, int]]:
        """name → (start, stop) in the flat array for these dimensions."""
        out: dict[str, tuple[int, int]] = {}
        start = 0
        for name, shape in self.entries:
            stop = start + self._extent(shape, dims)
            out[name], start = (start, stop), stop
        return out

    def size(self, **dims: int) -> int:
        """Length of the flat array for these dimensions."""
        return sum(self._extent(shape, dims) for _, shape in self.entries)

    def span(self, name: str) -> tuple[int, int]:
        """(start, stop) of an entry whose offset and size do not depend on any dimension."""
        start = 0
        for entry, shape in self.entries:
            if any(isinstance(d, str) for d in shape):
                raise ValueError(f"layout {self.name}: {entry!r} has a symbolic shape; use offsets(**dims)")
            if entry == name:
                return start, start + self._extent(shape, {})
            start += self._extent(shape, {})
        raise KeyError(f"layout {self.name} has no entry {name!r}")

    def index(self, name: str) -> int:
        """The slot of a scalar entry (shape ``()``)."""
        if self.entries[self._position[name]][1] != ():
            raise ValueError(f"layout {self.name}: {name!r} is not a scalar")
        return self.span(name)[0]

    def pack(self, values: Mapping[str, ArrayLike], **dims: int) -> NDArray[Any]:
        """The flat array of ``values`` (every entry by name, each of its spec's shape)."""
        missing = [name for name in self.names if name not in values]
        if missing:
            raise KeyError(f"layout {self.name}: missing {sorted(missing)}")
        if self._all_scalars:  # parameter vectors: packed once per plan, keep it cheap
            return np.array([values[name] for name in self.names], dtype=self.dtype)
        out: NDArray[Any] = np.empty(self.size(**dims), dtype=self.dtype)
        for name, (start, stop) in self.offsets(**dims).items():
            out[start:stop] = np.ravel(np.asarray(values[name], dtype=self.dtype))
        return out

    def read(self, flat: NDArray[Any]) -> list[Any]:
        """The values of a layout without dimensions, in entry order: scalars as Python floats, the rest as
        views of ``flat`` (the typed result views use this; the slices are computed once)."""
        if self._slices is None:
            self._slices = tuple((start, stop, shape) for (_, shape), (start, stop) in
                                 zip(self.entries, self.offsets().values(), strict=True))
            self._fixed_size = self.size()
        scalars = flat[:self._fixed_size].tolist()
        return [scalars[start] if not shape else flat[start:stop] if len(shape) == 1
                else flat[start:stop].reshape(shape) for start, stop, shape in self._slices]

    def unpack(self, flat: NDArray[Any], **dims: int) -> dict[str, NDArray[Any]]:
        """name → view of ``flat`` reshaped to the entry's shape (writes go through to ``flat``)."""
        views = {}
        for (name, shape), (start, stop) in zip(self.entries, self.offsets(**dims).values(), strict=True):
            concrete = tuple(int(dims[d]) if isinstance(d, str) else d for d in shape)
            views[name] = flat[start:stop].reshape(concrete) if concrete else flat[start:stop]
        return views

