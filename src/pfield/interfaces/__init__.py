"""Pydantic models mirroring the ROS 2 messages and services pfield speaks (the wire format).

:func:`lookup_type` / :func:`lookup_service` find every type pfield knows (importing the package imports
:mod:`pfield.interfaces.all`, which registers them, so a lookup never depends on what the caller imported
before); the models themselves live in the package modules
(``pfield.interfaces.geometry_msgs`` …).
:func:`message_from_yaml` parses the YAML flow text of ``ros2 topic pub``; ``pfield.interfaces.convert``
maps messages to and from pfield's core types.
"""

import pfield.interfaces.all  # noqa: F401 - registers every package's types
from pfield.interfaces._base import (
    RosMessage,
    ServiceType,
    lookup_service,
    lookup_type,
    registered_services,
    registered_types,
)
from pfield.interfaces._idl import PRIMITIVES, Constant, interface_text, model_definition
from pfield.interfaces._yaml import (
    field_path,
    load_yaml,
    load_yaml_file,
    message_from_data,
    message_from_yaml,
    message_to_data,
    message_to_yaml,
)

__all__ = [
    "PRIMITIVES",
    "Constant",
    "RosMessage",
    "ServiceType",
    "field_path",
    "interface_text",
    "load_yaml",
    "load_yaml_file",
    "lookup_service",
    "lookup_type",
    "message_from_data",
    "message_from_yaml",
    "message_to_data",
    "message_to_yaml",
    "model_definition",
    "registered_services",
    "registered_types",
]
