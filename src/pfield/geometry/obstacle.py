"""Obstacles (an id, a shape, a pose and a group) and their packing for compiled kernels.

An :class:`Obstacle` places a shape in the world: a point ``q`` of the shape's local frame is at
``p = R(orientation) q + position``. Obstacle ids are the seed's ``frame_id`` (unique ids, not TF frames).
:func:`pack_obstacles` turns a sequence of obstacles into one
:class:`~pfield.geometry.packed.PackedObstacles` that the compiled core reads in place
(:func:`~pfield.geometry.signed_distances`, the field, the planners); pack once and reuse it.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, TypeAlias, get_args

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pfield.errors import InvalidInput
from pfield.geometry._distances import signed_distances
from pfield.geometry.mesh import Mesh, MeshData
from pfield.geometry.packed import ROW_WIDTH, SHAPE_CODES, PackedObstacles, empty_packed
from pfield.geometry.shapes import Box, Capsule, Cylinder, Ellipsoid, Sphere
from pfield.spatial import Pose

__all__ = ["GROUPS", "SHAPE_TYPES", "Obstacle", "Shape", "pack_obstacles"]

Shape: TypeAlias = Sphere | Box | Cylinder | Ellipsoid | Capsule | Mesh
"""The obstacle shapes. A new kind joins here; tests/test_every_shape.py then names every consumer to teach it."""
_SHAPE_CLASSES: tuple[type, ...] = get_args(Shape)
SHAPE_TYPES = tuple(kind.__name__ for kind in _SHAPE_CLASSES)
"""The shapes' type names, as the seed's Obstacle message spells them."""
GROUPS = ("Static", "Dynamic", "Robot")


@dataclass(frozen=True)
class Obstacle:
    """A shape at a world pose: ``Obstacle("ball", Sphere(radius=0.1), Pose(position=(0.4, 0, 0.1)))``.

    ``id`` is a non-empty unique name (the message's ``frame_id``); ``group`` is ``"Static"``,
    ``"Dynamic"`` or ``"Robot"``. Mesh shapes arrive loaded (see :class:`~pfield.geometry.mesh.Mesh`).
    """

    id: str
    shape: Shape
    pose: Pose
    group: str = "Static"

    def __post_init__(self) -> None:
        if not isinstance(self.id, str) or not self.id:
            raise InvalidInput("id", self.id, "every obstacle needs a non-empty unique id")
        if not isinstance(self.shape, _SHAPE_CLASSES):
            raise InvalidInput("type", type(self.shape).__name__, f"unknown shape; expected one of {SHAPE_TYPES}")
        if not isinstance(self.pose, Pose):
            raise InvalidInput("pose", self.pose, "expected a pfield.Pose")
        if self.group not in GROUPS:
            raise InvalidInput("group", self.group, f"unknown group; expected one of {', '.join(GROUPS)}")

    @property
    def type(self) -> str:
        """The seed's shape type name (``"Sphere"`` … ``"Mesh"``)."""
        return self.shape.type_name

    @functools.cached_property
    def packed(self) -> PackedObstacles:
        """This obstacle alone, packed (built on first use)."""
        return pack_obstacles([self])

    def signed_distance(self, points: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Signed distance ``d`` (N,) in m, negative inside, and unit outward normals ``n = ∇d`` (N, 3).

        ``points`` is (N, 3) or one (3,) point in the world frame (then N = 1). Exact for every shape;
        see ``docs/geometry.md`` for the normal on ties (medial axis).
        """
        distances, normals = signed_distances(self.packed, points)
        return distances[:, 0], normals[:, 0, :]

    def bounding_radius(self) -> float:
        """Radius (m) of a sphere about ``pose.position`` containing the whole obstacle."""
        return self.shape.bounding_radius()


def _mesh_arrays(meshes: list[MeshData]) -> tuple[NDArray[Any], ...]:
    """Concatenate prepared meshes, offsetting BVH child and triangle indices to global ones."""
    node_offsets = np.cumsum([0] + [len(m.bvh_nodes) for m in meshes])
    triangle_offsets = np.cumsum([0] + [len(m.triangles) for m in meshes])
    nodes = []
    for mesh, node_offset, triangle_offset in zip(meshes, node_offsets, triangle_offsets, strict=False):
        shifted = np.array(mesh.bvh_nodes)
        leaf = shifted[:, 2] == 1
        shifted[leaf, 0] += triangle_offset
        shifted[~leaf, :2] += node_offset
        nodes.append(shifted)
    table = np.array([[node_offsets[k], len(m.bvh_nodes), triangle_offsets[k], len(m.triangles), int(m.watertight)]
                      for k, m in enumerate(meshes)], dtype=np.int64).reshape(-1, 5)
    return (
        np.concatenate([m.triangles for m in meshes]),
        np.concatenate([m.normals for m in meshes]),
        np.concatenate([m.bvh_lower for m in meshes]),
        np.concatenate([m.bvh_upper for m in meshes]),
        np.concatenate(nodes).astype(np.int64),
        table,
    )


def pack_obstacles(obstacles: Sequence[Obstacle]) -> PackedObstacles:
    """Pack obstacles (in order: index i is ``obstacles[i]``) into arrays for the compiled kernels.

    Rows hold the position, the row-major rotation matrix (local → world), the packed sizes and the
    mesh index (see :mod:`pfield.geometry.packed`); obstacles sharing one :class:`Mesh` share its arrays.
    """
    rows = np.zeros((len(obstacles), ROW_WIDTH))
    kinds = np.zeros(len(obstacles), dtype=np.int64)
    meshes: list[MeshData] = []
    mesh_index: dict[int, int] = {}
    for i, obstacle in enumerate(obstacles):
        if not isinstance(obstacle, Obstacle):
            raise InvalidInput(f"obstacles[{i}]", type(obstacle).__name__, "expected a pfield.Obstacle")
        shape = obstacle.shape
        kinds[i] = SHAPE_CODES[shape.type_name]
        rows[i, 0:3] = obstacle.pose.position
        rows[i, 3:12] = obstacle.pose.rotation.reshape(-1)
        rows[i, 12:15] = shape.packed_sizes()
        rows[i, 15] = -1.0
        if isinstance(shape, Mesh):
            key = id(shape.data)
            if key not in mesh_index:
                mesh_index[key] = len(meshes)
                meshes.append(shape.data)
            rows[i, 15] = float(mesh_index[key])
    empty = empty_packed()
    if not meshes:
        return empty._replace(kinds=kinds, rows=rows)
    triangles, normals, lower, upper, nodes, table = _mesh_arrays(meshes)
    return PackedObstacles(kinds, rows, triangles, normals, lower, upper, nodes, table)
