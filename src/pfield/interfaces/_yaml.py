"""Messages from the YAML flow text of ``ros2 topic pub`` / ``ros2 service call`` and back.

ROS's rules (rosidl_runtime_py ``set_message_fields``): the argument is YAML (``yaml.safe_load``, so JSON
works too) describing a mapping; missing fields keep their defaults, unknown fields are errors, integers
are accepted for floating-point fields. An empty argument means the default message. Errors become
:class:`~pfield.errors.InvalidInput` naming the dotted field path (``obstacles[0].radius``).

A document is bounded before anything else reads it (:func:`load_yaml`), whether it comes from a command-line
argument or a file (:func:`load_yaml_file`): at most :data:`MAX_BYTES` long, :data:`MAX_DEPTH` levels of
mappings and sequences deep (far more than any ROS message needs), at most :data:`MAX_NODES` nodes once its
aliases are expanded, and aliases repeating at most :data:`ALIAS_ALLOWANCE` nodes more than the document
writes out (so a problem set's memory follows its size, whatever its aliases). Beyond any of these
the document is refused with an error naming the bound, instead of exhausting the recursion limit, the
memory or the time of whatever walks the value (a few hundred bytes of nested aliases expand to a billion
nodes).
"""

from __future__ import annotations

import re
import typing
from collections.abc import Mapping
from pathlib import Path
from typing import Any, TypeVar

import yaml
from pydantic import ValidationError
from yaml.composer import Composer
from yaml.constructor import SafeConstructor
from yaml.events import AliasEvent
from yaml.resolver import Resolver

from pfield._files import read_text
from pfield.errors import InvalidInput
from pfield.interfaces._base import RosMessage

_Parser: Any
try:
    from yaml._yaml import CParser as _Parser  # libyaml's parser: about 10x faster than PyYAML's
except ImportError:  # PyYAML built without libyaml: its own parser (the rest of SafeLoader stays unused)
    from yaml import SafeLoader as _Parser

__all__ = ["ALIAS_ALLOWANCE", "MAX_BYTES", "MAX_DEPTH", "MAX_NODES", "field_path", "load_yaml", "load_yaml_file",
           "message_from_data", "message_from_yaml", "message_to_data", "message_to_yaml", "validation_error"]

M = TypeVar("M", bound=RosMessage)

MAX_BYTES = 8 * 2**20
"""Longest YAML document read (8 MiB; characters for a command-line argument): a MoveIt scene holding a mesh
of some 25 000 triangles, which reaches :data:`MAX_NODES` first."""
MAX_DEPTH = 100
"""Deepest nesting of mappings and sequences a YAML/JSON document may have (a MarkerArray needs 6)."""
MAX_NODES = 250_000
"""Most nodes (scalars, sequences, mappings) a YAML document may hold with its aliases expanded, each alias
counting the nodes it repeats: what every reader of the value walks. Composing one node takes about 0.5 kB,
so a document at the bound takes some 120 MB while it is read (a MotionBenchMaker scene has about 600)."""
ALIAS_ALLOWANCE = 1_000
"""Aliases may repeat at most as many nodes as the document writes out, plus this many: an alias saves writing
a pose twice, it cannot turn a small file into a large document."""


class _Refused(Exception):
    """A bound of the loader, with the place in the text where it was passed."""

    def __init__(self, reason: str, mark: Any) -> None:
        super().__init__(reason)
        self.reason = reason
        self.where = f" (at line {mark.line + 1}, column {mark.column + 1})" if mark is not None else ""


class _BoundedLoader(Composer, SafeConstructor, Resolver):
    """``yaml.safe_load``'s composer and constructor over libyaml's events, counting as it composes: the
    nesting depth, the nodes of the expanded document (an alias adds the size of the node it names) and how
    many of them aliases repeat. Each limit is checked before the next node is built, so a refused document
    costs no more than the bound. (libyaml's own composer is compiled and cannot count; its events can be.)"""

    def __init__(self, stream: str) -> None:
        self._events = _Parser(stream)
        Composer.__init__(self)
        SafeConstructor.__init__(self)
        Resolver.__init__(self)
        self._depth = 0
        self._nodes = 0
        self._repeated = 0
        self._sizes: dict[str | None, int] = {}  # anchor -> expanded size of the finished node it names

    def check_event(self, *choices: Any) -> bool:
        return bool(self._events.check_event(*choices))

    def peek_event(self) -> Any:
        return self._events.peek_event()

    def get_event(self) -> Any:
        return self._events.get_event()

    def dispose(self) -> None:
        self._events.dispose()

    def compose_node(self, parent: Any, index: Any) -> Any:
        event = self.peek_event()
        if isinstance(event, AliasEvent):
            size = self._sizes.get(event.anchor)
            if size is None and event.anchor in self.anchors:
                raise _Refused(f"the alias *{event.anchor} is used inside the node it names", event.start_mark)
            node = super().compose_node(parent, index)  # an undefined alias raises here
            self._count(size or 0, event)
            return node
        if self._depth >= MAX_DEPTH:
            raise _Refused(f"nested deeper than {MAX_DEPTH} levels", event.start_mark)
        before = self._nodes
        self._count(1, event)
        self._depth += 1
        try:
            node = super().compose_node(parent, index)
        finally:
            self._depth -= 1
        if event.anchor is not None:
            self._sizes[event.anchor] = self._nodes - before
        return node

    def _count(self, nodes: int, event: Any) -> None:
        self._nodes += nodes
        if isinstance(event, AliasEvent):
            self._repeated += nodes
            written = self._nodes - self._repeated
            if self._repeated > written + ALIAS_ALLOWANCE:
                raise _Refused(f"its aliases repeat {self._repeated} nodes, more than the {written} it writes out "
                               f"plus {ALIAS_ALLOWANCE}", event.start_mark)
        if self._nodes > MAX_NODES:
            raise _Refused(f"expands to more than {MAX_NODES} nodes (an alias counts the nodes it repeats)",
                           event.start_mark)


# YAML 1.1 reads 1e-3 and 2E5 (no dot, or no sign in the exponent) as strings; YAML 1.2 and JSON read numbers,
# and so does ros2's float() of a field. With number fields that refuse strings, they must arrive as numbers.
_BoundedLoader.add_implicit_resolver("tag:yaml.org,2002:float",
                                     re.compile(r"^[-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)[eE][-+]?[0-9]+$"),
                                     list("-+0123456789."))


def load_yaml(text: str, field: str = "yaml", source: str | None = None) -> Any:
    """``yaml.safe_load(text)`` within the bounds of the module text; malformed or unbounded text raises
    :class:`~pfield.errors.InvalidInput` naming ``field`` (the argument, option or file it came from) and
    quoting ``source`` (default: the text's first characters)."""
    quoted = text[:100] if source is None else source  # the message quotes at most VALUE_CHARS of it
    if len(text) > MAX_BYTES:
        raise InvalidInput(field, quoted, f"is {len(text)} characters long, over the limit of {MAX_BYTES}")
    loader = _BoundedLoader(text)
    try:
        return loader.get_single_data()
    except _Refused as exc:
        raise InvalidInput(field, quoted, exc.reason + exc.where) from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        if "nesting depth" in problem:  # libyaml's own limit (1000 levels) lies beyond MAX_DEPTH
            raise InvalidInput(field, quoted, f"nested deeper than {MAX_DEPTH} levels") from None
        raise InvalidInput(field, quoted, f"malformed YAML: {problem}{where}") from None
    except (ValueError, OverflowError) as exc:  # a tagged or timestamp scalar with an impossible value
        raise InvalidInput(field, quoted, f"malformed YAML: {exc}") from None
    finally:
        loader.dispose()


def load_yaml_file(path: Path, field: str) -> Any:
    """The YAML document of the file ``path`` (:func:`load_yaml`): a regular file of at most :data:`MAX_BYTES`
    bytes of UTF-8 (:func:`pfield._files.read_text`); errors name ``field`` and quote the path."""
    return load_yaml(read_text(field, path, MAX_BYTES), field, source=str(path))


def field_path(location: tuple[int | str, ...]) -> str:
    """A validation error's location as the field path errors name: ``("goal", "position", "x")`` →
    ``goal.position.x``, ``("obstacles", 0, "id")`` → ``obstacles[0].id``, ``()`` → ``message``."""
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
    field = field_path(location)
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
