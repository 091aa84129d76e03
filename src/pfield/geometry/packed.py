"""Packed, array-only representation of an obstacle set for compiled kernels.

This is the contract between :mod:`pfield.geometry` (which builds it) and every compiled consumer
(the field, whole-body planning, collision checks). One :class:`PackedObstacles` holds M obstacles:

* ``kinds[i]`` — shape code (``SPHERE`` … ``MESH`` below: the core's ``Kind``, ``src/core/geometry/packed.hpp``,
  their one definition; the core refuses any other code with a ``ValueError``);
* ``rows[i]`` — ``ROW_WIDTH`` float64: ``[0:3]`` world position of the shape centre, ``[3:12]`` the
  row-major rotation matrix (local → world), ``[12:15]`` the shape sizes in the local frame, ``[15]``
  the mesh index (−1 for primitives). Sizes: Sphere ``(r, 0, 0)``; Box ``(hx, hy, hz)`` half extents;
  Cylinder ``(r, h/2, 0)``; Ellipsoid ``(a, b, c)`` semi-axes; Capsule ``(r, h/2, 0)`` (half shaft
  length); Mesh ``(sx, sy, sz)`` scale (already applied to the stored triangles);
* mesh arrays (all meshes concatenated; empty arrays when there are none): triangle vertices in the
  obstacle's local, *scaled* frame, angle-weighted pseudo-normals for the sign, a BVH over triangles,
  and per-mesh offsets into them. BVH node and triangle indices are global (already offset), and each
  mesh's triangles are stored in its BVH leaf order. ``mesh_table[m, 4]`` is 1 when mesh ``m`` is
  watertight (signed distance) and 0 otherwise (unsigned distance).

Build it with :func:`pfield.geometry.pack_obstacles`; query it with :func:`pfield.geometry.signed_distances`
(the compiled core, ``src/core/geometry``, which reads these arrays in place). Treat the arrays as read-only.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from pfield._core.geometry import Kind

SHAPE_CODES: dict[str, int] = {kind.name: int(kind) for kind in Kind}
"""Shape type name (``Shape.type_name``) → code in ``kinds``."""
SPHERE, BOX, CYLINDER, ELLIPSOID, CAPSULE, MESH = (SHAPE_CODES[name] for name in
                                                   ("Sphere", "Box", "Cylinder", "Ellipsoid", "Capsule", "Mesh"))
ROW_WIDTH = 16


class PackedObstacles(NamedTuple):
    kinds: NDArray[np.int64]  # (M,)
    rows: NDArray[np.float64]  # (M, ROW_WIDTH)
    triangles: NDArray[np.float64]  # (T, 3, 3) vertices, local scaled frame
    pseudo_normals: NDArray[np.float64]  # (T, 7, 3): face, 3 edges, 3 vertices (Baerentzen & Aanaes 2005)
    bvh_lower: NDArray[np.float64]  # (K, 3) node AABB lower corners
    bvh_upper: NDArray[np.float64]  # (K, 3) node AABB upper corners
    bvh_nodes: NDArray[np.int64]  # (K, 3): [left child or first triangle, right child or count, is_leaf]
    mesh_table: NDArray[np.int64]  # (n_meshes, 5): [root node, node count, first triangle, triangle count, watertight]


def bounding_radius(packed: PackedObstacles, i: int) -> float:
    """Radius (m) of a sphere about obstacle i's centre (``rows[i, 0:3]``) that contains the whole shape.

    The signed distance at p is then at least ‖p − centre‖ − radius, which lets compiled consumers skip far
    obstacles exactly (the field's influence test, the whole-body link–obstacle culling).
    """
    kind = int(packed.kinds[i])
    s0, s1, s2 = (float(v) for v in packed.rows[i, 12:15])
    if kind == SPHERE:
        return s0
    if kind == BOX:
        return math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
    if kind == CYLINDER:
        return math.sqrt(s0 * s0 + s1 * s1)
    if kind == ELLIPSOID:
        return max(s0, s1, s2)
    if kind == CAPSULE:
        return s0 + s1
    if kind == MESH:
        first, length = (int(v) for v in packed.mesh_table[int(packed.rows[i, 15]), 2:4])
        vertices = packed.triangles[first:first + length].reshape(-1, 3)
        return float(np.max(np.linalg.norm(vertices, axis=1))) if length else 0.0
    raise ValueError(f"obstacle {i}: kind {kind} has no bounding radius (pfield.geometry.packed.bounding_radius)")


def empty_packed() -> PackedObstacles:
    """A :class:`PackedObstacles` with no obstacles and no meshes (same array types as a full one)."""
    return PackedObstacles(
        kinds=np.zeros(0, np.int64),
        rows=np.zeros((0, ROW_WIDTH)),
        triangles=np.zeros((0, 3, 3)),
        pseudo_normals=np.zeros((0, 7, 3)),
        bvh_lower=np.zeros((0, 3)),
        bvh_upper=np.zeros((0, 3)),
        bvh_nodes=np.zeros((0, 3), np.int64),
        mesh_table=np.zeros((0, 5), np.int64),
    )
