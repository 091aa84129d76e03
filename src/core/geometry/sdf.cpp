// Every expression keeps the operand order of the Python kernels this file replaced (issue 32), Python's min and
// max keep their tie rule (the later argument wins only when strictly beyond), and this file is compiled without
// fused multiply-adds (CMakeLists.txt): the distances kept their last bit (tests/geometry/test_core_sdf.py holds
// them to the recorded values).
#include "geometry/sdf.hpp"

#include <cmath>
#include <cstdint>
#include <limits>

namespace pfield::geometry {

BoxColumns::BoxColumns(const PackedView& packed) : slot(packed.obstacle_count, -1) {
  for (std::size_t i = 0; i < packed.obstacle_count; ++i) {
    if (static_cast<Kind>(packed.kinds[i]) != Kind::Box) continue;
    const double* row = packed.row(i);
    slot[i] = static_cast<std::int64_t>(size());
    // to_local's q = R^T (p - c): local x is row[3], row[6], row[9] in the world, and so on
    const auto push = [](Columns3& column, double x, double y, double z) {
      column.x.push_back(x);
      column.y.push_back(y);
      column.z.push_back(z);
    };
    push(centre, row[0], row[1], row[2]);
    push(x_axis, row[3], row[6], row[9]);
    push(y_axis, row[4], row[7], row[10]);
    push(z_axis, row[5], row[8], row[11]);
    push(half, row[12], row[13], row[14]);
  }
}

void BoxColumns::distances(const Vec3& p, double* out) const {
  const std::size_t count = size();
  const double px = p.x, py = p.y, pz = p.z;
  const double *cx = centre.x.data(), *cy = centre.y.data(), *cz = centre.z.data();
  const double *xx = x_axis.x.data(), *xy = x_axis.y.data(), *xz = x_axis.z.data();
  const double *yx = y_axis.x.data(), *yy = y_axis.y.data(), *yz = y_axis.z.data();
  const double *zx = z_axis.x.data(), *zy = z_axis.y.data(), *zz = z_axis.z.data();
  const double *hx = half.x.data(), *hy = half.y.data(), *hz = half.z.data();
#pragma omp simd
  for (std::size_t b = 0; b < count; ++b) {
    const double dx = px - cx[b], dy = py - cy[b], dz = pz - cz[b];
    const double qx = xx[b] * dx + xy[b] * dy + xz[b] * dz;
    const double qy = yx[b] * dx + yy[b] * dy + yz[b] * dz;
    const double qz = zx[b] * dx + zy[b] * dy + zz[b] * dz;
    // detail::box_distance with its branches as selects: that function branch-free made the scalar loops over a
    // scene's obstacles 2.2 times slower (geometry bench, nearest of 10 boxes: 0.039 -> 0.086 us per point)
    const double ex = std::abs(qx) - hx[b], ey = std::abs(qy) - hy[b], ez = std::abs(qz) - hz[b];
    const double ox = detail::max_of(ex, 0.0), oy = detail::max_of(ey, 0.0), oz = detail::max_of(ez, 0.0);
    const double outside = std::sqrt(ox * ox + oy * oy + oz * oz);
    const double inside = ex >= ey && ex >= ez ? ex : (ey >= ez ? ey : ez);
    out[b] = ex > 0.0 || ey > 0.0 || ez > 0.0 ? outside : inside;
  }
}

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

using detail::max_of;
using detail::min_of;

}  // namespace

// ellipsoid.hpp's root (the numba kernel's constants).
namespace detail::ellipsoid {
namespace {
constexpr int kMaxIterations = 128;
constexpr double kRelTol = 1e-15;
constexpr double kHalleyTol = 1e-9;
constexpr double kNoise = 1e-15;
// |n| below which an inside point's root is bracketed by [z2, |n|] rather than [z2, 1] (ellipsoid_root): Halley from
// 1 needs about log3(1 / root) steps, 84 for a root of 1e-40, within kMaxIterations; only points that close to the
// centre take the other bracket, so every other value keeps the numba kernel's bits (both digests of the tests)
constexpr double kNearCentre = 1e-40;
}  // namespace

double ellipsoid_root(double r0, double r1, double z0, double z1, double z2, double g) {
  const double n0 = r0 * z0, n1 = r1 * z1;
  const double c0 = r0 - 1.0, c1 = r1 - 1.0;
  // the root is at most |n| (each term of F is at most (n_i / u)^2, as c_i >= 0) and, inside, at most 1. Near the
  // centre |n| is the tight bound: a bracket [z2, 1] around a root of 1e-70 took Halley more than the iteration
  // budget (it shrinks u by a constant factor per step far above the root) and the distance came out as the
  // point's own tiny norm. Elsewhere the bracket stays [z2, 1], so the iterations, hence the bits, are the numba
  // kernel's (tests/geometry/test_core_sdf.py, tests/robot/test_core_distance.py).
  const double length = std::sqrt(n0 * n0 + n1 * n1 + z2 * z2);
  double lo = z2;
  double hi = g < 0.0 ? (length < kNearCentre ? length : 1.0) : length;
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

}  // namespace detail::ellipsoid

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
  return detail::ellipsoid::signed_distance(q, a, b, c);
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
      case Kind::Ellipsoid:
      case Kind::Mesh:
        for (std::size_t k = 0; k < n; ++k)
          out[k * m] = obstacle_distance(packed, i, {points[3 * k], points[3 * k + 1], points[3 * k + 2]}, cutoff);
    }
  }
}

}  // namespace pfield::geometry
