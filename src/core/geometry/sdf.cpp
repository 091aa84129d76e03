// Every expression keeps the operand order of the Python kernels this file replaced (issue 32), Python's min and
// max keep their tie rule (the later argument wins only when strictly beyond), and this file is compiled without
// fused multiply-adds (CMakeLists.txt): the distances kept their last bit (tests/geometry/test_core_sdf.py holds
// them to the recorded values).
#include "geometry/sdf.hpp"

#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>

namespace pfield::geometry {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

using detail::max_of;
using detail::min_of;
inline double square(double x) { return x * x; }

// --- The ellipsoid (Eberly). The numba kernel's constants. ---
constexpr int kMaxIterations = 128;
constexpr double kRelTol = 1e-15;
constexpr double kHalleyTol = 1e-9;
constexpr double kNoise = 1e-15;
constexpr double kFlat = 1e-100;

// Root u = s + 1 > 0 of sum (n_i / (u + c_i))^2 - 1 with n = (r0 z0, r1 z1, z2), c = (r0 - 1, r1 - 1, 0): F is
// convex and decreasing on the bracket [z2, |n|] ([z2, 1] inside, g < 0). Solving for u rather than s keeps the
// root's relative precision near the pole s = -1. Halley steps inside the shrinking bracket, else bisection
// (geometric while the bracket spans orders of magnitude). z1 = 0 gives the 2D problem.
double ellipsoid_root(double r0, double r1, double z0, double z1, double z2, double g) {
  const double n0 = r0 * z0, n1 = r1 * z1;
  const double c0 = r0 - 1.0, c1 = r1 - 1.0;
  double lo = z2;
  double hi = g < 0.0 ? 1.0 : std::sqrt(n0 * n0 + n1 * n1 + z2 * z2);
  double u = hi;
  for (int iteration = 0; iteration < kMaxIterations; ++iteration) {
    const double i0 = 1.0 / (u + c0), i1 = 1.0 / (u + c1), i2 = 1.0 / u;
    const double a0 = n0 * i0, a1 = n1 * i1, a2 = z2 * i2;
    const double f = a0 * a0 + a1 * a1 + a2 * a2 - 1.0;
    if (std::abs(f) <= kNoise) return u;  // F at its rounding-noise floor: u is the root to machine precision
    if (f > 0.0) {
      lo = u;
    } else {
      hi = u;
    }
    const double b0 = a0 * a0 * i0, b1 = a1 * a1 * i1, b2 = a2 * a2 * i2;
    const double df = -2.0 * (b0 + b1 + b2);
    const double ddf = 6.0 * (b0 * i0 + b1 * i1 + b2 * i2);
    double next = u - 2.0 * f * df / (2.0 * df * df - f * ddf);  // Halley's step
    if (lo < next && next < hi) {
      if (std::abs(next - u) <= kHalleyTol * u) return next;  // cubic convergence: the error is now ~tol^3
    } else {
      next = hi > 4.0 * lo ? std::sqrt(lo * hi) : 0.5 * (lo + hi);
    }
    if (hi - lo <= kRelTol * hi) return next;
    u = next;
  }
  return u;
}

struct Planar {
  double x0, x1;
};

// Closest point on the ellipse (e0 >= e1) to (y0, y1) >= 0 (Eberly, Listing 2).
Planar closest_on_ellipse(double e0, double e1, double y0, double y1) {
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
Vec3 closest_on_sorted_ellipsoid(double e0, double e1, double e2, double y0, double y1, double y2) {
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

}  // namespace

SignedDistance detail::mesh_within(const PackedView& packed, double mesh, const Vec3& q, double cutoff) {
  if (!(mesh > -1.0 && mesh < static_cast<double>(packed.mesh_count)))  // int(mesh) outside [0, count)
    return {kNaN, {kNaN, kNaN, kNaN}};
  const std::int64_t* table = packed.mesh(static_cast<std::int64_t>(mesh));
  if (cutoff < kInf) {
    const double* lo = packed.bvh_lower + 3 * table[0];
    const double* hi = packed.bvh_upper + 3 * table[0];
    const double gx = q.x - min_of(max_of(q.x, lo[0]), hi[0]);
    const double gy = q.y - min_of(max_of(q.y, lo[1]), hi[1]);
    const double gz = q.z - min_of(max_of(q.z, lo[2]), hi[2]);
    const double gap = std::sqrt(gx * gx + gy * gy + gz * gz);
    if (gap > cutoff) return {gap, {gx / gap, gy / gap, gz / gap}};  // beyond the box by more than the cutoff
  }
  return mesh_signed_distance(packed, table[0], table[4] != 0, q);
}

SignedDistance sphere_local(Vec3 q, double r) { return detail::sphere_at(q, r); }
SignedDistance box_local(Vec3 q, double hx, double hy, double hz) { return detail::box_at(q, hx, hy, hz); }
SignedDistance cylinder_local(Vec3 q, double r, double half_height) { return detail::cylinder_at(q, r, half_height); }
SignedDistance capsule_local(Vec3 q, double r, double half_height) { return detail::capsule_at(q, r, half_height); }

SignedDistance ellipsoid_local(Vec3 q, double a, double b, double c) {
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

NearestObstacle min_signed_distance(const PackedView& packed, Vec3 p) {
  NearestObstacle best;
  for (std::size_t i = 0; i < packed.obstacle_count; ++i) {
    // cutoff = the best so far: an obstacle that cannot beat it may answer with a cheap bound (> best)
    const SignedDistance d = obstacle_signed_distance(packed, i, p, best.nearest.distance);
    if (d.distance < best.nearest.distance) best = {d, static_cast<std::int64_t>(i)};
  }
  return best;
}

void signed_distances(const PackedView& packed, const double* points, std::size_t n, double* distances,
                      double* normals, double cutoff) {
  const std::size_t m = packed.obstacle_count;
  for (std::size_t k = 0; k < n; ++k) {
    const Vec3 p{points[3 * k], points[3 * k + 1], points[3 * k + 2]};
    for (std::size_t i = 0; i < m; ++i) {
      const SignedDistance d = obstacle_signed_distance(packed, i, p, cutoff);
      distances[k * m + i] = d.distance;
      double* normal = normals + 3 * (k * m + i);
      normal[0] = d.normal.x;
      normal[1] = d.normal.y;
      normal[2] = d.normal.z;
    }
  }
}

double min_distance(const PackedView& packed, const Vec3& p) {
  double best = kInf;
  for (std::size_t i = 0; i < packed.obstacle_count; ++i) {
    // cutoff = the best so far, as min_signed_distance's
    const double d = obstacle_distance(packed, i, p, best);
    if (d < best) best = d;
  }
  return best;
}

bool inside_any(const PackedView& packed, const Vec3& p) {
  double best = kInf;  // min_signed_distance's cutoff: the smallest distance so far
  for (std::size_t i = 0; i < packed.obstacle_count; ++i) {
    const double d = obstacle_distance(packed, i, p, best);
    if (d <= 0.0) return true;
    if (d < best) best = d;
  }
  return false;
}

namespace {

// distances[k * m + i] = local(q_k) for every point k, q_k the point in obstacle i's frame: one kind's tight loop
// (obstacle_distance's operations, the kind chosen once per obstacle, so the compiler may run points side by side).
template <class Local>
[[gnu::always_inline]] inline void column(const double* row, const double* points, std::size_t n, std::size_t m,
                                          double* distances, Local local) {
  for (std::size_t k = 0; k < n; ++k)
    distances[k * m] = local(detail::to_local(row, {points[3 * k], points[3 * k + 1], points[3 * k + 2]}));
}

}  // namespace

void signed_distances_only(const PackedView& packed, const double* points, std::size_t n, double* distances,
                           double cutoff) {
  const std::size_t m = packed.obstacle_count;
  for (std::size_t i = 0; i < m; ++i) {
    const double* row = packed.row(i);
    const double s0 = row[12], s1 = row[13], s2 = row[14];
    double* out = distances + i;
    switch (static_cast<Kind>(packed.kinds[i])) {
      case Kind::Sphere:
        for (std::size_t k = 0; k < n; ++k) {
          const double dx = points[3 * k] - row[0], dy = points[3 * k + 1] - row[1], dz = points[3 * k + 2] - row[2];
          const double norm = std::sqrt(dx * dx + dy * dy + dz * dz);
          out[k * m] = norm == 0.0 ? -s0 : norm - s0;
        }
        break;
      case Kind::Box:
        column(row, points, n, m, out, [&](const Vec3& q) { return detail::box_distance(q, s0, s1, s2); });
        break;
      case Kind::Cylinder:
        column(row, points, n, m, out, [&](const Vec3& q) { return detail::cylinder_distance(q, s0, s1); });
        break;
      case Kind::Capsule:
        column(row, points, n, m, out, [&](const Vec3& q) { return detail::capsule_distance(q, s0, s1); });
        break;
      default:  // ellipsoids, meshes, unknown codes
        for (std::size_t k = 0; k < n; ++k)
          out[k * m] = obstacle_distance(packed, i, {points[3 * k], points[3 * k + 1], points[3 * k + 2]}, cutoff);
    }
  }
}

}  // namespace pfield::geometry
