"""Compiled triangle-mesh distance: closest point on a triangle and a BVH query.

The query is exact: it returns the closest point over all triangles of one mesh, found by a
depth-first traversal of an axis-aligned bounding-box hierarchy (median split, built by
:func:`pfield.geometry._mesh_build.build_bvh`) that skips every node whose box lies farther than the best
triangle found so far (the box distance is a lower bound of every triangle distance inside it).
The nearer child is visited first, so the bound tightens early.

The sign comes from the angle-weighted pseudo-normal of the closest *feature* (face, edge or vertex)
of the closest triangle: a point ``p`` with closest point ``c`` is outside when ``(p − c)·n_feature ≥ 0``
(Bærentzen & Aanæs 2005, "Signed distance computation using the angle weighted pseudonormal",
IEEE TVCG 11(3)). This is exact for closed, consistently oriented (watertight) meshes.
"""

from __future__ import annotations

import math

import numpy as np
from numba import carray, njit

from pfield.geometry._raw import STACK_SIZE, float_pointer, int_pointer, stack_buffer

# Feature codes returned by closest_point_on_triangle; they index pseudo_normals[t, code].
FACE, EDGE_AB, EDGE_BC, EDGE_CA, VERTEX_A, VERTEX_B, VERTEX_C = 0, 1, 2, 3, 4, 5, 6
_ON_SURFACE = 1e-12


@njit(cache=True, inline="always")
def closest_point_on_triangle(
    triangles: np.ndarray, t: int, px: float, py: float, pz: float
) -> tuple[float, float, float, int]:
    """Closest point of triangle ``t`` to ``p`` and the feature it lies on (Ericson 2005, §5.1.5).

    Walks the Voronoi regions of the vertices, then the edges, then the face, using the barycentric
    tests of "Real-Time Collision Detection" §5.1.5. Returns ``(cx, cy, cz, feature)``.
    """
    ax, ay, az = triangles[t, 0, 0], triangles[t, 0, 1], triangles[t, 0, 2]
    abx, aby, abz = triangles[t, 1, 0] - ax, triangles[t, 1, 1] - ay, triangles[t, 1, 2] - az
    acx, acy, acz = triangles[t, 2, 0] - ax, triangles[t, 2, 1] - ay, triangles[t, 2, 2] - az
    apx, apy, apz = px - ax, py - ay, pz - az
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    if d1 <= 0.0 and d2 <= 0.0:
        return ax, ay, az, VERTEX_A
    bpx, bpy, bpz = apx - abx, apy - aby, apz - abz
    d3 = abx * bpx + aby * bpy + abz * bpz
    d4 = acx * bpx + acy * bpy + acz * bpz
    if d3 >= 0.0 and d4 <= d3:
        return ax + abx, ay + aby, az + abz, VERTEX_B
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        v = d1 / (d1 - d3)
        return ax + v * abx, ay + v * aby, az + v * abz, EDGE_AB
    cpx, cpy, cpz = apx - acx, apy - acy, apz - acz
    d5 = abx * cpx + aby * cpy + abz * cpz
    d6 = acx * cpx + acy * cpy + acz * cpz
    if d6 >= 0.0 and d5 <= d6:
        return ax + acx, ay + acy, az + acz, VERTEX_C
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        w = d2 / (d2 - d6)
        return ax + w * acx, ay + w * acy, az + w * acz, EDGE_CA
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        bx, by, bz = ax + abx, ay + aby, az + abz
        return bx + w * (acx - abx), by + w * (acy - aby), bz + w * (acz - abz), EDGE_BC
    denom = 1.0 / (va + vb + vc)
    v = vb * denom
    w = vc * denom
    return ax + v * abx + w * acx, ay + v * aby + w * acy, az + v * abz + w * acz, FACE


@njit(cache=True, inline="always")
def _box_distance_squared(lower: np.ndarray, upper: np.ndarray, k: int, px: float, py: float, pz: float) -> float:
    """Squared distance from ``p`` to the AABB of node ``k`` (0 inside): a lower bound for its triangles."""
    gx = max(lower[k, 0] - px, 0.0, px - upper[k, 0])
    gy = max(lower[k, 1] - py, 0.0, py - upper[k, 1])
    gz = max(lower[k, 2] - pz, 0.0, pz - upper[k, 2])
    return gx * gx + gy * gy + gz * gz


@njit(cache=True, inline="always")
def _leaf_closest(
    triangles: np.ndarray, first: int, count: int, px: float, py: float, pz: float,
    best: float, best_t: int, best_feature: int, cx: float, cy: float, cz: float,
) -> tuple[float, int, int, float, float, float]:
    for t in range(first, first + count):
        qx, qy, qz, feature = closest_point_on_triangle(triangles, t, px, py, pz)
        dist2 = (px - qx) ** 2 + (py - qy) ** 2 + (pz - qz) ** 2
        if dist2 < best:  # strict: the first triangle in traversal order wins ties
            best, best_t, best_feature, cx, cy, cz = dist2, t, feature, qx, qy, qz
    return best, best_t, best_feature, cx, cy, cz


@njit(cache=True)
def mesh_closest_point(
    triangles: np.ndarray, lower: np.ndarray, upper: np.ndarray, nodes: np.ndarray, root: int,
    px: float, py: float, pz: float,
) -> tuple[float, int, int, float, float, float]:
    """Exact closest point of the mesh whose BVH root is ``root``: ``(dist², triangle, feature, c)``.

    ``nodes[k] = (left child | first triangle, right child | triangle count, is_leaf)``; children and
    triangles use global indices. Traversal is iterative with a fixed-size stack on the call stack (a
    median split tree has depth ⌈log₂ T⌉ and the stack holds at most one entry per level plus one).
    """
    stack = carray(stack_buffer(), (STACK_SIZE,))
    stack[0] = root
    top = 1
    best, best_t, best_feature = math.inf, -1, FACE
    cx = cy = cz = 0.0
    while top > 0:
        top -= 1
        k = stack[top]
        if _box_distance_squared(lower, upper, k, px, py, pz) >= best:
            continue
        if nodes[k, 2] == 1:
            best, best_t, best_feature, cx, cy, cz = _leaf_closest(
                triangles, nodes[k, 0], nodes[k, 1], px, py, pz, best, best_t, best_feature, cx, cy, cz
            )
            continue
        left, right = nodes[k, 0], nodes[k, 1]
        d_left = _box_distance_squared(lower, upper, left, px, py, pz)
        d_right = _box_distance_squared(lower, upper, right, px, py, pz)
        near, far, d_near, d_far = left, right, d_left, d_right
        if d_right < d_left:
            near, far, d_near, d_far = right, left, d_right, d_left
        if d_far < best:
            stack[top] = far
            top += 1
        if d_near < best:
            stack[top] = near
            top += 1
    return best, best_t, best_feature, cx, cy, cz


@njit(cache=True)
def mesh_signed_distance(
    triangles: np.ndarray, pseudo_normals: np.ndarray, lower: np.ndarray, upper: np.ndarray,
    nodes: np.ndarray, root: int, signed: bool, px: float, py: float, pz: float,
) -> tuple[float, float, float, float]:
    """Signed distance and its gradient for a point ``p`` in the mesh's local (scaled) frame.

    ``d = s·|p − c|`` with ``s = +1`` when ``(p − c)·n_feature ≥ 0`` (or the mesh is not watertight),
    else −1; the gradient is ``s·(p − c)/|p − c|``. On the surface (``|p − c| ≤ 1e-12`` m) the
    feature's pseudo-normal is returned as the normal.
    """
    dist2, t, feature, cx, cy, cz = mesh_closest_point(triangles, lower, upper, nodes, root, px, py, pz)
    nx, ny, nz = pseudo_normals[t, feature, 0], pseudo_normals[t, feature, 1], pseudo_normals[t, feature, 2]
    dist = math.sqrt(dist2)
    if dist <= _ON_SURFACE:
        return 0.0, nx, ny, nz
    vx, vy, vz = (px - cx) / dist, (py - cy) / dist, (pz - cz) / dist
    sign = 1.0
    if signed and vx * nx + vy * ny + vz * nz < 0.0:
        sign = -1.0
    return sign * dist, sign * vx, sign * vy, sign * vz


@njit(cache=True)
def mesh_signed_distance_at(
    triangles_address: int, pseudo_normals_address: int, lower_address: int, upper_address: int,
    nodes_address: int, n_triangles: int, n_nodes: int, root: int, signed: bool,
    px: float, py: float, pz: float,
) -> tuple[float, float, float, float]:
    """:func:`mesh_signed_distance` on arrays given by address (see :mod:`._raw` for why)."""
    return mesh_signed_distance(
        carray(float_pointer(triangles_address), (n_triangles, 3, 3)),
        carray(float_pointer(pseudo_normals_address), (n_triangles, 7, 3)),
        carray(float_pointer(lower_address), (n_nodes, 3)),
        carray(float_pointer(upper_address), (n_nodes, 3)),
        carray(int_pointer(nodes_address), (n_nodes, 3)),
        root, signed, px, py, pz,
    )
