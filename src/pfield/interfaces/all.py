"""Import every interface module so :func:`~pfield.interfaces.lookup_type` knows all pfield types."""

from __future__ import annotations

import importlib
import logging

from pfield.interfaces import (
    control_msgs,
    geometry_msgs,
    nav_msgs,
    potential_fields_interfaces,
    std_msgs,
    std_srvs,
    trajectory_msgs,
    visualization_msgs,
)

_log = logging.getLogger(__name__)

try:  # sensor_msgs (LaserScan, JointState, Joy: the mobile base, joint states, joysticks); absent in a partial install
    sensor_msgs = importlib.import_module("pfield.interfaces.sensor_msgs")
except ModuleNotFoundError as _exc:  # pragma: no cover - only when the module is missing
    if _exc.name != "pfield.interfaces.sensor_msgs":
        raise
    _log.debug("pfield.interfaces.sensor_msgs not available")

__all__ = [
    "control_msgs",
    "geometry_msgs",
    "nav_msgs",
    "potential_fields_interfaces",
    "std_msgs",
    "std_srvs",
    "trajectory_msgs",
    "visualization_msgs",
]
