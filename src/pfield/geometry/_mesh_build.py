"""Preprocessing of triangle meshes for the compiled distance query (runs once per mesh, in numpy).

* :func:`pseudo_normals` — per triangle, the 7 angle-weighted pseudo-normals of its face, edges and
  vertices (Bærentzen & Aanæs 2005): a face uses its unit normal, an edge the normalised sum of its
  two faces' normals, a vertex the sum of its incident face normals weighted by the incident angles.
* :func:`build_bvh` — an axis-aligned bounding-box hierarchy: each node's triangles are split at the
  median centroid along the longest axis of their centroid bounds until at most ``leaf_size`` remain.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

LEAF_SIZE = 4


class Bvh(NamedTuple):
    """A BVH over ``T`` triangles, indices local to this mesh (root is node 0)."""

    order: NDArray[np.int64]  # (T,) triangle order: leaf ranges index triangles[order]
    lower: NDArray[np.float64]  # (K, 3)
    upper: NDArray[np.float64]  # (K, 3)
    nodes: NDArray[np.int64]  # (K, 3): [left | first, right | count, is_leaf]


def _unit(vectors: NDArray[np.float64]) -> NDArray[np.float64]:
    norms = np.linalg.norm(vectors, axis=-1, keepdims=True)
    return vectors / np.where(norms > 0.0, norms, 1.0)


def pseudo_normals(vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> NDArray[np.float64]:
    """``(F, 7, 3)``: unit normals of [face, edge ab, edge bc, edge ca, vertex a, vertex b, vertex c]."""
    corners = vertices[faces]  # (F, 3, 3)
    face_normals = _unit(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]))
    # Incident angle at each corner k between the edges to the other two corners.
    angles = np.empty((len(faces), 3))
    for k in range(3):
        u = _unit(corners[:, (k + 1) % 3] - corners[:, k])
        v = _unit(corners[:, (k + 2) % 3] - corners[:, k])
        angles[:, k] = np.arccos(np.clip(np.einsum("ij,ij->i", u, v), -1.0, 1.0))
    vertex_sum = np.zeros_like(vertices)
    for k in range(3):
        np.add.at(vertex_sum, faces[:, k], angles[:, k, None] * face_normals)
    vertex_normals = _unit(vertex_sum)
    edges = np.stack([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]], axis=1).reshape(-1, 2)
    edge_keys = np.sort(edges, axis=1)
    _, edge_ids = np.unique(edge_keys, axis=0, return_inverse=True)
    edge_ids = edge_ids.reshape(-1)
    edge_sum = np.zeros((edge_ids.max() + 1 if len(edge_ids) else 0, 3))
    np.add.at(edge_sum, edge_ids, np.repeat(face_normals, 3, axis=0))
    edge_normals = _unit(edge_sum)[edge_ids].reshape(-1, 3, 3)
    out = np.empty((len(faces), 7, 3))
    out[:, 0] = face_normals
    out[:, 1:4] = edge_normals
    out[:, 4:7] = vertex_normals[faces]
    return out


def build_bvh(triangles: NDArray[np.float64], leaf_size: int = LEAF_SIZE) -> Bvh:
    """Median-split AABB tree over ``triangles`` (T, 3, 3); nodes in depth-first order."""
    centroids = triangles.mean(axis=1)
    lows, highs = triangles.min(axis=1), triangles.max(axis=1)
    order = np.arange(len(triangles), dtype=np.int64)
    lower: list[NDArray[np.float64]] = []
    upper: list[NDArray[np.float64]] = []
    nodes: list[list[int]] = []
    pending = [(0, len(triangles), -1, 0)]  # (first, count, parent, which child slot)
    while pending:
        first, count, parent, slot = pending.pop()
        index = len(nodes)
        if parent >= 0:
            nodes[parent][slot] = index
        members = order[first:first + count]
        lower.append(lows[members].min(axis=0))
        upper.append(highs[members].max(axis=0))
        if count <= leaf_size:
            nodes.append([first, count, 1])
            continue
        nodes.append([-1, -1, 0])
        spread = centroids[members].max(axis=0) - centroids[members].min(axis=0)
        axis = int(np.argmax(spread))
        half = count // 2
        split = np.argpartition(centroids[members, axis], half, kind="introselect")
        order[first:first + count] = members[split]
        pending.append((first + half, count - half, index, 1))
        pending.append((first, half, index, 0))
    return Bvh(order, np.array(lower), np.array(upper), np.array(nodes, dtype=np.int64))
