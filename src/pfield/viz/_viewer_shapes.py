"""Triangle meshes of the obstacle shapes for the 3D viewer, and the viewer's colours.

Each shape is drawn as itself in its local frame (the obstacle pose places it): the sphere, box, cylinder
(along z), ellipsoid (a unit icosphere scaled by the semi-axes), capsule (shaft ``height`` along z plus two
hemispherical caps) and the mesh's own prepared, scaled vertices. An influence zone is the shape grown by
the influence distance Q on every side, where repulsion acts (Khatib 1986: the field is zero beyond Q); a
mesh's zone is its bounding sphere grown by Q, as in the node's RViz markers.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["GROUP_COLOURS", "PALETTE", "influence_mesh", "obstacle_colour", "shape_mesh"]

TriangleMesh = tuple[NDArray[np.float64], NDArray[np.int32]]
"""(V, 3) vertices in m (local frame) and (F, 3) vertex indices."""

PALETTE: tuple[tuple[int, int, int], ...] = (
    (31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40), (148, 103, 189),
    (140, 86, 75), (227, 119, 194), (188, 189, 34), (23, 190, 207), (127, 127, 127),
)
"""Obstacle colours (RGB 0–255, matplotlib's tab10), assigned in order of first appearance."""
GROUP_COLOURS = {"Static": (140, 140, 153), "Dynamic": (255, 140, 26), "Robot": (51, 115, 230)}
"""Influence-zone colours by obstacle group (the node's marker colours)."""


def obstacle_colour(index: int) -> tuple[int, int, int]:
    """The palette colour of the ``index``-th obstacle (cycling)."""
    return PALETTE[index % len(PALETTE)]


def _triangles(mesh: Any) -> TriangleMesh:
    return np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int32)


def _grown_shape_mesh(shape: Any, grow: float) -> TriangleMesh:
    import trimesh

    kind = type(shape).__name__
    if kind == "Sphere":
        return _triangles(trimesh.creation.icosphere(subdivisions=3, radius=shape.radius + grow))
    if kind == "Box":
        extents = (shape.length + 2 * grow, shape.width + 2 * grow, shape.height + 2 * grow)
        return _triangles(trimesh.creation.box(extents=extents))
    if kind == "Cylinder":
        return _triangles(trimesh.creation.cylinder(radius=shape.radius + grow, height=shape.height + 2 * grow,
                                                    sections=48))
    if kind == "Ellipsoid":
        vertices, faces = _triangles(trimesh.creation.icosphere(subdivisions=3, radius=1.0))
        semi_axes = np.array([shape.semi_x, shape.semi_y, shape.semi_z]) + grow
        return vertices * semi_axes, faces
    if kind == "Capsule":
        return _triangles(trimesh.creation.capsule(height=shape.height, radius=shape.radius + grow, count=(24, 24)))
    raise TypeError(f"no viewer mesh for shape {kind}")


def shape_mesh(shape: Any) -> TriangleMesh:
    """The triangle mesh of an obstacle shape in its local frame (a Mesh shape: its scaled vertices)."""
    if type(shape).__name__ == "Mesh":
        return np.asarray(shape.data.vertices, dtype=np.float64), np.asarray(shape.data.faces, dtype=np.int32)
    return _grown_shape_mesh(shape, 0.0)


def influence_mesh(shape: Any, influence_distance: float) -> TriangleMesh:
    """The shape grown by ``influence_distance`` (m); a mesh's bounding sphere grown by it."""
    if type(shape).__name__ == "Mesh":
        import trimesh

        radius = shape.bounding_radius() + influence_distance
        return _triangles(trimesh.creation.icosphere(subdivisions=3, radius=radius))
    return _grown_shape_mesh(shape, influence_distance)
