"""pfield: potential-field motion planning and shared control."""

__version__ = "0.1.0"

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

__all__ = [
    "Box",
    "Capsule",
    "Cylinder",
    "Ellipsoid",
    "Mesh",
    "Obstacle",
    "ResourceResolver",
    "Sphere",
    "pack_obstacles",
]
