"""Obstacle geometry: shapes, obstacles, mesh resources and exact signed distances.

Public API (see ``docs/geometry.md``)::

    from pfield.geometry import Obstacle, Sphere, Box, Cylinder, Ellipsoid, Capsule, Mesh, ResourceResolver
    obstacle = Obstacle("ball", Sphere(radius=0.1), Pose(position=(0.4, 0, 0.1)))
    d, n = obstacle.signed_distance(points)          # (N,), (N, 3)
    packed = pack_obstacles([obstacle, ...])          # for compiled consumers

Python code calls :func:`signed_distances` (the compiled core, ``src/core/geometry``); numba consumers call
:func:`obstacle_signed_distance` or :func:`min_signed_distance` (numba kernels, the same bits) on a
:class:`PackedObstacles`.
"""

from pfield.geometry._distances import signed_distances
from pfield.geometry._packed import PackedObstacles
from pfield.geometry._sdf import (
    empty_packed,
    min_signed_distance,
    obstacle_signed_distance,
    obstacle_signed_distance_within,
)
from pfield.geometry.mesh import Mesh, MeshData, load_mesh_arrays, read_mesh_file
from pfield.geometry.obstacle import GROUPS, SHAPE_TYPES, Obstacle, Shape, pack_obstacles
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
    "empty_packed",
    "load_mesh_arrays",
    "min_signed_distance",
    "obstacle_signed_distance",
    "obstacle_signed_distance_within",
    "pack_obstacles",
    "read_mesh_file",
    "signed_distances",
]
