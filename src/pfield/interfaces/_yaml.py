"""Messages from the YAML flow text of ``ros2 topic pub`` / ``ros2 service call`` and back.

ROS's rules (rosidl_runtime_py ``set_message_fields``): the argument is YAML (``yaml.safe_load``, so JSON
works too) describing a mapping; missing fields keep their defaults, unknown fields are errors, integers
are accepted for floating-point fields. An empty argument means the default message. Errors become
:class:`~pfield.errors.InvalidInput` naming the dotted field path (``obstacles[0].radius``).

Nesting is bounded (:data:`MAX_DEPTH` levels of mappings and sequences, far more than any ROS message
needs): a deeper document is refused with an error instead of exhausting Python's recursion limit.
"""

from __future__ import annotations

import typing
from collections.abc import Mapping
from typing import Any, TypeVar

import yaml
from pydantic import ValidationError

from pfield.errors import InvalidInput
from pfield.interfaces._base import RosMessage

__all__ = ["MAX_DEPTH", "load_yaml", "message_from_data", "message_from_yaml", "message_to_data", "message_to_yaml",
           "validation_error"]

M = TypeVar("M", bound=RosMessage)

MAX_DEPTH = 100
"""Deepest nesting of mappings and sequences a YAML/JSON argument may have (a MarkerArray needs 6)."""


class _TooDeep(Exception):
    def __init__(self, line: int, column: int) -> None:
        super().__init__(line, column)
        self.line, self.column = line, column


class _BoundedLoader(yaml.SafeLoader):
    """``yaml.SafeLoader`` that stops composing beyond :data:`MAX_DEPTH` nested collections."""

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        self._depth = 0

    def compose_node(self, parent: Any, index: Any) -> Any:
        self._depth += 1
        try:
            if self._depth > MAX_DEPTH:
                mark = self.peek_event().start_mark
                raise _TooDeep(mark.line + 1, mark.column + 1)
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1


def load_yaml(text: str, field: str = "yaml") -> Any:
    """``yaml.safe_load(text)`` with nesting bounded by :data:`MAX_DEPTH`; malformed or too deep text raises
    :class:`~pfield.errors.InvalidInput` naming ``field`` (the argument, option or file it came from)."""
    loader = _BoundedLoader(text)
    try:
        return loader.get_single_data()
    except _TooDeep as exc:
        raise InvalidInput(field, text[:60], f"nested deeper than {MAX_DEPTH} levels (at line {exc.line}, "
                                              f"column {exc.column})") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise InvalidInput(field, text[:200], f"malformed YAML: {problem}{where}") from None
    finally:
        loader.dispose()


def _path(location: tuple[int | str, ...]) -> str:
    text = ""
    for part in location:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text or "message"


def _message_class(annotation: Any) -> type[RosMessage] | None:
    """The message class a field annotation holds (``Pose``, ``list[Pose]``, ``Annotated[...]``), else None."""
    while typing.get_origin(annotation) in (typing.Annotated, list, tuple):
        annotation = typing.get_args(annotation)[0]
    return annotation if isinstance(annotation, type) and issubclass(annotation, RosMessage) else None


def _model_at(model: type[RosMessage], location: tuple[int | str, ...]) -> type[RosMessage]:
    """The (nested) message class holding the field at ``location`` (its last part is the unknown name)."""
    for part in location[:-1]:
        if isinstance(part, int):
            continue
        info = model.model_fields.get(str(part))
        nested = _message_class(info.annotation) if info is not None else None
        if nested is None:
            break
        model = nested
    return model


def validation_error(error: ValidationError, type_name: str,
                     model: type[RosMessage] | None = None) -> InvalidInput:
    """The first problem of a pydantic error as ``InvalidInput`` naming the field path (for an unknown field,
    also the fields the message at that place has, when ``model`` is given)."""
    first = error.errors()[0]
    location = tuple(first["loc"])
    field = _path(location)
    reason = first["msg"]
    if first["type"] == "extra_forbidden":
        reason = f"unknown field of {type_name}"
        if model is not None and location:
            holder = _model_at(model, location)
            known = ", ".join(info.alias or name for name, info in holder.model_fields.items())
            reason = f"unknown field of {holder.ros_type} (known: {known})"
    return InvalidInput(field, first.get("input"), reason)


def message_from_data(model: type[M], data: Any) -> M:
    """Validate a decoded mapping (``None`` means all defaults) as ``model``."""
    if data is None:
        data = {}
    if not isinstance(data, Mapping):
        raise InvalidInput("message", data, f"expected a mapping of the fields of {model.ros_type}")
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise validation_error(exc, model.ros_type, model) from None


def message_from_yaml(model: type[M], text: str) -> M:
    """Parse the YAML (or JSON) flow text of a message, e.g. ``"{radius: 0.1}"``."""
    return message_from_data(model, load_yaml(text) if text.strip() else None)


def message_to_data(message: RosMessage) -> dict[str, Any]:
    """JSON-compatible mapping of a message (every field, defaults included, like ``ros2 topic echo``)."""
    return message.model_dump(mode="json")


def message_to_yaml(message: RosMessage) -> str:
    """Block YAML of a message in field order, as ``ros2 topic echo`` prints it."""
    return yaml.safe_dump(message_to_data(message), sort_keys=False, default_flow_style=False)
