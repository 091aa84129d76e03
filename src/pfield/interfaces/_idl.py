"""The ROS 2 ``.msg``/``.srv`` text format: a small parser and its inverse for the pydantic models.

Grammar (design.ros2.org "Interface definition"): one field per line, ``TYPE NAME [DEFAULT]``, or a
constant ``TYPE NAME=VALUE``; ``#`` starts a comment; a service is request ``---`` response. Types are
primitives (``float32`` …, ``string``, bounded ``string<=N``), ``pkg/Name`` or a bare ``Name`` of the same
package, each optionally an array ``[]``, ``[N]`` or ``[<=N]``. :func:`model_definition` renders a model
in the same normalised form, so a test can compare a model with its file field by field and
``pfield interface show`` can print any registered type.
"""

from __future__ import annotations

import ast
import os
import re
import sys
import types
import typing
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pfield.errors import InvalidInput
from pfield.interfaces._base import RosMessage, RosType, lookup_service, lookup_type

__all__ = [
    "Constant",
    "Definition",
    "FieldDef",
    "interface_file",
    "interface_text",
    "model_definition",
    "parse_definition",
    "parse_service",
]

_INTEGERS = {"byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64", "uint64"}
_FLOATS = {"float32", "float64"}
_CONSTANT = re.compile(r"^([A-Za-z][A-Za-z0-9_]*)\s*=(.*)$")
PRIMITIVES = _INTEGERS | _FLOATS | {"bool", "string", "wstring"}


@dataclass(frozen=True)
class FieldDef:
    """A field: normalised ``type`` (``float32``, ``geometry_msgs/Pose``, ``Obstacle[]`` → ``pkg/Obstacle[]``)."""

    type: str
    name: str
    default: Any


@dataclass(frozen=True)
class Constant:
    type: str
    name: str
    value: Any


@dataclass(frozen=True)
class Definition:
    fields: tuple[FieldDef, ...]
    constants: tuple[Constant, ...]


def _strip_comment(line: str) -> str:
    quote = ""
    for i, char in enumerate(line):
        if char in "'\"" and (not quote or quote == char):
            quote = "" if quote else char
        elif char == "#" and not quote:
            return line[:i]
    return line


def _base_type(type_name: str) -> tuple[str, str]:
    """Split ``float32[<=3]`` into (``float32``, ``[]``): bounds are not modelled by the JSON wire format;
    a fixed size is (``float64[36]`` → ``[36]``)."""
    base, bracket, size = type_name.partition("[")
    base = base.split("<=")[0]
    size = size.rstrip("]")
    return base, (f"[{size}]" if size.isdigit() else "[]") if bracket else ""


def _normalise_type(type_name: str, package: str) -> str:
    base, array = _base_type(type_name)
    if base not in PRIMITIVES and "/" not in base:
        base = f"{package}/{base}"
    elif "/msg/" in base:
        base = base.replace("/msg/", "/")
    return base + array


def _literal(type_name: str, text: str) -> Any:
    base, array = _base_type(type_name)
    text = text.strip()
    if array:
        return [_literal(base, item) for item in ast.literal_eval(text)] if text else []
    if base in ("string", "wstring"):
        return ast.literal_eval(text) if text[:1] in "'\"" else text
    if base == "bool":
        return text.lower() in ("true", "1")
    return float(text) if base in _FLOATS else int(text, 0)


def _zero(type_name: str) -> Any:
    base, array = _base_type(type_name)
    if array:
        return [_zero(base)] * int(array[1:-1]) if array != "[]" else []
    if base in ("string", "wstring"):
        return ""
    if base == "bool":
        return False
    if base in _FLOATS:
        return 0.0
    return 0 if base in _INTEGERS else None  # None: a nested message's own defaults


def parse_definition(text: str, package: str) -> Definition:
    """Parse one ``.msg`` text (or one half of a ``.srv``); types normalised relative to ``package``."""
    fields: list[FieldDef] = []
    constants: list[Constant] = []
    for raw in text.splitlines():
        line = _strip_comment(raw).strip()
        if not line:
            continue
        type_name, _, rest = line.partition(" ")
        constant = _CONSTANT.match(rest.strip())
        if constant:
            constants.append(Constant(type_name, constant[1], _literal(type_name, constant[2])))
            continue
        rest = rest.strip()
        name, _, default = rest.partition(" ")
        ftype = _normalise_type(type_name, package)
        fields.append(FieldDef(ftype, name, _literal(type_name, default) if default.strip() else _zero(ftype)))
    return Definition(tuple(fields), tuple(constants))


def parse_service(text: str, package: str) -> tuple[Definition, Definition]:
    """Parse a ``.srv`` text into (request, response)."""
    lines = text.splitlines()
    split = next((i for i, line in enumerate(lines) if line.strip() == "---"), None)
    if split is None:
        raise InvalidInput("srv", text[:40], "a service definition needs a '---' line")
    return (parse_definition("\n".join(lines[:split]), package),
            parse_definition("\n".join(lines[split + 1:]), package))


def _annotation_type(annotation: Any) -> str:
    """ROS type of a model field annotation (``Float32`` → ``float32``, ``list[Pose]`` → ``geometry_msgs/Pose[]``)."""
    if typing.get_origin(annotation) is typing.Annotated:
        for meta in annotation.__metadata__:
            if isinstance(meta, RosType):
                return meta.name
        return _annotation_type(annotation.__origin__)
    if typing.get_origin(annotation) in (list, tuple):
        return _annotation_type(typing.get_args(annotation)[0]) + "[]"
    if isinstance(annotation, type) and issubclass(annotation, RosMessage):
        return annotation.ros_type.replace("/msg/", "/")
    if isinstance(annotation, types.UnionType):
        raise TypeError(f"optional fields do not exist in ROS: {annotation}")
    raise TypeError(f"field annotation without a ROS type: {annotation}")


def model_definition(model: type[RosMessage]) -> Definition:
    """The :class:`Definition` a model implements (defaults of nested messages as ``None``)."""
    fields = []
    for name, info in model.model_fields.items():
        ros_type = _annotation_type(info.rebuild_annotation())
        if ros_type.split("[")[0] in PRIMITIVES:
            default = info.get_default(call_default_factory=True)
        else:
            default = [] if ros_type.endswith("[]") else None
        fields.append(FieldDef(ros_type, info.alias or name, default))
    constants = tuple(Constant(t, n, v) for n, (t, v) in model.ros_constants.items())
    return Definition(tuple(fields), constants)


def _render(definition: Definition) -> str:
    lines = [f"{c.type} {c.name}={c.value!r}" if isinstance(c.value, str) else f"{c.type} {c.name}={c.value}"
             for c in definition.constants]
    for f in definition.fields:
        zero = f.default in (None, [], "", 0, 0.0, False) or (isinstance(f.default, list) and not any(f.default))
        default = "" if zero else f" {f.default!r}"
        lines.append(f"{f.type} {f.name}{default}")
    return "\n".join(lines)


def interface_file(type_name: str) -> Path | None:
    """The ``.msg``/``.srv`` file of a type: ``AMENT_PREFIX_PATH`` shares, this environment's share
    directory (the ROS 2 wheels), or the ``ros/`` folder of a source checkout; None when not found."""
    parts = type_name.split("/")
    if len(parts) == 2:
        parts = [parts[0], "msg", parts[1]]
    if len(parts) != 3 or parts[1] not in ("msg", "srv"):
        return None
    package, kind, name = parts
    relative = Path(package, kind, f"{name}.{kind}")
    prefixes = [Path(p) / "share" for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    prefixes += [Path(sys.prefix) / "share", Path(__file__).resolve().parents[3] / "ros"]
    return next((prefix / relative for prefix in prefixes if (prefix / relative).is_file()), None)


def interface_text(type_name: str) -> str:
    """Definition text of a message (``pkg/msg/Name``) or service (``pkg/srv/Name``): the file's text
    when it is installed (comments included, as ``ros2 interface show``), else rendered from the model."""
    path = interface_file(type_name)
    if "/srv/" in type_name:
        lookup_service(type_name)
    else:
        lookup_type(type_name)
    if path is not None:
        return path.read_text().rstrip("\n")
    if "/srv/" in type_name:
        service = lookup_service(type_name)
        return _render(model_definition(service.request)) + "\n---\n" + _render(model_definition(service.response))
    return _render(model_definition(lookup_type(type_name)))
