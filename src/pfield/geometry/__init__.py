"""Obstacle geometry: shapes, obstacles, mesh resources and exact signed distances.

Public API (see ``docs/geometry.md``)::

    from pfield.geometry import Obstacle, Sphere, Box, Cylinder, Ellipsoid, Capsule, Mesh, ResourceResolver
    obstacle = Obstacle("ball", Sphere(radius=0.1), Pose(position=(0.4, 0, 0.1)))
    d, n = obstacle.signed_distance(points)          # (N,), (N, 3)
    packed = pack_obstacles([obstacle, ...])          # for the compiled core

The compiled core (``src/core/geometry``) computes every signed distance: :func:`signed_distances` for many points
and all obstacles of a :class:`PackedObstacles` at once; :func:`obstacle_signed_distance`,
:func:`obstacle_signed_distance_within` and :func:`min_signed_distance` for one point, with the same bits.
"""

from pfield.geometry._distances import (
    distances,
    min_signed_distance,
    nearest_distances,
    obstacle_signed_distance,
    obstacle_signed_distance_within,
    signed_distances,
)
from pfield.geometry.mesh import Mesh, MeshData, load_mesh_arrays, read_mesh_file
from pfield.geometry.obstacle import GROUPS, SHAPE_TYPES, Obstacle, Shape, pack_obstacles
from pfield.geometry.packed import PackedObstacles, empty_packed
from pfield.geometry.resources import ResourceResolver
from pfield.geometry.shapes import Box, Capsule, Cylinder, Ellipsoid, Sphere

__all__ = [
    "GROUPS",
    "SHAPE_TYPES",
    "Box",
    "Capsule",
    "Cylinder",
    "Ellipsoid",
    "Mesh",
    "MeshData",
    "Obstacle",
    "PackedObstacles",
    "ResourceResolver",
    "Shape",
    "Sphere",
    "distances",
    "empty_packed",
    "load_mesh_arrays",
    "min_signed_distance",
    "nearest_distances",
    "obstacle_signed_distance",
    "obstacle_signed_distance_within",
    "pack_obstacles",
    "read_mesh_file",
    "signed_distances",
]
