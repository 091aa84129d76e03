// Exact signed distances of points to the packed obstacles (the numba kernels' bits: issue 32, sdf.cpp and
// ellipsoid.hpp).
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

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "geometry/ellipsoid.hpp"
#include "geometry/mesh_bvh.hpp"
#include "geometry/packed.hpp"

namespace pfield::geometry {

// Local-frame primitives: d and the local normal of q.
SignedDistance sphere_local(Vec3 q, double r);                  // d = |q| - r
SignedDistance box_local(Vec3 q, double hx, double hy, double hz);  // Quilez's box: exact inside and out
SignedDistance cylinder_local(Vec3 q, double r, double half_height);  // a 2D box in (rho, z), axis along z
SignedDistance capsule_local(Vec3 q, double r, double half_height);   // |q - segment z in [-hh, hh]| - r

// Semi-axes a, b, c: the closest point by D. Eberly's "Distance from a Point to an Ellipse, an Ellipsoid, or a
// Hyperellipsoid" (Geometric Tools, 2013-2020), its root solved by safeguarded Halley steps (ellipsoid.hpp: inline
// in the obstacle loops, the root's loop out of line); the normal is the surface normal at the closest point,
// proportional to (x/a^2, y/b^2, z/c^2).
SignedDistance ellipsoid_local(Vec3 q, double a, double b, double c);

namespace detail {

// Python's min and max tie rule (the later argument wins only when strictly beyond) and sign(0) = +1.
inline double max_of(double a, double b) { return b > a ? b : a; }
inline double min_of(double a, double b) { return b < a ? b : a; }
inline double sign_of(double x) { return x >= 0.0 ? 1.0 : -1.0; }

// The primitives: here so that every caller inlines the per-kind dispatch (obstacle_signed_distance below) rather
// than passing p and a 32-byte result through memory on every obstacle; sdf.cpp exports them as *_local.
[[gnu::always_inline]] inline SignedDistance sphere_at(const Vec3& q, double r) {
  const double norm = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z);
  if (norm == 0.0) return {-r, {0.0, 0.0, 1.0}};
  return {norm - r, {q.x / norm, q.y / norm, q.z / norm}};
}

// With e = |q| - h: d = |max(e, 0)| outside, max_i e_i inside. Outside n = sign(q) max(e, 0) / d; inside
// n = sign(q_k) e_k along the axis k of the largest e_k (the lowest index on ties).
[[gnu::always_inline]] inline SignedDistance box_at(const Vec3& q, double hx, double hy, double hz) {
  const double ex = std::abs(q.x) - hx, ey = std::abs(q.y) - hy, ez = std::abs(q.z) - hz;
  if (ex > 0.0 || ey > 0.0 || ez > 0.0) {
    const double ox = max_of(ex, 0.0), oy = max_of(ey, 0.0), oz = max_of(ez, 0.0);
    const double d = std::sqrt(ox * ox + oy * oy + oz * oz);
    return {d, {sign_of(q.x) * ox / d, sign_of(q.y) * oy / d, sign_of(q.z) * oz / d}};
  }
  if (ex >= ey && ex >= ez) return {ex, {sign_of(q.x), 0.0, 0.0}};
  if (ey >= ez) return {ey, {0.0, sign_of(q.y), 0.0}};
  return {ez, {0.0, 0.0, sign_of(q.z)}};
}

// box_at's distance alone (the same operations).
[[gnu::always_inline]] inline double box_distance(const Vec3& q, double hx, double hy, double hz) {
  const double ex = std::abs(q.x) - hx, ey = std::abs(q.y) - hy, ez = std::abs(q.z) - hz;
  if (ex > 0.0 || ey > 0.0 || ez > 0.0) {
    const double ox = max_of(ex, 0.0), oy = max_of(ey, 0.0), oz = max_of(ez, 0.0);
    return std::sqrt(ox * ox + oy * oy + oz * oz);
  }
  if (ex >= ey && ex >= ez) return ex;
  return ey >= ez ? ey : ez;
}

// e = (rho - r, |z| - hh): outside both, the corner ring; inside, the cap wins the tie with the side wall. rho =
// |(qx, qy)| and the radial unit vector (local +x on the axis).
[[gnu::always_inline]] inline SignedDistance cylinder_at(const Vec3& q, double r, double half_height) {
  const double rho = std::sqrt(q.x * q.x + q.y * q.y);
  const double ux = rho == 0.0 ? 1.0 : q.x / rho, uy = rho == 0.0 ? 0.0 : q.y / rho;
  const double er = rho - r, ez = std::abs(q.z) - half_height;
  const double sz = sign_of(q.z);
  if (er > 0.0 && ez > 0.0) {
    const double d = std::sqrt(er * er + ez * ez);
    return {d, {ux * er / d, uy * er / d, sz * ez / d}};
  }
  if (er > 0.0) return {er, {ux, uy, 0.0}};
  if (ez > 0.0 || ez >= er) return {ez, {0.0, 0.0, sz}};
  return {er, {ux, uy, 0.0}};
}

// cylinder_at's distance alone (the same operations).
[[gnu::always_inline]] inline double cylinder_distance(const Vec3& q, double r, double half_height) {
  const double rho = std::sqrt(q.x * q.x + q.y * q.y);
  const double er = rho - r, ez = std::abs(q.z) - half_height;
  if (er > 0.0 && ez > 0.0) return std::sqrt(er * er + ez * ez);
  if (er > 0.0) return er;
  return ez > 0.0 || ez >= er ? ez : er;
}

[[gnu::always_inline]] inline SignedDistance capsule_at(const Vec3& q, double r, double half_height) {
  const double cz = min_of(max_of(q.z, -half_height), half_height);
  const double vz = q.z - cz;
  const double norm = std::sqrt(q.x * q.x + q.y * q.y + vz * vz);
  if (norm == 0.0) return {-r, {1.0, 0.0, 0.0}};
  return {norm - r, {q.x / norm, q.y / norm, vz / norm}};
}

// capsule_at's distance alone (the same operations).
[[gnu::always_inline]] inline double capsule_distance(const Vec3& q, double r, double half_height) {
  const double cz = min_of(max_of(q.z, -half_height), half_height);
  const double vz = q.z - cz;
  const double norm = std::sqrt(q.x * q.x + q.y * q.y + vz * vz);
  return norm == 0.0 ? -r : norm - r;
}

// The costly kinds in the obstacle's local frame. An ellipsoid: exact within the cutoff, else possibly its bounding
// sphere's distance, a lower bound. A mesh (sdf.cpp): exact within the cutoff, else possibly
// its bounding box's gap; NaN for a row naming no packed mesh.
[[gnu::always_inline]] inline SignedDistance ellipsoid_within(const Vec3& q, double a, double b, double c,
                                                              double cutoff) {
  const double radius = max_of(max_of(a, b), c);
  // sphere_at's distance (|q| - r, also at the centre) first: its normal only when the bound is the answer
  if (std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z) - radius <= cutoff) return ellipsoid::signed_distance(q, a, b, c);
  return sphere_at(q, radius);
}
SignedDistance mesh_within(const PackedView& packed, double mesh, const Vec3& q, double cutoff);

// q = R^T (p - c): p in obstacle i's frame (row: its packed row).
[[gnu::always_inline]] inline Vec3 to_local(const double* row, const Vec3& p) {
  const double dx = p.x - row[0], dy = p.y - row[1], dz = p.z - row[2];
  return {row[3] * dx + row[6] * dy + row[9] * dz, row[4] * dx + row[7] * dy + row[10] * dz,
          row[5] * dx + row[8] * dy + row[11] * dz};
}

}  // namespace detail

// Signed distance and world normal of p to obstacle i. Exact whenever d <= cutoff; beyond it the answer may be a
// cheaper lower bound d' with cutoff < d' <= d and a unit normal pointing away (ellipsoids: their bounding
// sphere; meshes: their bounding box), which consumers that ignore obstacles beyond an influence distance never
// see. A mesh row naming no packed mesh gives NaN. Inline: the primitives' dispatch runs in the caller's loop.
[[gnu::always_inline]] inline SignedDistance obstacle_signed_distance(
    const PackedView& packed, std::size_t i, const Vec3& p, double cutoff = std::numeric_limits<double>::infinity()) {
  const double* row = packed.row(i);
  const auto kind = static_cast<Kind>(packed.kinds[i]);
  if (kind == Kind::Sphere) {
    const double dx = p.x - row[0], dy = p.y - row[1], dz = p.z - row[2];
    const double norm = std::sqrt(dx * dx + dy * dy + dz * dz);
    if (norm > 0.0) return {norm - row[12], {dx / norm, dy / norm, dz / norm}};
  }
  const Vec3 q = detail::to_local(row, p);
  SignedDistance local{std::numeric_limits<double>::quiet_NaN(), {}};  // every Kind sets it (check_packed)
  switch (kind) {
    case Kind::Sphere:  // at its centre
      local = detail::sphere_at(q, row[12]);
      break;
    case Kind::Box:
      local = detail::box_at(q, row[12], row[13], row[14]);
      break;
    case Kind::Cylinder:
      local = detail::cylinder_at(q, row[12], row[13]);
      break;
    case Kind::Capsule:
      local = detail::capsule_at(q, row[12], row[13]);
      break;
    case Kind::Ellipsoid:
      local = detail::ellipsoid_within(q, row[12], row[13], row[14], cutoff);
      break;
    case Kind::Mesh:
      local = detail::mesh_within(packed, row[15], q, cutoff);
      break;
  }
  const Vec3& n = local.normal;
  return {local.distance, {row[3] * n.x + row[4] * n.y + row[5] * n.z, row[6] * n.x + row[7] * n.y + row[8] * n.z,
                           row[9] * n.x + row[10] * n.y + row[11] * n.z}};
}

// obstacle_signed_distance's distance alone, the same bits, without the normal's divisions and rotation (the
// primitives; ellipsoids and meshes compute theirs).
[[gnu::always_inline]] inline double obstacle_distance(const PackedView& packed, std::size_t i, const Vec3& p,
                                                       double cutoff = std::numeric_limits<double>::infinity()) {
  const double* row = packed.row(i);
  const auto kind = static_cast<Kind>(packed.kinds[i]);
  if (kind == Kind::Sphere) {
    const double dx = p.x - row[0], dy = p.y - row[1], dz = p.z - row[2];
    const double norm = std::sqrt(dx * dx + dy * dy + dz * dz);
    return norm == 0.0 ? -row[12] : norm - row[12];  // at the centre: sphere_at's -r (NaN stays NaN)
  }
  const Vec3 q = detail::to_local(row, p);
  switch (kind) {
    case Kind::Sphere:  // unreachable: answered above
      return detail::sphere_at(q, row[12]).distance;
    case Kind::Box:
      return detail::box_distance(q, row[12], row[13], row[14]);
    case Kind::Cylinder:
      return detail::cylinder_distance(q, row[12], row[13]);
    case Kind::Capsule:
      return detail::capsule_distance(q, row[12], row[13]);
    case Kind::Ellipsoid:
      return detail::ellipsoid_within(q, row[12], row[13], row[14], cutoff).distance;
    case Kind::Mesh:
      return detail::mesh_within(packed, row[15], q, cutoff).distance;
  }
  return std::numeric_limits<double>::quiet_NaN();  // no Kind: check_packed refuses such codes
}

// The boxes among packed obstacles as columns, one array per coordinate, so that one point's distance to every box
// runs in SIMD lanes: obstacle_distance's box branch (to_local, then box_distance) with its branches as selects,
// the same operations and bits. The global search's state check measures each link's axis midpoint this way.
struct BoxColumns {
  struct Columns3 {
    std::vector<double> x, y, z;
  };

  BoxColumns() = default;
  explicit BoxColumns(const PackedView& packed);

  std::vector<std::int64_t> slot;  // (M,) obstacle i's box index b, or -1 when it is not a box
  Columns3 centre, x_axis, y_axis, z_axis, half;  // (B,) each: the box's centre, local axes (world), half sizes

  std::size_t size() const { return centre.x.size(); }

  // out[b] = obstacle_distance(packed, i, p) of the box i with slot[i] = b, for every box (out: size() values).
  // Out of line (sdf.cpp, no fused multiply-adds): one compiled copy for the search and the tests.
  void distances(const Vec3& p, double* out) const;
};

struct NearestObstacle {
  SignedDistance nearest{std::numeric_limits<double>::infinity(), {}};
  std::int64_t index = -1;  // -1 with no obstacles
};

// The smallest signed distance over all obstacles; ties go to the lowest index.
NearestObstacle min_signed_distance(const PackedView& packed, Vec3 p);

// min_signed_distance(p).nearest.distance from distances alone (the same bits; inf with no obstacles).
double min_distance(const PackedView& packed, const Vec3& p);

// True when some obstacle's signed distance at p is <= 0: min_signed_distance(p).nearest.distance <= 0 (the same
// distances, cutoff included), from distances alone and stopping at the first such obstacle.
bool inside_any(const PackedView& packed, const Vec3& p);

// distances (n, M), row-major, of n points (n, 3) to every obstacle: signed_distances' without the normals.
void signed_distances_only(const PackedView& packed, const double* points, std::size_t n, double* distances,
                           double cutoff = std::numeric_limits<double>::infinity());

// distances (n, M) and normals (n, M, 3), row-major, of n points (n, 3) to every obstacle (cutoff: as
// obstacle_signed_distance's).
void signed_distances(const PackedView& packed, const double* points, std::size_t n, double* distances,
                      double* normals, double cutoff = std::numeric_limits<double>::infinity());

}  // namespace pfield::geometry
