// The exact point-ellipsoid signed distance (D. Eberly, "Distance from a Point to an Ellipse, an Ellipsoid, or a
// Hyperellipsoid", Geometric Tools, 2013-2020), inline in the obstacle loops: a loop that calls it out of line spills
// its own state around every call and receives the 32-byte result through memory. Signed distances of 2000 points
// to ten ellipsoids: 98 ns per ellipsoid out of line, 77 inline with the root's loop out of line (below), 80 with
// that inline too (and 30 kB more code); the numba kernel took 89.
// Every expression keeps the operand order of the Python kernel this replaced (issue 32). It does arithmetic inline:
// call it only from files compiled with -ffp-contract=off (src/core/geometry and the folders of CMakeLists.txt's
// PFIELD_FIELD_SOURCES), not from the binding files, or the bits may differ.
#pragma once

#include <cmath>
#include <utility>

#include "geometry/packed.hpp"

namespace pfield::geometry::detail {
namespace ellipsoid {

inline double square(double x) { return x * x; }

// Coordinates below kFlat of their semi-axis count as on the plane (the numba kernel's constant).
inline constexpr double kFlat = 1e-100;

// Root u = s + 1 > 0 of sum (n_i / (u + c_i))^2 - 1 with n = (r0 z0, r1 z1, z2), c = (r0 - 1, r1 - 1, 0): F is
// convex and decreasing on the bracket [z2, |n|] ([z2, 1] inside, g < 0). Solving for u rather than s keeps the
// root's relative precision near the pole s = -1. Halley steps inside the shrinking bracket, else bisection
// (geometric while the bracket spans orders of magnitude). z1 = 0 gives the 2D problem. Out of line, in sdf.cpp (one
// copy, compiled with the geometry's flags): its loop is most of the code, and the call costs little beside its
// iterations.
double ellipsoid_root(double r0, double r1, double z0, double z1, double z2, double g);

struct Planar {
  double x0, x1;
};

// Closest point on the ellipse (e0 >= e1) to (y0, y1) >= 0 (Eberly, Listing 2).
[[gnu::always_inline]] inline Planar closest_on_ellipse(double e0, double e1, double y0, double y1) {
  if (y1 > 0.0) {
    if (y0 > 0.0) {
      const double z0 = y0 / e0, z1 = y1 / e1;
      const double g = z0 * z0 + z1 * z1 - 1.0;
      if (g == 0.0) return {y0, y1};
      const double r0 = square(e0 / e1);
      const double u = ellipsoid_root(r0, 1.0, z0, 0.0, z1, g);
      return {r0 * y0 / (u + (r0 - 1.0)), y1 / u};
    }
    return {0.0, e1};
  }
  const double denom0 = e0 * e0 - e1 * e1;
  const double numer0 = e0 * y0;
  if (numer0 < denom0) {
    const double xde0 = numer0 / denom0;
    return {e0 * xde0, e1 * std::sqrt(1.0 - xde0 * xde0)};
  }
  return {e0, 0.0};
}

// Closest point on the ellipsoid (e0 >= e1 >= e2) to y >= 0 componentwise (Eberly, Listing 5).
[[gnu::always_inline]] inline Vec3 closest_on_sorted_ellipsoid(double e0, double e1, double e2, double y0, double y1,
                                                               double y2) {
  if (y2 > 0.0) {
    if (y1 > 0.0) {
      if (y0 > 0.0) {
        const double z0 = y0 / e0, z1 = y1 / e1, z2 = y2 / e2;
        const double g = z0 * z0 + z1 * z1 + z2 * z2 - 1.0;
        if (g == 0.0) return {y0, y1, y2};
        const double r0 = square(e0 / e2), r1 = square(e1 / e2);
        const double u = ellipsoid_root(r0, r1, z0, z1, z2, g);
        return {r0 * y0 / (u + (r0 - 1.0)), r1 * y1 / (u + (r1 - 1.0)), y2 / u};
      }
      const Planar x = closest_on_ellipse(e1, e2, y1, y2);
      return {0.0, x.x0, x.x1};
    }
    if (y0 > 0.0) {
      const Planar x = closest_on_ellipse(e0, e2, y0, y2);
      return {x.x0, 0.0, x.x1};
    }
    return {0.0, 0.0, e2};
  }
  // On the plane y2 = 0: inside points near the smallest axis have their closest point off the plane.
  const double denom0 = e0 * e0 - e2 * e2, denom1 = e1 * e1 - e2 * e2;
  const double numer0 = e0 * y0, numer1 = e1 * y1;
  if (numer0 < denom0 && numer1 < denom1) {
    const double xde0 = numer0 / denom0, xde1 = numer1 / denom1;
    const double discr = 1.0 - xde0 * xde0 - xde1 * xde1;
    if (discr > 0.0) return {e0 * xde0, e1 * xde1, e2 * std::sqrt(discr)};
  }
  const Planar x = closest_on_ellipse(e0, e1, y0, y1);
  return {x.x0, x.x1, 0.0};
}

inline double pick(int k, double a, double b, double c) { return k == 0 ? a : (k == 1 ? b : c); }

// Semi-axes a, b, c: d and the local normal of q (sdf.hpp: ellipsoid_local).
[[gnu::always_inline]] inline SignedDistance signed_distance(const Vec3& q, double a, double b, double c) {
  const double sx = q.x >= 0.0 ? 1.0 : -1.0;
  const double sy = q.y >= 0.0 ? 1.0 : -1.0;
  const double sz = q.z >= 0.0 ? 1.0 : -1.0;
  // Coordinates below 1e-100 of their semi-axis count as on the plane: the root solve would otherwise run
  // through denormals (the error is < 1e-100 m).
  const double ya = std::abs(q.x) > kFlat * a ? std::abs(q.x) : 0.0;
  const double yb = std::abs(q.y) > kFlat * b ? std::abs(q.y) : 0.0;
  const double yc = std::abs(q.z) > kFlat * c ? std::abs(q.z) : 0.0;
  // Axes by decreasing semi-axis; equal axes keep x, y, z order.
  int i0 = 0, i1 = 1, i2 = 2;
  if (pick(i1, a, b, c) > pick(i0, a, b, c)) std::swap(i0, i1);
  if (pick(i2, a, b, c) > pick(i1, a, b, c)) {
    std::swap(i1, i2);
    if (pick(i1, a, b, c) > pick(i0, a, b, c)) std::swap(i0, i1);
  }
  const Vec3 x = closest_on_sorted_ellipsoid(pick(i0, a, b, c), pick(i1, a, b, c), pick(i2, a, b, c),
                                             pick(i0, ya, yb, yc), pick(i1, ya, yb, yc), pick(i2, ya, yb, yc));
  const double xa = i0 == 0 ? x.x : (i1 == 0 ? x.y : x.z);
  const double xb = i0 == 1 ? x.x : (i1 == 1 ? x.y : x.z);
  const double xc = i0 == 2 ? x.x : (i1 == 2 ? x.y : x.z);
  double dist = std::sqrt(square(ya - xa) + square(yb - xb) + square(yc - xc));
  if (square(ya / a) + square(yb / b) + square(yc / c) < 1.0) dist = -dist;
  const double nx = sx * xa / (a * a), ny = sy * xb / (b * b), nz = sz * xc / (c * c);
  const double norm = std::sqrt(nx * nx + ny * ny + nz * nz);
  return {dist, {nx / norm, ny / norm, nz / norm}};
}

}  // namespace ellipsoid
}  // namespace pfield::geometry::detail
