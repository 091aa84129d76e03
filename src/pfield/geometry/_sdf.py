"""Compiled signed-distance kernels over :class:`~pfield.geometry._packed.PackedObstacles`.

Every compiled consumer (field, planners, collision checks) calls :func:`obstacle_signed_distance`,
:func:`obstacle_signed_distance_within` or :func:`min_signed_distance`. They are inlined into the
caller, allocate nothing on the heap (the mesh query keeps its traversal stack on the call stack) and,
for primitives, do no reference counting. Python code calls :func:`pfield.geometry.signed_distances`, which
runs the compiled core's port of these kernels (``src/core/geometry``, the same bits) until the consumers
above move to the core too.

Conventions
-----------
``d`` is the exact Euclidean signed distance in metres, negative inside. The normal is the unit
gradient ∇d in the world frame: outside it points from the closest surface point to ``p``, inside it
is the outward surface normal at the closest surface point. Where ∇d is undefined (the medial axis:
several closest points) the normal is chosen by this deterministic rule, in the obstacle's local frame:

* among equally near faces the lower axis wins (x before y before z), and the + side wins when the
  coordinate is exactly 0 (``sign(0) = +1``);
* a point with no preferred direction (sphere centre) gets local +z; a point on a cylinder's or capsule's
  axis whose closest points form a circle gets local +x;
* a cylinder point equally near the cap and the side wall gets the cap normal (±z);
* ellipsoid points on a symmetry plane with mirror-image closest points take the + side;
* meshes: the first closest triangle in BVH traversal order (see :mod:`._bvh`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import carray, njit

from pfield.geometry._bvh import mesh_signed_distance_at
from pfield.geometry._ellipsoid import ellipsoid_signed_distance
from pfield.geometry._packed import (
    BOX,
    CAPSULE,
    CYLINDER,
    ELLIPSOID,
    MESH,
    ROW_WIDTH,
    SPHERE,
    PackedObstacles,
)
from pfield.geometry._raw import float_pointer, int_pointer

_MeshAddresses = tuple[int, int, int, int, int, int, int, int, int]
"""Addresses of triangles, pseudo-normals, BVH lower, upper, nodes, mesh table; triangle, node, mesh counts
(all int64 in compiled code, :func:`mesh_addresses`)."""

__all__ = [
    "empty_packed",
    "mesh_addresses",
    "min_signed_distance",
    "obstacle_signed_distance",
    "obstacle_signed_distance_within",
    "primitive_local",
    "row_signed_distance",
]


@njit(cache=True)
def _sign(x: float) -> float:
    return 1.0 if x >= 0.0 else -1.0


@njit(cache=True)
def sphere_local(qx: float, qy: float, qz: float, r: float) -> tuple[float, float, float, float]:
    """Sphere of radius r: d = ‖q‖ − r, n = q/‖q‖ (local +z at the centre)."""
    norm = math.sqrt(qx * qx + qy * qy + qz * qz)
    if norm == 0.0:
        return -r, 0.0, 0.0, 1.0
    return norm - r, qx / norm, qy / norm, qz / norm


@njit(cache=True)
def box_local(
    qx: float, qy: float, qz: float, hx: float, hy: float, hz: float
) -> tuple[float, float, float, float]:
    """Box with half extents h: with e = |q| − h, d = ‖max(e, 0)‖ outside, max_i e_i inside.

    (Quílez's box SDF; exact.) Outside, n = sign(q)∘max(e, 0)/d; inside, n = sign(q_k) e_k for the
    axis k of the largest e_k (lowest index on ties).
    """
    ex, ey, ez = abs(qx) - hx, abs(qy) - hy, abs(qz) - hz
    if ex > 0.0 or ey > 0.0 or ez > 0.0:
        ox, oy, oz = max(ex, 0.0), max(ey, 0.0), max(ez, 0.0)
        d = math.sqrt(ox * ox + oy * oy + oz * oz)
        return d, _sign(qx) * ox / d, _sign(qy) * oy / d, _sign(qz) * oz / d
    if ex >= ey and ex >= ez:
        return ex, _sign(qx), 0.0, 0.0
    if ey >= ez:
        return ey, 0.0, _sign(qy), 0.0
    return ez, 0.0, 0.0, _sign(qz)


@njit(cache=True)
def _radial(qx: float, qy: float) -> tuple[float, float, float]:
    """ρ = ‖(qx, qy)‖ and the radial unit vector (local +x on the axis)."""
    rho = math.sqrt(qx * qx + qy * qy)
    if rho == 0.0:
        return 0.0, 1.0, 0.0
    return rho, qx / rho, qy / rho


@njit(cache=True)
def cylinder_local(qx: float, qy: float, qz: float, r: float, hh: float) -> tuple[float, float, float, float]:
    """Cylinder of radius r, half height hh along z: e = (ρ − r, |z| − hh), as a 2D box in (ρ, z)."""
    rho, ux, uy = _radial(qx, qy)
    er, ez = rho - r, abs(qz) - hh
    sz = _sign(qz)
    if er > 0.0 and ez > 0.0:
        d = math.sqrt(er * er + ez * ez)
        return d, ux * er / d, uy * er / d, sz * ez / d
    if er > 0.0:
        return er, ux, uy, 0.0
    if ez > 0.0 or ez >= er:
        return ez, 0.0, 0.0, sz
    return er, ux, uy, 0.0


@njit(cache=True)
def capsule_local(qx: float, qy: float, qz: float, r: float, hh: float) -> tuple[float, float, float, float]:
    """Capsule: distance to the segment z ∈ [−hh, hh] on the local z axis minus r."""
    cz = min(max(qz, -hh), hh)
    vz = qz - cz
    norm = math.sqrt(qx * qx + qy * qy + vz * vz)
    if norm == 0.0:
        return -r, 1.0, 0.0, 0.0
    return norm - r, qx / norm, qy / norm, vz / norm


@njit(cache=True, inline="always")
def mesh_addresses(packed: PackedObstacles) -> _MeshAddresses:
    """Addresses and sizes of the mesh arrays, so the mesh branch passes no reference-counted arrays.

    All nine are int64, the type Python integers take when such a tuple comes back into compiled code (a test
    or tool calling a consumer from Python): one specialisation of each consumer, whoever calls it."""
    return (  # type: ignore[return-value]  # np.int64 is numba's int64 here, a Python int outside
        np.int64(packed.triangles.ctypes.data), np.int64(packed.pseudo_normals.ctypes.data),
        np.int64(packed.bvh_lower.ctypes.data), np.int64(packed.bvh_upper.ctypes.data),
        np.int64(packed.bvh_nodes.ctypes.data), np.int64(packed.mesh_table.ctypes.data),
        packed.triangles.shape[0], packed.bvh_nodes.shape[0], packed.mesh_table.shape[0],
    )


@njit(cache=True)
def _mesh_local(
    meshes: _MeshAddresses, m: int, qx: float, qy: float, qz: float,
    cutoff: float,
) -> tuple[float, float, float, float]:
    if not 0 <= m < meshes[8]:  # a hand-built, inconsistent PackedObstacles: no memory access
        return math.nan, math.nan, math.nan, math.nan
    table = carray(int_pointer(meshes[5]), (meshes[8], 5))
    if cutoff < math.inf:
        root = table[m, 0]
        lower = carray(float_pointer(meshes[2] + 24 * root), (3,))
        upper = carray(float_pointer(meshes[3] + 24 * root), (3,))
        gx = qx - min(max(qx, lower[0]), upper[0])
        gy = qy - min(max(qy, lower[1]), upper[1])
        gz = qz - min(max(qz, lower[2]), upper[2])
        gap = math.sqrt(gx * gx + gy * gy + gz * gz)
        if gap > cutoff:  # outside the mesh's bounding box by more than the cutoff
            return gap, gx / gap, gy / gap, gz / gap
    return mesh_signed_distance_at(
        meshes[0], meshes[1], meshes[2], meshes[3], meshes[4], meshes[6], meshes[7],
        table[m, 0], table[m, 4] != 0, qx, qy, qz,
    )


@njit(cache=True, inline="always")
def row_signed_distance(
    kinds: np.ndarray, rows: np.ndarray, meshes: _MeshAddresses,
    i: int, px: float, py: float, pz: float, cutoff: float,
) -> tuple[float, float, float, float]:
    """:func:`obstacle_signed_distance_within` of the point (px, py, pz) from the packed arrays themselves
    (``kinds``, ``rows`` and :func:`mesh_addresses`), for loops that hoist them: each member read of a
    :class:`PackedObstacles` inside a compiled loop costs a reference-count update."""
    # The row is read in one block so numba can prune its reference counting in callers' loops.
    cx, cy, cz = rows[i, 0], rows[i, 1], rows[i, 2]
    r00, r01, r02 = rows[i, 3], rows[i, 4], rows[i, 5]
    r10, r11, r12 = rows[i, 6], rows[i, 7], rows[i, 8]
    r20, r21, r22 = rows[i, 9], rows[i, 10], rows[i, 11]
    s0, s1, s2, mesh = rows[i, 12], rows[i, 13], rows[i, 14], rows[i, 15]
    kind = kinds[i]
    dx, dy, dz = px - cx, py - cy, pz - cz
    if kind == SPHERE:
        norm = math.sqrt(dx * dx + dy * dy + dz * dz)
        if norm > 0.0:
            return norm - s0, dx / norm, dy / norm, dz / norm
    qx = r00 * dx + r10 * dy + r20 * dz
    qy = r01 * dx + r11 * dy + r21 * dz
    qz = r02 * dx + r12 * dy + r22 * dz
    if kind == MESH:
        d, lx, ly, lz = _mesh_local(meshes, int(mesh), qx, qy, qz, cutoff)
    else:
        d, lx, ly, lz = primitive_local(kind, qx, qy, qz, s0, s1, s2, cutoff)
    return d, r00 * lx + r01 * ly + r02 * lz, r10 * lx + r11 * ly + r12 * lz, r20 * lx + r21 * ly + r22 * lz


@njit(cache=True, inline="always")
def primitive_local(kind: int, qx: float, qy: float, qz: float, s0: float, s1: float, s2: float,
                    cutoff: float) -> tuple[float, float, float, float]:
    """Signed distance and local normal of the obstacle-frame point q to a primitive (not a mesh) of packed
    sizes ``s0..s2`` (:func:`obstacle_signed_distance_within`'s cutoff rule)."""
    if kind == BOX:
        return box_local(qx, qy, qz, s0, s1, s2)
    if kind == CYLINDER:
        return cylinder_local(qx, qy, qz, s0, s1)
    if kind == CAPSULE:
        return capsule_local(qx, qy, qz, s0, s1)
    if kind == ELLIPSOID:
        # the bounding sphere's distance is a lower bound of the ellipsoid's: exact only within the cutoff
        d, lx, ly, lz = sphere_local(qx, qy, qz, max(s0, s1, s2))
        if d <= cutoff:
            return ellipsoid_signed_distance(qx, qy, qz, s0, s1, s2)
        return d, lx, ly, lz
    return sphere_local(qx, qy, qz, s0)


@njit(cache=True, inline="always")
def obstacle_signed_distance(packed: PackedObstacles, i: int, p: np.ndarray) -> tuple[float, float, float, float]:
    """Exact signed distance ``d`` (m, negative inside) of world point ``p`` (3,) to obstacle ``i``,
    and the unit outward normal ``n = ∇d`` in the world frame: ``(d, nx, ny, nz)``.

    The point is taken into the obstacle frame, ``q = Rᵀ(p − c)``, the local kernel runs there, and
    the normal is rotated back, ``n = R n_local`` (distances are invariant under rigid motion).
    Inlined into the caller (numba ``inline="always"``), allocation- and reference-count-free for
    primitives: about 3 ns for a sphere inside a compiled loop.
    """
    return row_signed_distance(packed.kinds, packed.rows, mesh_addresses(packed), i, p[0], p[1], p[2], math.inf)


@njit(cache=True, inline="always")
def obstacle_signed_distance_within(
    packed: PackedObstacles, i: int, p: np.ndarray, cutoff: float
) -> tuple[float, float, float, float]:
    """:func:`obstacle_signed_distance`, exact whenever ``d ≤ cutoff``; beyond, possibly a cheaper bound.

    When the true distance exceeds ``cutoff`` (m) the result may instead be a lower bound ``d'`` with
    ``cutoff < d' ≤ d`` and a unit normal pointing away from the obstacle (ellipsoids: the distance to
    their bounding sphere; meshes: to their bounding box). Consumers that ignore obstacles beyond an
    influence distance (Khatib repulsion) get identical results, faster.
    """
    return row_signed_distance(packed.kinds, packed.rows, mesh_addresses(packed), i, p[0], p[1], p[2], cutoff)


@njit(cache=True, inline="always")
def min_signed_distance(packed: PackedObstacles, p: np.ndarray) -> tuple[float, float, float, float, int]:
    """Smallest signed distance over all obstacles: ``(d, nx, ny, nz, index)``.

    Ties go to the lowest index; with no obstacles the answer is ``(inf, 0, 0, 0, −1)``.
    """
    kinds, rows, meshes = packed.kinds, packed.rows, mesh_addresses(packed)
    px, py, pz = p[0], p[1], p[2]
    best, bx, by, bz, best_i = math.inf, 0.0, 0.0, 0.0, -1
    for i in range(kinds.shape[0]):
        # Cutoff = best so far: an obstacle that cannot beat it may return a cheap bound (> best).
        d, nx, ny, nz = row_signed_distance(kinds, rows, meshes, i, px, py, pz, best)
        if d < best:
            best, bx, by, bz, best_i = d, nx, ny, nz, i
    return best, bx, by, bz, best_i


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
