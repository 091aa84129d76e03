"""pfield: potential-field motion planning and shared control.

The names below load on first use (PEP 562): ``import pfield`` costs a few milliseconds, so the CLI's node
commands (``pfield topic``, ``pfield service`` …), which need none of them, start without numpy, and
``RobotModel`` brings pinocchio (~0.3 s) only when asked for.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from pfield._lazy import lazy_exports

__version__ = "0.1.0"

_HOMES = {
    "pfield.errors": ("InvalidInput", "PfieldError", "PlanningFailed", "ResourceNotAllowed", "ResourceNotFound",
                      "UnknownFrame"),
    "pfield.field": ("FieldConfig", "PotentialField", "PreparedTwist"),
    "pfield.geometry": ("Box", "Capsule", "Cylinder", "Ellipsoid", "Mesh", "Obstacle", "ResourceResolver", "Sphere",
                        "pack_obstacles"),
    "pfield.planning": ("CancelToken", "PlannedPath", "PlanOptions", "PlanStatus"),
    "pfield.robot": ("RobotModel",),
    "pfield.spatial": ("Pose", "Twist", "Wrench"),
}
_HOME_OF = {name: module for module, names in _HOMES.items() for name in names}

__all__ = [
    "Box",
    "CancelToken",
    "Capsule",
    "Cylinder",
    "Ellipsoid",
    "FieldConfig",
    "InvalidInput",
    "Mesh",
    "Obstacle",
    "PfieldError",
    "PlanOptions",
    "PlanStatus",
    "PlannedPath",
    "PlanningFailed",
    "Pose",
    "PotentialField",
    "PreparedTwist",
    "ResourceNotAllowed",
    "ResourceNotFound",
    "ResourceResolver",
    "RobotModel",
    "Sphere",
    "Twist",
    "UnknownFrame",
    "Wrench",
    "pack_obstacles",
]

if TYPE_CHECKING:
    from pfield.errors import (
        InvalidInput,
        PfieldError,
        PlanningFailed,
        ResourceNotAllowed,
        ResourceNotFound,
        UnknownFrame,
    )
    from pfield.field import FieldConfig, PotentialField, PreparedTwist
    from pfield.geometry import (
        Box,
        Capsule,
        Cylinder,
        Ellipsoid,
        Mesh,
        Obstacle,
        ResourceResolver,
        Sphere,
        pack_obstacles,
    )
    from pfield.planning import CancelToken, PlannedPath, PlanOptions, PlanStatus
    from pfield.robot import RobotModel
    from pfield.spatial import Pose, Twist, Wrench


__getattr__, __dir__ = lazy_exports(__name__, _HOME_OF, globals())
