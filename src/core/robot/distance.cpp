// Every expression keeps the operand order of the numba kernels this file replaced (issue 32), Python's min and max
// keep their tie rule, and this file is compiled without fused multiply-adds (CMakeLists.txt): the same bits as
// those kernels (tests/robot/test_core_distance.py holds digests of their results).
#include "robot/distance.hpp"

#include <cmath>
#include <cstdint>
#include <limits>

#include "geometry/sdf.hpp"

namespace pfield::robot {
namespace {

using detail::py_max;
using detail::py_min;
using geometry::Kind;
using geometry::PackedView;
using geometry::SignedDistance;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kBisections = 24;
constexpr int kMeshSamples = 9;
constexpr int kGoldenSteps = 18;
constexpr double kInvPhi = 0.6180339887498949;  // 1 / golden ratio

Kind kind_of(const PackedView& packed, std::size_t i) { return static_cast<Kind>(packed.kinds[i]); }

// The point a + t (b - a).
Vec3 along(Vec3 a, Vec3 b, double t) { return {a.x + t * (b.x - a.x), a.y + t * (b.y - a.y), a.z + t * (b.z - a.z)}; }

SignedDistance distance_at(const PackedView& packed, std::size_t i, Vec3 a, Vec3 b, double t) {
  return geometry::obstacle_signed_distance(packed, i, along(a, b, t), kInf);
}

// The segment a-b in the frame of obstacle i: start p0 = R^T (a - c) and direction u = R^T (b - a).
struct LocalSegment {
  double p0[3];
  double u[3];
};

LocalSegment local_segment(const double* row, Vec3 a, Vec3 b) {
  const double cx = a.x - row[0], cy = a.y - row[1], cz = a.z - row[2];
  const double ux = b.x - a.x, uy = b.y - a.y, uz = b.z - a.z;
  return {{row[3] * cx + row[6] * cy + row[9] * cz, row[4] * cx + row[7] * cy + row[10] * cz,
           row[5] * cx + row[8] * cy + row[11] * cz},
          {row[3] * ux + row[6] * uy + row[9] * uz, row[4] * ux + row[7] * uy + row[10] * uz,
           row[5] * ux + row[8] * uy + row[11] * uz}};
}

// The local signed distance of a cylinder or an ellipsoid, the kinds convex_minimum serves (the signed distance
// dispatch with no cutoff); segment_obstacle_distance sends no other kind here, and a new kind must say whether it
// comes (the switch lists every kind).
SignedDistance convex_local(Kind kind, Vec3 q, double s0, double s1, double s2) {
  switch (kind) {
    case Kind::Cylinder:
      return geometry::detail::cylinder_at(q, s0, s1);
    case Kind::Ellipsoid: {
      // the dispatch's bounding-sphere test, with cutoff inf: it passes unless the bound is NaN
      const SignedDistance bound = geometry::detail::sphere_at(q, py_max(py_max(s0, s1), s2));
      if (bound.distance <= kInf) return geometry::detail::ellipsoid::signed_distance(q, s0, s1, s2);
      return bound;
    }
    case Kind::Sphere:
    case Kind::Box:
    case Kind::Capsule:
    case Kind::Mesh:
      break;  // minimised by their own rules (segment_obstacle_distance)
  }
  return {std::numeric_limits<double>::quiet_NaN(), {}};
}

// The slope grad d . u of d along the segment at p0 + t u (obstacle frame).
double local_slope(Kind kind, const double* row, const LocalSegment& s, double t) {
  const Vec3 q{s.p0[0] + t * s.u[0], s.p0[1] + t * s.u[1], s.p0[2] + t * s.u[2]};
  const Vec3 n = convex_local(kind, q, row[12], row[13], row[14]).normal;
  return n.x * s.u[0] + n.y * s.u[1] + n.z * s.u[2];
}

// (d^2, half its derivative) of the box-frame point p0 + t u outside the box of half extents h (0, 0 inside).
struct Excess {
  double square;
  double slope;
};

Excess box_excess_slope(const LocalSegment& s, const double* h, double t) {
  double square = 0.0, slope = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double value = s.p0[k] + t * s.u[k];
    const double excess = std::abs(value) - h[k];
    if (excess > 0.0) {
      square += excess * excess;
      slope += excess * (value >= 0.0 ? s.u[k] : -s.u[k]);
    }
  }
  return {square, slope};
}

// The smallest t in [0, 1] minimising max_j (s_j t + o_j) over the six faces' affine excesses +-p_k(t) - h_k: an
// end, or where two of them cross (the 15 face pairs in order (0, 1), (0, 2), ..., (4, 5)).
double box_reach_minimiser(const LocalSegment& s, const double* h) {
  const double slopes[6] = {s.u[0], -s.u[0], s.u[1], -s.u[1], s.u[2], -s.u[2]};
  const double offsets[6] = {s.p0[0] - h[0], -s.p0[0] - h[0], s.p0[1] - h[1],
                             -s.p0[1] - h[1], s.p0[2] - h[2], -s.p0[2] - h[2]};
  double best_t = 0.0, best = kInf;
  const auto consider = [&](double t) {
    double value = -kInf;
    for (int f = 0; f < 6; ++f) value = py_max(value, slopes[f] * t + offsets[f]);
    if (value < best || (value == best && t < best_t)) {
      best_t = t;
      best = value;
    }
  };
  consider(0.0);
  consider(1.0);
  for (int j = 0; j < 6; ++j) {
    for (int m = j + 1; m < 6; ++m) {
      if (slopes[j] == slopes[m]) continue;
      const double t = (offsets[m] - offsets[j]) / (slopes[j] - slopes[m]);
      if (!(0.0 < t && t < 1.0)) continue;
      consider(t);
    }
  }
  return best_t;
}

}  // namespace

double point_segment_distance(Vec3 c, Vec3 a, Vec3 b) { return detail::point_segment_distance(c, a, b); }

SegmentParameters closest_segment_points(Vec3 p1, Vec3 q1, Vec3 p2, Vec3 q2) {
  return detail::closest_segment_points(p1, q1, p2, q2);
}

double segment_segment_distance(Vec3 p1, Vec3 q1, Vec3 p2, Vec3 q2) {
  return detail::segment_segment_distance(p1, q1, p2, q2);
}

void segment_distances_to(const double* a, const double* b, std::size_t first, std::size_t stop, Vec3 p2, Vec3 q2,
                          double* out) {
  detail::segment_distances_to(a, b, first, stop, p2, q2, out);
}

double box_minimiser(const PackedView& packed, std::size_t i, Vec3 a, Vec3 b) {
  const double* row = packed.row(i);
  const LocalSegment s = local_segment(row, a, b);
  const double* h = row + 12;
  double low_t = 0.0, low = box_excess_slope(s, h, 0.0).slope;
  double high_t = 1.0, high = box_excess_slope(s, h, 1.0).slope;
  double best_t;
  if (low >= 0.0) {
    best_t = 0.0;
  } else if (high <= 0.0) {
    best_t = 1.0;
  } else {
    for (int k = 0; k < 3; ++k) {
      if (s.u[k] == 0.0) continue;
      for (const double side : {-1.0, 1.0}) {
        const double t = (side * h[k] - s.p0[k]) / s.u[k];
        if (!(0.0 < t && t < 1.0)) continue;
        const double slope = box_excess_slope(s, h, t).slope;
        if (slope < 0.0 && t > low_t) {
          low_t = t;
          low = slope;
        } else if (slope >= 0.0 && t < high_t) {
          high_t = t;
          high = slope;
        }
      }
    }
    best_t = low_t - low * (high_t - low_t) / (high - low);  // the zero of the linear g' between them
  }
  if (box_excess_slope(s, h, best_t).square > 1e-24) return best_t;
  return box_reach_minimiser(s, h);
}

SegmentDistance round_segment_distance(const PackedView& packed, std::size_t i, Vec3 a, Vec3 b) {
  const double* row = packed.row(i);
  const Vec3 c{row[0], row[1], row[2]};
  const double radius = row[12];
  const Vec3 e = b - a;
  double t;
  Vec3 q;
  if (kind_of(packed, i) == Kind::Sphere) {
    t = closest_parameter(c - a, e, math::dot(e, e));
    q = c;
  } else {
    // the capsule's axis: local z (the third column of the row-major R) times the half height, about c
    const double half = row[13];
    const Vec3 z{half * row[5], half * row[8], half * row[11]};
    const Vec3 a2 = c - z, b2 = c + z;
    const SegmentParameters st = detail::closest_segment_points(a, b, a2, b2);
    t = st.s;
    q = along(a2, b2, st.t);
  }
  const Vec3 p{a.x + t * e.x, a.y + t * e.y, a.z + t * e.z};
  const Vec3 d = p - q;
  const double norm = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
  if (norm > 1e-12) return {norm - radius, t, {d.x / norm, d.y / norm, d.z / norm}};
  // on the centre or axis: any direction perpendicular to the segment is a gradient; take one deterministically
  const Vec3 n = std::abs(e.z) < py_max(std::abs(e.x), std::abs(e.y)) ? Vec3{-e.y, e.x, 0.0} : Vec3{0.0, -e.z, e.y};
  const double scale = std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
  if (scale < 1e-12) return {-radius, t, {0.0, 0.0, 1.0}};
  return {-radius, t, {n.x / scale, n.y / scale, n.z / scale}};
}

SegmentDistance convex_minimum(const PackedView& packed, std::size_t i, Vec3 a, Vec3 b) {
  const Kind kind = kind_of(packed, i);
  const double* row = packed.row(i);
  const LocalSegment s = local_segment(row, a, b);
  double t;
  if (local_slope(kind, row, s, 0.0) >= 0.0) {
    t = 0.0;
  } else if (local_slope(kind, row, s, 1.0) <= 0.0) {
    t = 1.0;
  } else {
    double lo = 0.0, hi = 1.0;
    for (int step = 0; step < kBisections; ++step) {
      const double mid = 0.5 * (lo + hi);
      if (local_slope(kind, row, s, mid) < 0.0) {
        lo = mid;
      } else {
        hi = mid;
      }
    }
    t = 0.5 * (lo + hi);
  }
  const SignedDistance d = distance_at(packed, i, a, b, t);
  return {d.distance, t, d.normal};
}

SegmentDistance mesh_minimum(const PackedView& packed, std::size_t i, Vec3 a, Vec3 b) {
  const auto f = [&](double t) { return distance_at(packed, i, a, b, t).distance; };
  double best_t = 0.0, best_d = kInf;
  for (int k = 0; k < kMeshSamples; ++k) {
    const double t = static_cast<double>(k) / static_cast<double>(kMeshSamples - 1);
    const double d = f(t);
    if (d < best_d) {
      best_d = d;
      best_t = t;
    }
  }
  const double step = 1.0 / static_cast<double>(kMeshSamples - 1);
  double lo = py_max(best_t - step, 0.0), hi = py_min(best_t + step, 1.0);
  double x1 = hi - kInvPhi * (hi - lo);
  double x2 = lo + kInvPhi * (hi - lo);
  double f1 = f(x1), f2 = f(x2);
  for (int k = 0; k < kGoldenSteps; ++k) {
    if (f1 < f2) {
      hi = x2, x2 = x1, f2 = f1;
      x1 = hi - kInvPhi * (hi - lo);
      f1 = f(x1);
    } else {
      lo = x1, x1 = x2, f1 = f2;
      x2 = lo + kInvPhi * (hi - lo);
      f2 = f(x2);
    }
  }
  double t = f1 < f2 ? x1 : x2;
  if (best_d < py_min(f1, f2)) t = best_t;  // the sample beat the refined bracket (flat or noisy f)
  const SignedDistance d = distance_at(packed, i, a, b, t);
  return {d.distance, t, d.normal};
}

SegmentDistance segment_obstacle_distance(const PackedView& packed, std::size_t i, Vec3 a, Vec3 b) {
  switch (kind_of(packed, i)) {
    case Kind::Sphere:
    case Kind::Capsule:
      return round_segment_distance(packed, i, a, b);
    case Kind::Box: {
      const double t = box_minimiser(packed, i, a, b);
      const SignedDistance d = geometry::obstacle_signed_distance(packed, i, along(a, b, t), kInf);
      return {d.distance, t, d.normal};
    }
    case Kind::Mesh:
      return mesh_minimum(packed, i, a, b);
    case Kind::Cylinder:
    case Kind::Ellipsoid:
      return convex_minimum(packed, i, a, b);
  }
  return {std::numeric_limits<double>::quiet_NaN(), 0.0, {}};  // no Kind: check_packed refuses such codes
}

}  // namespace pfield::robot
