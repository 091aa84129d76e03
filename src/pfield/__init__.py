"""pfield: potential-field motion planning and shared control."""

__version__ = "0.1.0"

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
from pfield.spatial import Pose, Twist, Wrench

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


def __getattr__(name: str) -> object:
    # RobotModel imports pinocchio (~0.3 s): load it on first use, not at ``import pfield``.
    if name == "RobotModel":
        from pfield.robot import RobotModel

        return RobotModel
    raise AttributeError(f"module 'pfield' has no attribute {name!r}")
