"""A pfield node's parameters as ROS 2 parameters of its rclpy node, validated by the pfield node.

Every entry of :meth:`pfield.node.Node.get_parameters` is declared on the rclpy node with its
current value, so ``ros2 param list|get|set|dump`` and ``--ros-args -p``/``--params-file`` work as for
any ROS node. Setting goes through two rclpy callbacks:

* a *pre-set* callback widens integers to doubles for parameters declared as doubles (``ros2 param
  set /pfield_manager max_linear_velocity 1`` means 1.0, as a user expects, instead of a type error); an
  integer beyond a double's range (a 400-digit one, which Python's ``float`` refuses with ``OverflowError``)
  becomes ±inf, as IEEE 754 rounds it, and the node refuses it as not finite;
* an *on-set* callback hands the new values to ``node.set_parameters``, which validates them all and
  applies them together. A rejected value is refused with the node's reason (``InvalidInput`` names the
  parameter and the value); the rclpy value then stays as it was, and so does the pfield node's.
"""

from __future__ import annotations

import array
import logging
import math
from collections.abc import Mapping
from typing import Any

from pydantic import ValidationError
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.exceptions import InvalidParameterTypeException
from rclpy.node import Node as RclpyNode
from rclpy.parameter import Parameter

from pfield.errors import InvalidInput, PfieldError
from pfield.node import Node

__all__ = ["declare_parameters"]

_LOG = logging.getLogger(__name__)


def _plain(value: Any) -> Any:
    """A ROS parameter value as a JSON-compatible Python value (arrays become lists)."""
    if isinstance(value, array.array | tuple):
        return list(value)
    return value


def _ros_value(value: Any) -> Any:
    """A pfield parameter value as a value rclpy can type, or raise TypeError."""
    if isinstance(value, tuple):
        value = list(value)
    Parameter.Type.from_parameter_value(value)
    return value


def _descriptor(name: str, value: Any, row: Mapping[str, Any] | None) -> ParameterDescriptor:
    """The rclpy descriptor of a parameter from its row of the node's table (``ros2 param describe``): the
    description, the read-only flag and the range (or choices) as ``additional_constraints``. The range is
    not set as rclpy's ``floating_point_range``: the pfield node stays the one validator, so a refused value
    gets the node's reason (``max_linear_velocity=-2.0: must be > 0``), here and over HTTP alike."""
    # A None or empty-list default gives rclpy no type to enforce: let the pfield node judge.
    untyped = value is None or value == []
    if row is None:
        return ParameterDescriptor(name=name, description="pfield parameter (validated by the node)",
                                   dynamic_typing=untyped)
    constraints = ""
    value_range = row.get("range")
    if value_range and row["type"] == "string":
        constraints = "one of: " + ", ".join(str(v) for v in value_range)
    elif value_range:
        unit = f" {row['unit']}" if row.get("unit") else ""
        constraints = f"range [{value_range[0]:g}, {value_range[1]:g}]{unit}"
    return ParameterDescriptor(name=name, description=str(row["description"]), read_only=bool(row["read_only"]),
                               additional_constraints=constraints, dynamic_typing=untyped)


def declare_parameters(ros_node: RclpyNode, node: Node) -> list[str]:
    """Declare ``node``'s parameters on ``ros_node`` and install the validation callbacks.

    Values given on the rclpy command line (``--ros-args -p name:=value`` or ``--params-file``) override
    the node's current ones and are applied through ``node.set_parameters``; a bad one (or one of another
    type, ``9`` for a double) raises ``InvalidInput`` here, before the node serves anything. Returns the
    declared names.
    """
    current = node.get_parameters()
    rows = node.describe_parameters()
    declared: list[str] = []
    for name, value in current.items():
        try:
            ros_value = _ros_value(value)
        except TypeError:  # a mapping (static_transforms): set from the YAML or the command line, not over ROS 2
            _LOG.info("parameter %s has no ROS parameter type: not exposed over ROS 2 (set it in the --params YAML "
                      "or with its command-line option)", name)
            continue
        try:
            ros_node.declare_parameter(name, ros_value, _descriptor(name, ros_value, rows.get(name)))
        except InvalidParameterTypeException as error:  # a --ros-args/--params-file value of another type
            raise InvalidInput(name, ros_value, f"the ROS argument for it has the wrong type: {error}") from None
        declared.append(name)
    given = {name: _plain(ros_node.get_parameter(name).value) for name in declared}
    overrides = {name: value for name, value in given.items() if value != _plain(current[name])}
    if overrides:
        node.set_parameters(overrides)
    names = frozenset(declared)
    ros_node.add_pre_set_parameters_callback(lambda parameters: _widen(ros_node, parameters))
    ros_node.add_on_set_parameters_callback(lambda parameters: _validate(node, names, parameters))
    return declared


def _widen(ros_node: RclpyNode, parameters: list[Parameter]) -> list[Parameter]:
    """Integers for double parameters become doubles (pre-set callback; may rewrite the list)."""
    widened = []
    for parameter in parameters:
        declared_type = ros_node.get_parameter(parameter.name).type_ if ros_node.has_parameter(parameter.name) else None
        if declared_type == Parameter.Type.DOUBLE and parameter.type_ == Parameter.Type.INTEGER:
            parameter = Parameter(parameter.name, Parameter.Type.DOUBLE, _as_double(parameter.value))
        elif declared_type == Parameter.Type.DOUBLE_ARRAY and parameter.type_ == Parameter.Type.INTEGER_ARRAY:
            parameter = Parameter(parameter.name, Parameter.Type.DOUBLE_ARRAY, [_as_double(v) for v in parameter.value])
        widened.append(parameter)
    return widened


def _as_double(value: int) -> float:
    """``value`` as a double; beyond a double's range (about ±1.8e308) ±inf, which the node refuses. The
    pre-set callback must not raise: its exception would escape ``set_parameters`` instead of a refusal."""
    try:
        return float(value)
    except OverflowError:
        return math.inf if value > 0 else -math.inf


def _validate(node: Node, names: frozenset[str], parameters: list[Parameter]) -> SetParametersResult:
    """On-set callback: the pfield node validates and applies the values, or refuses with a reason."""
    values: Mapping[str, Any] = {p.name: _plain(p.value) for p in parameters if p.name in names}
    if not values:
        return SetParametersResult(successful=True)
    try:
        node.set_parameters(values)
    except (PfieldError, ValidationError, ValueError, TypeError) as error:
        _LOG.warning("%s: refused parameters %s: %s", node.name, sorted(values), error)
        return SetParametersResult(successful=False, reason=str(error))
    return SetParametersResult(successful=True)
