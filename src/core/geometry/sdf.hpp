// Exact signed distances of points to the packed obstacles (the numba kernels' bits: issue 32, sdf.cpp).
//
// d is the Euclidean signed distance in metres, negative inside. The normal is the unit gradient grad d in the
// world frame: outside it points from the closest surface point to p, inside it is the outward surface normal at
// the closest surface point. On the medial axis (several closest points) the normal follows these rules, in the
// obstacle's local frame (docs/geometry.md):
//
//   * among equally near box faces the lower axis wins (x, then y, then z); the + side wins at a coordinate of
//     exactly 0 (sign(0) = +1);
//   * the sphere's centre gets local +z; a point on a cylinder's or capsule's axis whose closest points form a
//     circle gets local +x;
//   * a cylinder point equally near the cap and the side wall gets the cap's normal (+-z);
//   * an ellipsoid point on a symmetry plane with mirror-image closest points takes the + side;
//   * meshes: the first closest triangle in BVH traversal order (mesh_bvh.hpp).
//
// A point is taken into the obstacle's frame, q = R^T (p - c), the local formula runs there and the normal comes
// back as R n_local (distances are invariant under rigid motion). Sphere points off the centre are computed in
// the world frame directly (no rotation: fewer roundings).
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>

#include "geometry/mesh_bvh.hpp"
#include "geometry/packed.hpp"

namespace pfield::geometry {

// Local-frame primitives: d and the local normal of q.
SignedDistance sphere_local(Vec3 q, double r);                  // d = |q| - r
SignedDistance box_local(Vec3 q, double hx, double hy, double hz);  // Quilez's box: exact inside and out
SignedDistance cylinder_local(Vec3 q, double r, double half_height);  // a 2D box in (rho, z), axis along z
SignedDistance capsule_local(Vec3 q, double r, double half_height);   // |q - segment z in [-hh, hh]| - r

// Semi-axes a, b, c: the closest point by D. Eberly's "Distance from a Point to an Ellipse, an Ellipsoid, or a
// Hyperellipsoid" (Geometric Tools, 2013-2020), its root solved by safeguarded Halley steps (sdf.cpp); the normal
// is the surface normal at the closest point, proportional to (x/a^2, y/b^2, z/c^2).
SignedDistance ellipsoid_local(Vec3 q, double a, double b, double c);

// Signed distance and world normal of p to obstacle i. Exact whenever d <= cutoff; beyond it the answer may be a
// cheaper lower bound d' with cutoff < d' <= d and a unit normal pointing away (ellipsoids: their bounding
// sphere; meshes: their bounding box), which consumers that ignore obstacles beyond an influence distance never
// see. A mesh row naming no packed mesh gives NaN.
SignedDistance obstacle_signed_distance(const PackedView& packed, std::size_t i, Vec3 p,
                                        double cutoff = std::numeric_limits<double>::infinity());

struct NearestObstacle {
  SignedDistance nearest{std::numeric_limits<double>::infinity(), {}};
  std::int64_t index = -1;  // -1 with no obstacles
};

// The smallest signed distance over all obstacles; ties go to the lowest index.
NearestObstacle min_signed_distance(const PackedView& packed, Vec3 p);

// distances (n, M) and normals (n, M, 3), row-major, of n points (n, 3) to every obstacle (cutoff: as
// obstacle_signed_distance's).
void signed_distances(const PackedView& packed, const double* points, std::size_t n, double* distances,
                      double* normals, double cutoff = std::numeric_limits<double>::infinity());

}  // namespace pfield::geometry
