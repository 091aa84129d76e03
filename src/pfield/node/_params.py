"""Declarative parameter tables: one row per ROS parameter of a node (name, type, range, description, default).

A node's :class:`ParameterTable` is the one place its parameters are described and range-checked: the
node's ``set_parameters`` checks every value against its row *before* anything changes (unknown name,
wrong type, out of range, read-only), then the node's config objects add the cross-field rules
(``min_spd_norm`` ≤ ``max_spd_norm`` …). ``describe()`` is what ``GET /param/<node>?describe=true`` answers
and what the rclpy adapter turns into ``ParameterDescriptor``\\ s (``ros2 param describe``).

Types use ROS 2's parameter type names (``double``, ``integer``, ``bool``, ``string``) plus ``map`` for a
nested mapping (``static_transforms``), which only the HTTP transport carries. Ranges are inclusive
``[low, high]`` in the parameter's unit; a string parameter may instead list its ``choices``.

Every value is bounded before it is compared: a number must be a finite double (an integer of 400 digits is
refused, not converted), an integer parameter an integral value, a string at most ``max_length`` characters
(:data:`MAX_STRING_LENGTH` unless the row says more), a map at most :data:`MAX_MAP_ENTRIES` wide with bounded
strings (the node reads its numbers as finite doubles). A refusal is ``InvalidInput`` naming the parameter,
which every transport answers as a 400 (never a 500), and nothing changes.

Descriptions are read from the config dataclasses' own documentation (attribute docstrings or a
Google-style ``Attributes:`` section) by :func:`field_docs`, so each parameter is documented once.
"""

from __future__ import annotations

import ast
import inspect
import itertools
import math
import re
import textwrap
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, fields
from functools import cache
from typing import Any

from pfield import _validation
from pfield.errors import InvalidInput

__all__ = ["ParameterRow", "ParameterTable", "field_docs"]

_TYPES = ("double", "integer", "bool", "string", "map")
MAX_MAP_ENTRIES = 64
"""A ``map`` parameter holds at most this many entries (a robot's static frames are a handful)."""
MAX_STRING_LENGTH = 256
"""Characters of a string parameter (a frame name or a choice), and of each string or key in a map, unless
the row allows more (``max_length``: the costmap's footprint polygon)."""


@dataclass(frozen=True)
class ParameterRow:
    """One parameter: ``type`` (see the module docstring), inclusive ``[low, high]`` range or ``choices``."""

    name: str
    type: str
    description: str
    default: Any
    low: float | None = None
    high: float | None = None
    unit: str = ""
    choices: tuple[str, ...] = ()
    read_only: bool = False
    positive: bool = False
    """The value must also be strictly above ``low`` (a gain or a period that cannot be 0)."""
    max_length: int = MAX_STRING_LENGTH
    """Longest value of a ``string`` parameter, in characters."""

    def __post_init__(self) -> None:
        if self.type not in _TYPES:
            raise ValueError(f"parameter {self.name}: unknown type {self.type!r}")

    def check(self, value: Any) -> Any:
        """``value`` in the row's type (integers widen to doubles) and range; else ``InvalidInput``."""
        if self.type == "double":
            if isinstance(value, str):
                raise InvalidInput(self.name, value, "must be a number")
            return self._range(_validation.finite(self.name, value))
        if self.type == "integer":
            # is_integer() is False for inf and NaN, which int() could not convert
            if isinstance(value, bool) or not isinstance(value, int | float) \
                    or (isinstance(value, float) and not value.is_integer()):
                raise InvalidInput(self.name, value, "must be an integer")
            return int(self._range(int(value)))
        if self.type == "bool":
            if not isinstance(value, bool):
                raise InvalidInput(self.name, value, "must be true or false")
            return value
        if self.type == "string":
            if isinstance(value, list | tuple) and self.name == "footprint":
                return value  # nav2's footprint also comes as a parsed list of pairs (checked by the node)
            text = _validation.text(self.name, value)
            if len(text) > self.max_length:
                raise InvalidInput(self.name, text, f"at most {self.max_length} characters")
            if self.choices and text not in self.choices:
                raise InvalidInput(self.name, value, f"must be one of {', '.join(self.choices)}")
            return text
        return _check_map(self.name, value)

    def _range(self, number: float) -> float:
        """``number`` (an int of any size, or a finite float) within the row's range; Python compares ints and
        floats exactly, so a huge integer is refused here without being converted."""
        low = -math.inf if self.low is None else self.low
        high = math.inf if self.high is None else self.high
        unit = f" {self.unit}" if self.unit else ""
        if number < low or (self.positive and number == low):
            raise InvalidInput(self.name, number, f"must be {'>' if self.positive else '>='} {low:g}{unit}")
        if number > high:
            raise InvalidInput(self.name, number, f"must be <= {high:g}{unit}")
        return number

    def describe(self) -> dict[str, Any]:
        value_range: Any = None
        if self.choices:
            value_range = list(self.choices)
        elif self.low is not None or self.high is not None:
            value_range = [self.low, self.high]
        return {"type": self.type, "description": self.description, "range": value_range, "unit": self.unit,
                "default": self.default, "read_only": self.read_only, "positive": self.positive}


def _check_map(field: str, value: Any, depth: int = 0) -> Any:
    """A JSON-like mapping whose keys and strings are valid UTF-8 of at most :data:`MAX_STRING_LENGTH`
    characters, at most :data:`MAX_MAP_ENTRIES` wide (its numbers are the node's to judge: a static transform's
    are read as finite doubles within their range)."""
    if depth == 0 and not isinstance(value, Mapping):
        raise InvalidInput(field, value, "must be a mapping")
    if depth > 4:
        raise InvalidInput(field, "...", "nested too deeply")
    if isinstance(value, Mapping):
        if len(value) > MAX_MAP_ENTRIES:
            raise InvalidInput(field, len(value), f"at most {MAX_MAP_ENTRIES} entries")
        for key in value:
            _check_text(f"{field} key", key)
        for key, item in value.items():
            _check_map(f"{field}.{key}", item, depth + 1)
    elif isinstance(value, list | tuple):
        if len(value) > MAX_MAP_ENTRIES:
            raise InvalidInput(field, len(value), f"at most {MAX_MAP_ENTRIES} entries")
        for index, item in enumerate(value):
            _check_map(f"{field}[{index}]", item, depth + 1)
    elif isinstance(value, str):
        _check_text(field, value)
    return value


def _check_text(field: str, value: Any) -> str:
    text = _validation.text(field, value)
    if len(text) > MAX_STRING_LENGTH:
        raise InvalidInput(field, text, f"at most {MAX_STRING_LENGTH} characters")
    return text


class ParameterTable:
    """The parameter rows of one node, in order (see the module docstring)."""

    def __init__(self, node_name: str, rows: Iterable[ParameterRow]) -> None:
        self.node_name = node_name
        self.rows = {row.name: row for row in rows}

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.rows)

    def check(self, values: Mapping[str, Any]) -> dict[str, Any]:
        """Every value checked against its row (all of them, before any is applied); raises ``InvalidInput``
        naming the first unknown, read-only, mistyped or out-of-range parameter."""
        if not isinstance(values, Mapping):
            raise InvalidInput("parameters", values, "expected a mapping {name: value}")
        checked = {}
        for name, value in values.items():
            row = self.rows.get(_validation.text("parameter name", name))
            if row is None:
                raise InvalidInput(name, value, f"unknown parameter of {self.node_name}; known: "
                                   f"{', '.join(self.rows)}")
            if row.read_only:
                raise InvalidInput(name, value, f"is read-only on {self.node_name}")
            checked[name] = row.check(value)
        return checked

    def describe(self) -> dict[str, dict[str, Any]]:
        """``{name: {"type", "description", "range", "unit", "default", "read_only"}}`` in table order."""
        return {name: row.describe() for name, row in self.rows.items()}


@cache
def field_docs(cls: type) -> dict[str, str]:
    """Each dataclass field's documentation: its attribute docstring, else its line in an ``Attributes:``
    section of the class docstring (continuation lines joined); ``""`` when undocumented."""
    docs = {f.name: "" for f in fields(cls)}
    section = (cls.__doc__ or "").partition("Attributes:")[2]
    current: list[str] = []
    for line in textwrap.dedent(section).splitlines():
        match = re.match(r"\s*([a-z_, ]+):\s+(.*)", line)
        if match and all(name.strip() in docs for name in match.group(1).split(",")):
            current = [name.strip() for name in match.group(1).split(",")]
            for name in current:
                docs[name] = match.group(2).strip()
        elif line.strip() and current:
            for name in current:
                docs[name] += " " + line.strip()
        elif not line.strip():
            current = []
    try:
        tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
    except (OSError, TypeError):  # no source (frozen application): the Attributes section only
        return docs
    body = tree.body[0].body if tree.body and isinstance(tree.body[0], ast.ClassDef) else []
    for node, after in itertools.pairwise(body):
        if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name) and node.target.id in docs \
                and isinstance(after, ast.Expr) and isinstance(after.value, ast.Constant) \
                and isinstance(after.value.value, str):
            docs[node.target.id] = " ".join(after.value.value.split())
    return docs
