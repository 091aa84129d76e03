// Closest points between a link's segment and an obstacle, and between two segments: the distances every
// robot-level clearance is built from (robot/clearance.hpp). The same operations in the same order as the numba
// kernels they replaced (issue 32), so the same bits (tests/robot/test_core_distance.py holds digests of those
// kernels' results, beside oracles).
//
// A link capsule is a segment s(t) = a + t (b - a), t in [0, 1], swept by a sphere of radius r, so its signed
// distance to an obstacle is min_t d_O(s(t)) - r with d_O the obstacle's exact signed distance
// (geometry::obstacle_signed_distance). The minimisation over t is continuous:
//
//   * spheres and capsules: closed form (point-segment, segment-segment; Ericson, "Real-Time Collision
//     Detection" 2005, sections 5.1.2 and 5.1.9);
//   * boxes: closed form (box_minimiser: d^2 is piecewise quadratic along the segment);
//   * cylinders, ellipsoids: the signed distance of a convex set is convex, so f(t) = d_O(s(t)) is convex and its
//     minimiser is found by bisection on the sign of f'(t) = grad d_O . (b - a) (convex_minimiser);
//   * meshes (possibly non-convex): the best of 9 samples, refined by golden-section search in the bracket around
//     it (mesh_minimiser).
//
// The point-segment closest parameter (closest_parameter) is the one home of that formula in the core: the
// point-segment distance, the sphere obstacle's closed form and the fitted primitives' culling bound
// (clearance.cpp) all take their t from it.
//
// closest_parameter and the point-segment and segment-segment distances of namespace detail are inline (the culling
// loops and the search's state checks inline them) and do arithmetic: call them only from files compiled with
// -ffp-contract=off (every file under src/core/{field,planning,robot,math,shared_control}), not from the binding
// files, or the bits may differ; everything else here is defined in distance.cpp.
#pragma once

#include <cmath>
#include <cstddef>

#include "geometry/packed.hpp"
#include "math/vec3.hpp"

namespace pfield::robot {

using math::Vec3;

namespace detail {
// Python's min and max, whose tie rule the numba kernels kept and the ports keep: the second argument wins only when
// strictly beyond the first.
inline double py_min(double a, double b) { return b < a ? b : a; }
inline double py_max(double a, double b) { return b > a ? b : a; }
inline double clamp01(double x) { return py_min(py_max(x, 0.0), 1.0); }  // min(max(x, 0), 1)
}  // namespace detail

// Segments shorter than sqrt(1e-14) m (1e-7 m) count as points.
constexpr double kDegenerateLength2 = 1e-14;

// The parameter t in [0, 1] of the point of the segment a + t e closest to a + offset (offset = c - a, e = b - a,
// length2 = e . e): the projection clamped onto the segment (Ericson 5.1.2); 0 for a degenerate segment.
inline double closest_parameter(Vec3 offset, Vec3 e, double length2) {
  return length2 <= kDegenerateLength2 ? 0.0 : detail::clamp01(math::dot(offset, e) / length2);
}

// Parameters s (on p1-q1) and t (on p2-q2) in [0, 1] of the closest points of two segments.
struct SegmentParameters {
  double s = 0.0;
  double t = 0.0;
};

// The point-segment and segment-segment distances, inline: the state checks of the global search and the link
// model's distances call them for every pair they look at, and an out-of-line call passed the four Vec3 ends
// through memory and made the caller's loop spill its state. The out-of-line versions after the namespace are
// these, for pfield._core.robot_distance.
namespace detail {

// Euclidean distance (m) from point c to segment a-b: |c - (a + t e)| with t = closest_parameter.
[[gnu::always_inline]] inline double point_segment_distance(const Vec3& c, const Vec3& a, const Vec3& b) {
  const Vec3 d = b - a;
  const double t = closest_parameter(c - a, d, math::dot(d, d));
  const double ex = c.x - (a.x + t * d.x), ey = c.y - (a.y + t * d.y), ez = c.z - (a.z + t * d.z);
  return std::sqrt(ex * ex + ey * ey + ez * ez);
}

// Ericson 5.1.9: the unconstrained minimiser clamped onto s, t recomputed from it and clamped, s recomputed when
// t was clamped; degenerate segments (length^2 <= 1e-14) reduce to point-segment, parallel ones (a e - b^2 <=
// 1e-14) take s = 0.
[[gnu::always_inline]] inline SegmentParameters closest_segment_points(const Vec3& p1, const Vec3& q1, const Vec3& p2,
                                                                      const Vec3& q2) {
  const Vec3 d1 = q1 - p1, d2 = q2 - p2, r = p1 - p2;
  const double a = math::dot(d1, d1), e = math::dot(d2, d2), f = math::dot(d2, r);
  constexpr double eps = 1e-14;
  if (a <= eps && e <= eps) return {0.0, 0.0};
  if (a <= eps) return {0.0, clamp01(f / e)};
  const double c = math::dot(d1, r);
  if (e <= eps) return {clamp01(-c / a), 0.0};
  const double b = math::dot(d1, d2);
  const double denom = a * e - b * b;
  double s = denom > eps ? clamp01((b * f - c * e) / denom) : 0.0;
  double t = (b * s + f) / e;
  if (t < 0.0) {
    t = 0.0;
    s = clamp01(-c / a);
  } else if (t > 1.0) {
    t = 1.0;
    s = clamp01((b - c) / a);
  }
  return {s, t};
}

// Euclidean distance (m) between segments p1-q1 and p2-q2.
[[gnu::always_inline]] inline double segment_segment_distance(const Vec3& p1, const Vec3& q1, const Vec3& p2,
                                                             const Vec3& q2) {
  const SegmentParameters st = closest_segment_points(p1, q1, p2, q2);
  const double dx = (p1.x + st.s * (q1.x - p1.x)) - (p2.x + st.t * (q2.x - p2.x));
  const double dy = (p1.y + st.s * (q1.y - p1.y)) - (p2.y + st.t * (q2.y - p2.y));
  const double dz = (p1.z + st.s * (q1.z - p1.z)) - (p2.z + st.t * (q2.z - p2.z));
  return std::sqrt(0.0 + dx * dx + dy * dy + dz * dz);  // summed from 0.0, as the numba loop did
}

// segment_segment_distance(a[k], b[k], p2, q2) for the segments k = first .. stop - 1 of the rows a, b ((k, 3)
// each) into out[k - first], bit for bit: the same operations, with closest_segment_points' branches as selects
// so that the loop runs in SIMD lanes (the fitted self pairs' culling measures a link's primitives against the
// other link's bounding capsule this way). A degenerate p2-q2 takes the branching form.
inline void segment_distances_to(const double* a, const double* b, std::size_t first, std::size_t stop,
                                 const Vec3& p2, const Vec3& q2, double* out) {
  constexpr double eps = 1e-14;
  const Vec3 start = p2, end = q2;  // copies: out cannot alias them, so the loop keeps them in registers
  const Vec3 d2 = end - start;
  const double e = math::dot(d2, d2);
  if (e <= eps) {
    for (std::size_t k = first; k < stop; ++k)
      out[k - first] = segment_segment_distance({a[3 * k], a[3 * k + 1], a[3 * k + 2]},
                                                {b[3 * k], b[3 * k + 1], b[3 * k + 2]}, p2, q2);
    return;
  }
#pragma omp simd
  for (std::size_t k = first; k < stop; ++k) {
    const Vec3 p1{a[3 * k], a[3 * k + 1], a[3 * k + 2]}, q1{b[3 * k], b[3 * k + 1], b[3 * k + 2]};
    const Vec3 d1 = q1 - p1, r = p1 - start;
    const double aa = math::dot(d1, d1), f = math::dot(d2, r);
    const double c = math::dot(d1, r), bb = math::dot(d1, d2);
    // every branch's value, then the selects (a division in a branch would keep the loop scalar); the divisions of
    // the clamped cases do not wait for t (choosing their operands from t first measured 12 % slower: a longer chain)
    const bool point = aa <= eps;  // p1-q1 degenerate: s = 0, t = clamp01(f / e)
    const double length = point ? 1.0 : aa;
    const double denom = aa * e - bb * bb;
    const bool skew = denom > eps;
    const double inner = clamp01((bb * f - c * e) / (skew ? denom : 1.0));
    const double s0 = skew ? inner : 0.0;
    const double t0 = (bb * s0 + f) / e;
    const double below = clamp01(-c / length), beyond = clamp01((bb - c) / length), alone = clamp01(f / e);
    const double s1 = t0 < 0.0 ? below : (t0 > 1.0 ? beyond : s0);
    const double t1 = t0 < 0.0 ? 0.0 : (t0 > 1.0 ? 1.0 : t0);
    const double s = point ? 0.0 : s1, t = point ? alone : t1;
    const double dx = (p1.x + s * (q1.x - p1.x)) - (start.x + t * (end.x - start.x));
    const double dy = (p1.y + s * (q1.y - p1.y)) - (start.y + t * (end.y - start.y));
    const double dz = (p1.z + s * (q1.z - p1.z)) - (start.z + t * (end.z - start.z));
    out[k - first] = std::sqrt(0.0 + dx * dx + dy * dy + dz * dz);
  }
}

}  // namespace detail

double point_segment_distance(Vec3 c, Vec3 a, Vec3 b);
SegmentParameters closest_segment_points(Vec3 p1, Vec3 q1, Vec3 p2, Vec3 q2);
double segment_segment_distance(Vec3 p1, Vec3 q1, Vec3 p2, Vec3 q2);
void segment_distances_to(const double* a, const double* b, std::size_t first, std::size_t stop, Vec3 p2, Vec3 q2,
                          double* out);

// The minimum over t in [0, 1] of the signed distance of a + t (b - a) to an obstacle: d (m, negative inside), the
// minimising t and the obstacle's outward unit normal (grad d) at that point.
struct SegmentDistance {
  double distance = 0.0;
  double t = 0.0;
  Vec3 normal;
};

// min_t d_i(a + t (b - a)) to packed obstacle i, by the obstacle's kind (see the top of this file); a mesh row naming
// no packed mesh gives NaN, and so does a code that is no Kind (check_packed refuses such codes before a query).
SegmentDistance segment_obstacle_distance(const geometry::PackedView& packed, std::size_t i, Vec3 a, Vec3 b);

// The pieces, for tests and for callers that know the obstacle's kind.
//
// Spheres and capsules (kinds[i] Sphere or Capsule) in closed form. On the centre or axis (distance below 1e-12)
// any direction perpendicular to the segment is a gradient: (-e_y, e_x, 0) normalised when |e_z| < max(|e_x|,
// |e_y|), else (0, -e_z, e_y), and local (0, 0, 1) for a degenerate segment.
SegmentDistance round_segment_distance(const geometry::PackedView& packed, std::size_t i, Vec3 a, Vec3 b);

// The t minimising the signed distance of a + t (b - a) to box i, in closed form. In the box frame the segment is
// p(t) = p0 + t u with excesses e_k(t) = |p_k(t)| - h_k. Outside, g = d^2 = sum_k max(e_k, 0)^2 is convex and C^1,
// g' linear between the breakpoints where some p_k(t) = +-h_k (at most six): the minimiser is an end, or the zero
// of g' interpolated between the last candidate (ends and breakpoints) with g' < 0 and the first with g' >= 0.
// When g is zero there the segment reaches the box, where d = max_k e_k, the largest of six affine functions
// +-p_k(t) - h_k: its minimum is at an end or where two of them cross (ties: the smallest t).
double box_minimiser(const geometry::PackedView& packed, std::size_t i, Vec3 a, Vec3 b);

// Bisection (24 halvings) on the sign of the slope grad d . u in the obstacle's frame: exact for convex kinds.
SegmentDistance convex_minimum(const geometry::PackedView& packed, std::size_t i, Vec3 a, Vec3 b);

// The best of 9 evenly spaced samples, refined by 18 golden-section steps in the bracket of its neighbours (kept
// when the refined bracket is worse: a flat or noisy f).
SegmentDistance mesh_minimum(const geometry::PackedView& packed, std::size_t i, Vec3 a, Vec3 b);

}  // namespace pfield::robot
