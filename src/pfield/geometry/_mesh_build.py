"""Preprocessing of triangle meshes for the compiled distance query (runs once per mesh).

* :func:`pseudo_normals` — per triangle, the 7 angle-weighted pseudo-normals of its face, edges and
  vertices (Bærentzen & Aanæs 2005): a face uses its unit normal, an edge the normalised sum of its
  two faces' normals, a vertex the sum of its incident face normals weighted by the incident angles.
* :func:`build_bvh` — an axis-aligned bounding-box hierarchy: each node's triangles are split at the
  median centroid along the longest axis of their centroid bounds until at most ``leaf_size`` remain
  (the compiled core builds it).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from pfield._core import geometry as _geometry

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


def orient_consistently(faces: NDArray[np.int64]) -> NDArray[np.int64] | None:
    """Faces re-wound so that every edge shared by two faces is traversed in opposite directions.

    Breadth-first over edge-adjacent faces, flipping a neighbour whose shared edge runs the same way.
    Returns None for a non-orientable or non-manifold mesh (an edge with more than two faces). The
    orientation of each connected component is arbitrary: see :func:`orient_components_outward`.
    """
    faces = np.array(faces, dtype=np.int64)
    edge_faces: dict[tuple[int, int], list[int]] = {}
    for f, (a, b, c) in enumerate(faces.tolist()):
        for u, v in ((a, b), (b, c), (c, a)):
            edge_faces.setdefault((min(u, v), max(u, v)), []).append(f)
    if any(len(owners) > 2 for owners in edge_faces.values()):
        return None
    visited = np.zeros(len(faces), dtype=bool)
    for seed in range(len(faces)):
        if visited[seed]:
            continue
        visited[seed] = True
        queue = [seed]
        while queue:
            f = queue.pop()
            a, b, c = faces[f].tolist()
            for u, v in ((a, b), (b, c), (c, a)):
                for g in edge_faces[(min(u, v), max(u, v))]:
                    if g == f:
                        continue
                    same_direction = _has_directed_edge(faces[g], u, v)
                    if visited[g]:
                        if same_direction:
                            return None  # non-orientable (e.g. a Möbius strip)
                        continue
                    if same_direction:
                        faces[g] = faces[g, ::-1]
                    visited[g] = True
                    queue.append(g)
    return faces


def orient_components_outward(
    vertices: NDArray[np.float64], faces: NDArray[np.int64], adjacency: NDArray[np.int64]
) -> NDArray[np.int64]:
    """Flip every edge-connected component whose signed volume is negative (consistent winding assumed).

    ``adjacency`` lists pairs of faces sharing an edge. Volume by the divergence theorem:
    V = Σ det(a, b, c) / 6 over the component's triangles.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    count = len(faces)
    graph = coo_matrix((np.ones(len(adjacency)), (adjacency[:, 0], adjacency[:, 1])), shape=(count, count))
    _, labels = connected_components(graph, directed=False)
    corners = vertices[faces]
    volumes = np.einsum("ij,ij->i", corners[:, 0], np.cross(corners[:, 1], corners[:, 2])) / 6.0
    inverted = np.bincount(labels, weights=volumes) < 0.0
    out = np.array(faces, dtype=np.int64)
    flip = inverted[labels]
    out[flip] = out[flip, ::-1]
    return out


def _has_directed_edge(face: NDArray[np.int64], u: int, v: int) -> bool:
    a, b, c = face.tolist()
    return (a, b) == (u, v) or (b, c) == (u, v) or (c, a) == (u, v)


def _scatter_sum(indices: NDArray[np.int64], values: NDArray[np.float64], size: int) -> NDArray[np.float64]:
    """Row sums of ``values`` (K, 3) grouped by ``indices`` (K,) into ``size`` rows."""
    return np.stack([np.bincount(indices, weights=values[:, k], minlength=size) for k in range(3)], axis=1)


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
    weighted = (angles[:, :, None] * face_normals[:, None, :]).reshape(-1, 3)
    vertex_normals = _unit(_scatter_sum(faces.reshape(-1), weighted, len(vertices)))
    ends = np.stack([faces, np.roll(faces, -1, axis=1)], axis=2).reshape(-1, 2)  # edges ab, bc, ca
    keys = np.minimum(ends[:, 0], ends[:, 1]) * len(vertices) + np.maximum(ends[:, 0], ends[:, 1])
    _, edge_ids = np.unique(keys, return_inverse=True)
    edge_sum = _scatter_sum(edge_ids.reshape(-1), np.repeat(face_normals, 3, axis=0), int(edge_ids.max()) + 1)
    out = np.empty((len(faces), 7, 3))
    out[:, 0] = face_normals
    out[:, 1:4] = _unit(edge_sum)[edge_ids].reshape(-1, 3, 3)
    out[:, 4:7] = vertex_normals[faces]
    return out


def build_bvh(triangles: NDArray[np.float64], leaf_size: int = LEAF_SIZE) -> Bvh:
    """Median-split AABB tree over ``triangles`` (T ≥ 1, 3, 3); nodes in depth-first order, built by the compiled
    core (``src/core/geometry/bvh_build.cpp``)."""
    order, lower, upper, nodes = _geometry.build_bvh(np.ascontiguousarray(triangles.mean(axis=1)),
                                                     np.ascontiguousarray(triangles.min(axis=1)),
                                                     np.ascontiguousarray(triangles.max(axis=1)), leaf_size)
    return Bvh(order, lower, upper, nodes)
