// Point-mesh signed distance over a packed mesh's bounding-box hierarchy (the numba kernel's order: issue 32).
//
// The closest point over all triangles of one mesh is found by a depth-first traversal of its median-split AABB
// tree that skips every node whose box is not nearer than the best triangle so far (the box distance is a lower
// bound of its triangles'); the nearer child is visited first (the right one when both are equally near), and a
// triangle replaces the best only when strictly nearer, so ties pick the first triangle in traversal order.
//
// Sign: the angle-weighted pseudo-normal n of the closest feature (face, edge or vertex) of the closest triangle;
// p with closest point c is outside when (p - c).n >= 0 (Baerentzen & Aanaes 2005, "Signed distance computation
// using the angle weighted pseudonormal", IEEE TVCG 11(3)); exact for closed, consistently oriented meshes. Open
// meshes get the unsigned distance.
#pragma once

#include <cstdint>

#include "geometry/packed.hpp"

namespace pfield::geometry {

// The closest feature of a triangle; indexes its 7 pseudo-normals.
enum class Feature : int { Face = 0, EdgeAB = 1, EdgeBC = 2, EdgeCA = 3, VertexA = 4, VertexB = 5, VertexC = 6 };

struct TrianglePoint {
  Vec3 point;
  Feature feature = Feature::Face;
};

struct MeshClosest {
  double distance_squared = 0.0;
  std::int64_t triangle = -1;  // -1: the mesh has no triangle
  Feature feature = Feature::Face;
  Vec3 point;
};

// Closest point of the triangle (a, b, c) = vertices[0..8] to p, walking the Voronoi regions of its vertices, edges
// and face with the barycentric tests of Ericson, "Real-Time Collision Detection" (2005), section 5.1.5.
TrianglePoint closest_point_on_triangle(const double* vertices, Vec3 p);

// The exact closest point of the mesh whose BVH root is node `root`, p in the mesh's local frame.
MeshClosest mesh_closest_point(const PackedView& packed, std::int64_t root, Vec3 p);

// d = s |p - c| with s = -1 when the mesh is watertight (`signed`) and (p - c).n < 0, else +1; the normal is
// s (p - c) / |p - c|. On the surface (|p - c| <= 1e-12 m) d = 0 and the normal is the feature's pseudo-normal.
SignedDistance mesh_signed_distance(const PackedView& packed, std::int64_t root, bool signed_, Vec3 p);

}  // namespace pfield::geometry
