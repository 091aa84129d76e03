"""Conversion between pfield's pydantic message models and the message classes rclpy generates.

Generic, by field name and recursively: the layout of each rclpy class is read once from its
``SLOT_TYPES`` (rosidl's own type description of every field) and cached, so one pair of functions
serves every message and service pfield speaks — the standard ones (``geometry_msgs`` …) and the
package ``potential_fields_interfaces`` built from ``ros/``. The pydantic model and the rclpy class
must have exactly the same fields (``tests/interfaces`` proves the models equal the ``.msg`` files);
a difference raises :class:`TypeError` naming the fields, since it is a build mismatch, not bad input.

Scalars are cast to the Python type rclpy's setters insist on (``float`` for float32/float64 …);
numeric sequences are passed as ``array.array`` of the matching typecode, which rclpy accepts without
copying element by element.
"""

from __future__ import annotations

import array
import functools
import importlib
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TypeVar

from rosidl_parser import definition as idl

from pfield.interfaces import RosMessage

__all__ = ["from_ros", "interface_class", "to_ros"]

M = TypeVar("M", bound=RosMessage)

_TYPECODES = {
    "float": "f", "double": "d", "int8": "b", "uint8": "B", "int16": "h", "uint16": "H",
    "int32": "i", "uint32": "I", "int64": "q", "uint64": "Q",
}


def _cast_for(type_name: str) -> Callable[[Any], Any]:
    if type_name in ("float", "double", "long double"):
        return float
    if type_name == "boolean":
        return bool
    if type_name == "octet":
        return bytes
    if type_name in ("char", "wchar"):
        return str
    return int


@dataclass(frozen=True)
class _Slot:
    """How one field of an rclpy class is converted.

    ``kind`` is ``message`` (nested), ``messages`` (sequence of nested), ``values`` (sequence of
    scalars or strings) or ``scalar``; ``nested`` is the rclpy class of nested messages; ``typecode``
    the ``array`` typecode of an unbounded/bounded numeric sequence (None for fixed arrays and strings).
    """

    name: str
    kind: str
    nested: type | None
    cast: Callable[[Any], Any]
    typecode: str | None


_SLOTS: dict[type, tuple[_Slot, ...]] = {}
_NAMES_CHECKED: set[tuple[type, type]] = set()
_LOCK = threading.Lock()


def interface_class(type_name: str) -> type:
    """rclpy class for a ROS type name: ``pkg/msg/Name``, ``pkg/srv/Name`` (the service, with
    ``.Request``/``.Response``) or ``pkg/srv/Name_Request``/``_Response`` (one half of it)."""
    parts = type_name.split("/")
    if len(parts) != 3 or parts[1] not in ("msg", "srv", "action"):
        raise ValueError(f"not a ROS interface type name: {type_name!r} (expected pkg/msg/Name or pkg/srv/Name)")
    package, kind, name = parts
    module = importlib.import_module(f"{package}.{kind}")
    for suffix in ("_Request", "_Response"):
        if kind == "srv" and name.endswith(suffix) and not hasattr(module, name):
            service = getattr(module, name.removesuffix(suffix))
            return getattr(service, suffix.lstrip("_"))  # type: ignore[no-any-return]
    return getattr(module, name)  # type: ignore[no-any-return]


def _nested_class(nested: idl.NamespacedType) -> type:
    return interface_class("/".join([*nested.namespaces, nested.name]))


def _slot(name: str, slot_type: Any) -> _Slot:
    if isinstance(slot_type, idl.NamespacedType):
        return _Slot(name, "message", _nested_class(slot_type), dict, None)
    if isinstance(slot_type, idl.AbstractNestedType):
        value_type = slot_type.value_type
        if isinstance(value_type, idl.NamespacedType):
            return _Slot(name, "messages", _nested_class(value_type), dict, None)
        if isinstance(value_type, idl.AbstractGenericString):
            return _Slot(name, "values", None, str, None)
        typecode = None if isinstance(slot_type, idl.Array) else _TYPECODES.get(value_type.typename)
        return _Slot(name, "values", None, _cast_for(value_type.typename), typecode)
    if isinstance(slot_type, idl.AbstractGenericString):
        return _Slot(name, "scalar", None, str, None)
    return _Slot(name, "scalar", None, _cast_for(slot_type.typename), None)


def _slots(ros_class: type) -> tuple[_Slot, ...]:
    """The cached conversion plan of an rclpy message class (fields in declaration order)."""
    slots = _SLOTS.get(ros_class)
    if slots is None:
        names = list(ros_class.get_fields_and_field_types())  # type: ignore[attr-defined]
        slots = tuple(_slot(name, slot_type) for name, slot_type in zip(names, ros_class.SLOT_TYPES, strict=True))  # type: ignore[attr-defined]
        with _LOCK:
            _SLOTS[ros_class] = slots
    return slots


@functools.cache
def _ros_field_names(model_class: type[RosMessage]) -> dict[str, str]:
    """ROS field name -> pydantic attribute name (the alias is the ROS name where one is set)."""
    return {(info.alias or name): name for name, info in model_class.model_fields.items()}


def _check_names(model_class: type[RosMessage], ros_class: type) -> None:
    if (model_class, ros_class) in _NAMES_CHECKED:
        return
    model_names = set(_ros_field_names(model_class))
    ros_names = {slot.name for slot in _slots(ros_class)}
    if model_names != ros_names:
        raise TypeError(
            f"{model_class.__name__} and {ros_class.__module__}.{ros_class.__name__} differ: "
            f"only in the model {sorted(model_names - ros_names)}, only in ROS {sorted(ros_names - model_names)}"
        )
    with _LOCK:
        _NAMES_CHECKED.add((model_class, ros_class))


def to_ros(model: RosMessage, ros_class: type) -> Any:
    """An rclpy message of ``ros_class`` with the values of the pydantic ``model`` (same fields)."""
    model_class = type(model)
    _check_names(model_class, ros_class)
    attributes = _ros_field_names(model_class)
    message = ros_class()
    for slot in _slots(ros_class):
        value = getattr(model, attributes[slot.name])
        if slot.kind == "message":
            converted: Any = to_ros(value, slot.nested)  # type: ignore[arg-type]
        elif slot.kind == "messages":
            converted = [to_ros(item, slot.nested) for item in value]  # type: ignore[arg-type]
        elif slot.kind == "values":
            items = [slot.cast(item) for item in value]
            converted = array.array(slot.typecode, items) if slot.typecode else items
        else:
            converted = slot.cast(value)
        setattr(message, slot.name, converted)
    return message


def _to_plain(message: Any) -> dict[str, Any]:
    """An rclpy message as nested dicts and lists keyed by ROS field name."""
    plain: dict[str, Any] = {}
    for slot in _slots(type(message)):
        value = getattr(message, slot.name)
        if slot.kind == "message":
            plain[slot.name] = _to_plain(value)
        elif slot.kind == "messages":
            plain[slot.name] = [_to_plain(item) for item in value]
        elif slot.kind == "values":
            plain[slot.name] = value.tolist() if hasattr(value, "tolist") else list(value)
        else:
            plain[slot.name] = value
    return plain


def from_ros(message: Any, model_class: type[M]) -> M:
    """The pydantic ``model_class`` instance equal to the rclpy ``message``; validation errors of the
    model (pydantic's ``ValidationError``) propagate to the caller."""
    _check_names(model_class, type(message))
    return model_class.model_validate(_to_plain(message))
