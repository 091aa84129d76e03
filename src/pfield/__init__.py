"""pfield: potential-field motion planning and shared control."""

__version__ = "0.1.0"

from pfield.field import FieldConfig, PotentialField
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
from pfield.planning import PlannedPath

__all__ = [
    "Box",
    "Capsule",
    "Cylinder",
    "Ellipsoid",
    "FieldConfig",
    "Mesh",
    "Obstacle",
    "PlannedPath",
    "PotentialField",
    "ResourceResolver",
    "Sphere",
    "pack_obstacles",
]
