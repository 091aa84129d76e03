"""How ``topic echo`` and ``service call`` show a message: ``--field``, ``--no-arr`` and the outcome line.

* ``--field a.b.c`` selects one field by its dotted path, as ``ros2 topic echo --field`` does; an integer
  part indexes an array (``poses.0.pose``). A part that names nothing is refused with the known names.
* ``--no-arr`` replaces every array by its summary in rosidl_runtime_py's words (``ros2 topic echo
  --no-arr``): ``<sequence type: double, length: 7>`` for an unbounded array, ``<array type: double[36]>``
  for a fixed-size one. Types are the IDL names ROS prints (float64 → ``double``, float32 → ``float``).
* :func:`outcome_line` is the one line that says whether a service call worked (``success`` and its
  ``error_message``/``message``), printed after the response so that it is visible without scrolling.
* An integer field that stands for one of its message's constants is shown with the constant's name as a YAML
  comment, ``state: 1  # INSCRIBED`` (bit flags: ``flags: 6  # FLAG_NEAR_OBSTACLE|FLAG_AT_GOAL``): the value
  stays the number for a YAML reader. A field stands for the constants of its type when it is the message's
  only field of that type (FindValidPose's ``state``, ComputeAssistance's ``flags``); a message with several
  (Marker's ``id``, ``type`` and ``action`` are all int32) names none, as nothing links a constant to a field.
"""

from __future__ import annotations

import json
import secrets
from dataclasses import dataclass
from typing import Any

import yaml

from pfield.errors import InvalidInput
from pfield.interfaces import PRIMITIVES, Constant, RosMessage, lookup_type, model_definition

__all__ = ["ConstantValue", "MessageView", "format_yaml", "outcome_line"]

_IDL_NAMES = {"float32": "float", "float64": "double", "bool": "boolean", "byte": "octet"}


@dataclass(frozen=True)
class _Slot:
    """The ROS type of a value being viewed: ``base`` (``float64``, ``geometry_msgs/Pose``), its array part
    (``""`` a single value, ``"[]"`` unbounded, ``"[36]"`` fixed, ``"[<=5]"`` bounded)."""

    base: str
    array: str = ""
    constants: tuple[Constant, ...] = ()
    """The message's constants this (integer) field stands for, if any."""

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
        definition = model_definition(model)
        slots = {f.name: _Slot.parse(f.type) for f in definition.fields}
        for constant_type in {c.type for c in definition.constants if _is_integer(c.value)}:
            typed = [name for name, slot in slots.items() if slot.base == constant_type and not slot.array]
            if len(typed) == 1:  # the only field the constants can belong to
                slots[typed[0]] = _Slot(constant_type, constants=tuple(
                    c for c in definition.constants if c.type == constant_type))
        return slots

    def constant_names(self, value: int) -> str | None:
        """The constants ``value`` stands for: equal ones (``A/B`` when two share it), else, when every constant
        is a distinct bit, the set bits (``A|B``); None when the field has no constants or they do not add up."""
        equal = [c.name for c in self.constants if c.value == value]
        if equal:
            return "/".join(equal)
        bits = [c.value for c in self.constants]
        if value <= 0 or not bits or any(b <= 0 or b & (b - 1) for b in bits) or len(set(bits)) < len(bits):
            return None
        if value & ~sum(bits):
            return None
        return "|".join(c.name for c in self.constants if value & c.value)

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
        """``data`` or the field at ``field`` (dotted path), with arrays summarised when ``no_arr`` and integers
        that stand for constants as :class:`ConstantValue` (equal to their numbers)."""
        slot = self._root()
        if field:
            data, slot = _select(data, slot, field)
        data = _name_constants(data, slot)
        return _abbreviate(data, slot) if no_arr else data


class ConstantValue(int):
    """An integer field with the names of the constants it stands for (``names``); it compares, hashes and
    serialises (JSON) as its number, and :func:`format_yaml` writes it as ``1  # INSCRIBED``."""

    names: str

    def __new__(cls, value: int, names: str) -> ConstantValue:
        number = super().__new__(cls, value)
        number.names = names
        return number


def _is_integer(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _name_constants(data: Any, slot: _Slot | None) -> Any:
    if slot is None:
        return data
    if isinstance(data, list):
        return [_name_constants(item, slot.element()) for item in data] if slot.array else data
    if isinstance(data, dict):
        fields = slot.fields()
        return {key: _name_constants(value, fields.get(key)) for key, value in data.items()}
    if _is_integer(data) and slot.constants and (names := slot.constant_names(data)) is not None:
        return ConstantValue(data, names)
    return data


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
    """``data`` as block YAML, one line per scalar (no wrapping of long strings); a scalar alone as itself; a
    :class:`ConstantValue` as its number and a comment naming its constants."""
    if isinstance(data, ConstantValue):
        return f"{int(data)}  # {data.names}"
    if not isinstance(data, dict | list):
        return json.dumps(data) if data is None or isinstance(data, bool) else str(data)
    marked: dict[str, ConstantValue] = {}
    suffix = secrets.token_hex(8)  # no value of the message can spell the placeholders

    def mark(value: Any) -> Any:
        if isinstance(value, ConstantValue):
            placeholder = f"pfield-constant-{len(marked)}-{suffix}"
            marked[placeholder] = value
            return placeholder
        if isinstance(value, dict):
            return {key: mark(item) for key, item in value.items()}
        if isinstance(value, list):
            return [mark(item) for item in value]
        return value

    text = yaml.safe_dump(mark(data), sort_keys=False, default_flow_style=False, width=2**31 - 1).rstrip("\n")
    for placeholder, value in marked.items():  # block style: each placeholder ends its line
        text = text.replace(placeholder, f"{int(value)}  # {value.names}")
    return text
