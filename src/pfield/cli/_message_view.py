"""How ``topic echo`` and ``service call`` show a message: ``--field``, ``--no-arr`` and the outcome line.

* ``--field a.b.c`` selects one field by its dotted path, as ``ros2 topic echo --field`` does; an integer
  part indexes an array (``poses.0.pose``). A part that names nothing is refused with the known names.
* ``--no-arr`` replaces every array by its summary in rosidl_runtime_py's words (``ros2 topic echo
  --no-arr``): ``<sequence type: double, length: 7>`` for an unbounded array, ``<array type: double[36]>``
  for a fixed-size one. Types are the IDL names ROS prints (float64 → ``double``, float32 → ``float``).
* :func:`outcome_line` is the one line that says whether a service call worked (``success`` and its
  ``error_message``/``message``), printed after the response so that it is visible without scrolling.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

import yaml

from pfield.errors import InvalidInput
from pfield.interfaces import RosMessage, lookup_type
from pfield.interfaces._idl import PRIMITIVES, model_definition

__all__ = ["MessageView", "format_yaml", "outcome_line"]

_IDL_NAMES = {"float32": "float", "float64": "double", "bool": "boolean", "byte": "octet"}


@dataclass(frozen=True)
class _Slot:
    """The ROS type of a value being viewed: ``base`` (``float64``, ``geometry_msgs/Pose``), its array part
    (``""`` a single value, ``"[]"`` unbounded, ``"[36]"`` fixed, ``"[<=5]"`` bounded)."""

    base: str
    array: str = ""

    @classmethod
    def parse(cls, type_name: str) -> _Slot:
        base, bracket, rest = type_name.partition("[")
        return cls(base, bracket + rest)

    @property
    def model(self) -> type[RosMessage] | None:
        return None if self.base.split("<=")[0] in PRIMITIVES else lookup_type(self.base)

    def element(self) -> _Slot:
        return _Slot(self.base)

    def fields(self) -> dict[str, _Slot]:
        model = self.model
        if model is None or self.array:
            return {}
        return {f.name: _Slot.parse(f.type) for f in model_definition(model).fields}

    def summary(self, length: int) -> str:
        model = self.model
        name = model.ros_type if model is not None else _IDL_NAMES.get(self.base, self.base)
        size = self.array[1:-1]
        if size.startswith("<="):
            return f"<sequence type: {name}[{size}], length: {length}>"
        if size:
            return f"<array type: {name}[{size}]>"
        return f"<sequence type: {name}, length: {length}>"


@dataclass(frozen=True)
class MessageView:
    """Select and abbreviate the JSON data of a message whose ROS type is ``type_name`` (None: unknown)."""

    type_name: str | None

    def _root(self) -> _Slot | None:
        if self.type_name is None:
            return None
        return _Slot(lookup_type(self.type_name).ros_type.replace("/msg/", "/", 1))

    def show(self, data: Any, field: str | None = None, no_arr: bool = False) -> Any:
        """``data`` or the field at ``field`` (dotted path), with arrays summarised when ``no_arr``."""
        slot = self._root()
        if field:
            data, slot = _select(data, slot, field)
        return _abbreviate(data, slot) if no_arr else data


def _select(data: Any, slot: _Slot | None, path: str) -> tuple[Any, _Slot | None]:
    walked: list[str] = []
    for part in path.split("."):
        if isinstance(data, list) and part.lstrip("-").isdigit() and -len(data) <= int(part) < len(data):
            data, slot = data[int(part)], slot.element() if slot is not None else None
        elif isinstance(data, dict) and part in data:
            data, slot = data[part], (slot.fields().get(part) if slot is not None else None)
        else:
            where = ".".join(walked) or "the message"
            if isinstance(data, dict):
                known = f"known: {', '.join(data)}"
            elif isinstance(data, list):
                known = f"an array of {len(data)}: give an index 0..{len(data) - 1}"
            else:
                known = f"{where} is a {type(data).__name__}, it has no fields"
            raise InvalidInput("--field", path, f"{part!r} is not a field of {where} ({known})")
        walked.append(part)
    return data, slot


def _abbreviate(data: Any, slot: _Slot | None) -> Any:
    if isinstance(data, list):
        if slot is not None and slot.array:
            return slot.summary(len(data))
        return f"<sequence length: {len(data)}>"
    if isinstance(data, dict):
        fields = slot.fields() if slot is not None else {}
        return {key: _abbreviate(value, fields.get(key)) for key, value in data.items()}
    return data


def outcome_line(response: Any) -> str | None:
    """``success: false (error_message: ...)`` for a response with a ``success`` field, else None."""
    if not isinstance(response, dict) or not isinstance(response.get("success"), bool):
        return None
    line = f"success: {str(response['success']).lower()}"
    for key in ("error_message", "message"):
        if isinstance(response.get(key), str) and response[key]:
            return f"{line} ({key}: {response[key]})"
    return line


def format_yaml(data: Any) -> str:
    """``data`` as block YAML, one line per scalar (no wrapping of long strings); a scalar alone as itself."""
    if not isinstance(data, dict | list):
        return json.dumps(data) if data is None or isinstance(data, bool) else str(data)
    return yaml.safe_dump(data, sort_keys=False, default_flow_style=False, width=2**31 - 1).rstrip("\n")
