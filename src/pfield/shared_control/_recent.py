"""Compiled objects kept per thread for the calls that reuse them: the autonomy vector's steppers and the assistance's
workspaces, each built from two objects (a field or a scene, and a robot) and found again by their identity.

Several are kept, not only the last one used: shared autonomy asks for the autonomy vector toward each candidate goal
(one field per goal) every control period, and with one entry each call would build its stepper again (the Panda,
three goals in turn: 70 µs a call where one goal takes 3 µs). The entries hold the objects they were built from, so
an id is never reused while it is a key.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Callable
from typing import Generic, TypeVar

V = TypeVar("V")
Entry = tuple[object, object, V]

RECENT = 8
"""Values kept per thread and cache (the least recently used goes first): a handful of candidate goals."""


def _always(_: object) -> bool:
    return True


class Recent(Generic[V]):
    """Per thread, the :data:`RECENT` values last used, each under the two objects it was built from."""

    def __init__(self, size: int = RECENT) -> None:
        self._local = threading.local()
        self._size = size

    def last(self) -> Entry[V] | None:
        """(first, second, value) used last on this thread, for a hot path to test inline before :meth:`get`."""
        return getattr(self._local, "last", None)

    def get(self, first: object, second: object, build: Callable[[], V],
            usable: Callable[[V], bool] = _always) -> V:
        """The value built from ``first`` and ``second`` (these very objects) that is ``usable``, else ``build()``'s,
        kept from now on. The one used last is tested first (it is already the most recent)."""
        local = self._local
        last: Entry[V] | None = getattr(local, "last", None)
        if last is not None and last[0] is first and last[1] is second and usable(last[2]):
            return last[2]
        entries: OrderedDict[tuple[int, int], Entry[V]] | None = getattr(local, "entries", None)
        if entries is None:
            entries = local.entries = OrderedDict()
        key = (id(first), id(second))
        entry = entries.get(key)
        if entry is not None and entry[0] is first and entry[1] is second and usable(entry[2]):
            entries.move_to_end(key)
        else:
            entry = entries[key] = (first, second, build())
            entries.move_to_end(key)
            while len(entries) > self._size:
                entries.popitem(last=False)
        local.last = entry
        return entry[2]
