"""Named layouts of packed float/int arrays: one (name, shape) spec per structure, everything else derived.

Compiled kernels take packed arrays (a parameter vector, a result row, a workspace carved out of one
buffer). A :class:`Layout` describes such an array once, as ordered ``(name, shape)`` entries whose shape
items are ints or dimension names (``("n", 3, 3)``), and derives from that one spec:

* the offsets — :meth:`Layout.index` (a scalar slot) and :meth:`Layout.span` (a constant-size entry), used
  as module-level constants that numba freezes at compile time;
* the packing — :meth:`Layout.pack` (name → values into one flat array) and :meth:`Layout.size`;
* the views — :meth:`Layout.unpack` (Python: name → reshaped view) and :func:`compile_views`, which writes
  the compiled function that re-views flat buffers as a named tuple of arrays inside numba code, so the
  offsets are never kept in step by hand;
* the reference-count-free copy — :func:`compile_unowned`, the same named tuple with every array re-viewed
  without an owner, for the top of a compiled loop.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

__all__ = ["Layout", "compile_allocation", "compile_unowned", "compile_views"]

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


def _compiled(function_name: str, lines: list[str], owner: Any, namespace: dict[str, Any]) -> Any:
    """njit(cache=True) of generated source, attributed to ``owner``'s module (its file stamps the cache)."""
    module = sys.modules[owner.__module__]
    namespace["__name__"] = module.__name__
    exec(compile("\n".join(lines), str(module.__file__), "exec"), namespace)
    return njit(cache=True)(namespace[function_name])


def compile_allocation(function_name: str, target: Any, layout: Layout, dims: Sequence[str]) -> Any:
    """A compiled ``function_name(*dims) -> target``: a fresh array per entry of ``layout`` (one allocation
    each, so every array starts aligned), fields in ``target``'s order."""
    if set(target._fields) != set(layout.names) or not set(layout.dims) <= set(dims):
        raise ValueError(f"{target.__name__}: fields or dimensions do not match layout {layout.name}")
    shapes = dict(layout.entries)
    arrays = [f"_np.empty(({', '.join(str(d) for d in shapes[name])},))" if shapes[name] else "_np.empty(1)"
              for name in target._fields]
    lines = [f"def {function_name}({', '.join(dims)}):", f"    return _target({', '.join(arrays)})"]
    return _compiled(function_name, lines, target, {"_target": target, "_np": np})


def compile_views(function_name: str, target: Any, layouts: Sequence[tuple[str, Layout]],
                  dims: Sequence[str], passthrough: Sequence[str] = ()) -> Any:
    """A compiled ``function_name(*buffers, *dims, *passthrough) -> target`` that views flat buffers.

    ``layouts`` pairs each buffer argument name with its :class:`Layout`; ``target`` is a ``NamedTuple``
    class whose fields are all entries of the layouts plus the ``passthrough`` arguments (given as they
    are). The source is written from the specs (so views, sizes and packing cannot drift) and compiled
    with numba's on-disk cache, attributed to the module of ``target`` (which owns the specs: its changes
    invalidate the cache). Scalar entries (shape ``()``) become length-1 views.
    """
    lines = [f"def {function_name}({', '.join([name for name, _ in layouts] + list(dims) + list(passthrough))}):"]
    known = set(passthrough)
    for buffer, layout in layouts:
        lines.append("    o = 0")
        for name, shape in layout.entries:
            extent = " * ".join(str(d) for d in shape) or "1"
            reshape = f".reshape(({', '.join(str(d) for d in shape)},))" if len(shape) > 1 else ""
            lines.append(f"    {name} = {buffer}[o:o + {extent}]{reshape}")
            lines.append(f"    o += {extent}")
            known.add(name)
    used = {d for _, layout in layouts for d in layout.dims}
    if not used <= set(dims):
        raise ValueError(f"{target.__name__}: dimensions {sorted(used - set(dims))} are not arguments")
    fields = target._fields
    if set(fields) != known:
        raise ValueError(f"{target.__name__}: fields {sorted(set(fields) ^ known)} are not covered exactly")
    lines.append(f"    return _target({', '.join(fields)})")
    return _compiled(function_name, lines, target, {"_target": target})


def compile_unowned(function_name: str, target: Any, views: Mapping[str, Sequence[Layout]],
                    functions: Mapping[str, Any], fields: Mapping[str, str] | None = None,
                    passthrough: Sequence[str] = ()) -> Any:
    """A compiled ``function_name(x) -> target``: the named tuple ``x`` with the entries of each layout in
    ``views[f]`` re-viewed by the function ``functions[f]``, the other ``fields`` (name → function name) by
    theirs, and the ``passthrough`` fields as they are.

    For the top of a compiled loop: numba reference-counts an array with two atomic operations each time
    an inlined kernel binds it, and a loop over a step that binds dozens of arrays pays that at every step
    (see :mod:`pfield.field._unowned`). The views have no owner: ``x`` must outlive them (a loop's own
    arguments do; a workspace allocated in the loop must stay referenced until its end), and its arrays must
    be C-contiguous."""
    calls = {name: view for view, layouts in views.items() for layout in layouts for name in layout.names}
    calls.update(fields or {})
    covered = set(calls) | set(passthrough)
    if set(target._fields) != covered:
        raise ValueError(f"{target.__name__}: fields {sorted(set(target._fields) ^ covered)} are not covered exactly")
    values = [f"x.{name}" if name in passthrough else f"{calls[name]}(x.{name})" for name in target._fields]
    lines = [f"def {function_name}(x):", f"    return _target({', '.join(values)})"]
    return _compiled(function_name, lines, target, {"_target": target, **functions})
