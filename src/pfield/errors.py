"""The pfield exception hierarchy.

Every error pfield raises on purpose derives from :class:`PfieldError`, so callers (the node, the CLI)
can catch one base class, report ``str(error)`` to the user and keep running. Messages name the field
and the offending value, and where possible say what to do next.

A message quotes at most :data:`VALUE_CHARS` characters of the value (:func:`short_repr`): the value may come
from an untrusted file, where a few hundred bytes of YAML aliases expand to a structure whose full ``repr``
takes minutes and gigabytes.
"""

from __future__ import annotations

import builtins
import reprlib
from itertools import islice
from pathlib import PurePath
from typing import Any

__all__ = [
    "VALUE_CHARS",
    "InvalidInput",
    "PfieldError",
    "PlanningFailed",
    "ResourceNotAllowed",
    "ResourceNotFound",
    "UnknownFrame",
    "Unreachable",
    "short_repr",
]

VALUE_CHARS = 80
"""Longest quotation of a value in an error message; a longer ``repr`` is cut and ends with "…"."""
_PATH_CHARS = 4096  # PATH_MAX: a longer string is no path; it is cut at its end as any string
_FIELD_CHARS = 200  # a field is a dotted path, but a key read from a file can be any string
_REASON_CHARS = 1000  # reasons are written by pfield; the cut only guards values formatted into them


class _Prefix(reprlib.Repr):
    """``reprlib``'s bounded walk (a few items of each container, a few levels deep), with strings, numbers and
    other objects cut at the end instead of the middle and mappings in their own order (``reprlib`` sorts the
    keys, which costs a sort of the whole mapping)."""

    def __init__(self) -> None:
        super().__init__()
        self.maxlevel = 3
        self.maxdict = 6
        self.maxlist = self.maxtuple = self.maxset = self.maxfrozenset = self.maxdeque = self.maxarray = 10
        self.fillvalue = "…"

    def repr_str(self, x: str, level: int) -> str:
        return builtins.repr(x[:VALUE_CHARS])

    def repr_int(self, x: int, level: int) -> str:
        try:
            return builtins.repr(x)
        except ValueError:  # beyond sys.get_int_max_str_digits()
            return f"<an integer of {x.bit_length()} bits>"

    def repr_dict(self, x: dict[Any, Any], level: int) -> str:
        if not x:
            return "{}"
        if level <= 0:
            return "{…}"
        pieces = [f"{self.repr1(key, level - 1)}: {self.repr1(value, level - 1)}"
                  for key, value in islice(x.items(), self.maxdict)]
        return "{" + ", ".join(pieces + ["…"] * (len(x) > self.maxdict)) + "}"

    def repr_instance(self, x: object, level: int) -> str:
        try:
            return builtins.repr(x)
        except Exception:  # a broken __repr__ must not hide the error being reported
            return f"<{type(x).__name__}>"


_PREFIX = _Prefix()


def short_repr(value: object, limit: int = VALUE_CHARS) -> str:
    """``repr(value)`` cut to ``limit`` characters (the last one "…" when cut), in time and memory bounded
    whatever the value's size: only the first items of each container and the first characters of each
    string are looked at. A file path (a ``PurePath``, or a string with a "/" in it) too long to quote whole is
    cut in the middle instead, so that its file name stays: the part a reader needs to fix the call."""
    if isinstance(value, PurePath) or (isinstance(value, str) and "/" in value[:_PATH_CHARS]
                                       and len(value) <= _PATH_CHARS):
        return _path_repr(str(value), limit)
    return _cut(_PREFIX.repr(value), limit)


def _path_repr(path: str, limit: int) -> str:
    quoted = builtins.repr(path)
    if len(quoted) <= limit:
        return quoted
    tail = max(limit // 2, limit - 3 - 24)  # the file name and its folder; the head says where it lives
    head = limit - 3 - tail
    cut = builtins.repr(path[:head] + "…" + path[-tail:]) if head > 0 else quoted
    return cut if len(cut) <= limit else _cut(quoted, limit)  # escapes made it longer: cut at the end


def _cut(text: str, limit: int) -> str:
    return text if len(text) <= limit else text[: limit - 1] + "…"


class PfieldError(Exception):
    """Base class of every error raised by pfield."""


class InvalidInput(PfieldError, ValueError):
    """A value supplied by a caller is malformed, out of range or inconsistent.

    ``field`` names the offending field (dotted path for nested fields, e.g. ``obstacles[2].radius``)
    and ``value`` holds the rejected value, so transports can report both. The message quotes a prefix of the
    value (:func:`short_repr`) and stays short whatever the value.
    """

    def __init__(self, field: str, value: object, reason: str) -> None:
        self.field = field
        self.value = value
        self.reason = reason
        super().__init__(f"{_cut(field, _FIELD_CHARS)}={short_repr(value)}: {_cut(reason, _REASON_CHARS)}")


class UnknownFrame(InvalidInput):
    """A message refers to a coordinate frame pfield has no transform for."""


class ResourceNotFound(PfieldError, FileNotFoundError):
    """A file or package resource (mesh, URDF, map) could not be found or read."""


class ResourceNotAllowed(PfieldError, PermissionError):
    """A resource URI resolves outside the configured allowed roots."""


class PlanningFailed(PfieldError):
    """A planner could not produce a result at all (not merely an unsuccessful plan)."""


class Unreachable(PfieldError, ConnectionError):
    """A service the caller named (a Ray cluster's address) does not answer: the same call may succeed once it
    runs (the CLI exits 1, not 2)."""
