// Every expression keeps the operand order of the numba kernels this file replaced (issue 32), Python's min keeps its
// tie rule, and this file is compiled without fused multiply-adds (CMakeLists.txt): the same bits as those kernels
// (tests/robot/test_core_distance.py holds digests of their results).
#include "robot/clearance.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "geometry/sdf.hpp"
#include "robot/kinematics.hpp"

namespace pfield::robot {
namespace {

using detail::py_min;
using geometry::Kind;
using geometry::PackedView;

constexpr double kInf = std::numeric_limits<double>::infinity();

Vec3 point_at(const double* rows, std::size_t k) { return {rows[3 * k], rows[3 * k + 1], rows[3 * k + 2]}; }

// A result that is not exact: a lower bound, no point, normal (0, 0, 1).
LinkObstacleDistance bound_only(double distance, ClearanceLevel level) {
  LinkObstacleDistance out;
  out.distance = distance;
  out.exact = false;
  out.level = level;
  return out;
}

}  // namespace

void world_segment_range(const Frames& frames, const std::int64_t* joints, const double* a, const double* b,
                         std::size_t start, std::size_t stop, double* out_a, double* out_b) {
  // a run of segments on one joint (a link's primitives) with that joint's frame in registers, as transform_point
  // computes each coordinate (the same bits), so that the loop runs in SIMD lanes
  for (std::size_t c = start, end = start; c < stop; c = end) {
    const std::int64_t joint = joints[c];
    for (end = c + 1; end < stop && joints[end] == joint;) ++end;
    if (joint < 0) {  // the base: the ends as they are
      std::copy(a + 3 * c, a + 3 * end, out_a + 3 * c);
      std::copy(b + 3 * c, b + 3 * end, out_b + 3 * c);
      continue;
    }
    const double* rotation = frames.rotation(joint);
    const double r0 = rotation[0], r1 = rotation[1], r2 = rotation[2], r3 = rotation[3], r4 = rotation[4];
    const double r5 = rotation[5], r6 = rotation[6], r7 = rotation[7], r8 = rotation[8];
    const double o0 = frames.origins[3 * joint], o1 = frames.origins[3 * joint + 1], o2 = frames.origins[3 * joint + 2];
#pragma omp simd
    for (std::size_t k = c; k < end; ++k) {
      const double ax = a[3 * k], ay = a[3 * k + 1], az = a[3 * k + 2];
      const double bx = b[3 * k], by = b[3 * k + 1], bz = b[3 * k + 2];
      out_a[3 * k] = r0 * ax + r1 * ay + r2 * az + o0;
      out_a[3 * k + 1] = r3 * ax + r4 * ay + r5 * az + o1;
      out_a[3 * k + 2] = r6 * ax + r7 * ay + r8 * az + o2;
      out_b[3 * k] = r0 * bx + r1 * by + r2 * bz + o0;
      out_b[3 * k + 1] = r3 * bx + r4 * by + r5 * bz + o1;
      out_b[3 * k + 2] = r6 * bx + r7 * by + r8 * bz + o2;
    }
  }
}

void capsule_segments(const LinkModelView& links, const Frames& frames, WorldSegments& world) {
  world_segment_range(frames, links.cap_joint, links.cap_a, links.cap_b, 0, links.capsule_count, world.cap_a,
                      world.cap_b);
}

void primitive_segments(const LinkModelView& links, const Frames& frames, WorldSegments& world) {
  world_segment_range(frames, links.prim_joint, links.prim_a, links.prim_b, 0, links.primitive_count, world.prim_a,
                      world.prim_b);
}

void near_segments(const LinkModelView& links, const Frames& frames, const ObstacleSet& obstacles,
                   WorldSegments& world, const PrimitivePlacement* placement) {
  const PrimitivePlacement unflagged{&links, &frames, &world, nullptr};
  const PrimitivePlacement& place = placement != nullptr ? *placement : unflagged;
  const std::size_t count = obstacles.count();
  for (std::size_t link = 0; link < links.capsule_count; ++link) {
    bool near = false;
    for (std::size_t i = 0; i < count && !near; ++i)
      near = capsule_lower_bound(obstacles, i, world, links, link) < kFineRange + kFineMargin;
    if (near) place.place(link);
  }
}

LinkObstacleDistance capsule_level_distance(const PackedView& packed, std::size_t i, Vec3 a, Vec3 b, double radius) {
  const SegmentDistance s = segment_obstacle_distance(packed, i, a, b);
  const double d = s.distance - radius;
  if (!(d >= kFineRange)) return bound_only(d, ClearanceLevel::Capsule);
  // far: the bounding capsule's distance (a lower bound of the fitted model's) stands for the pair
  LinkObstacleDistance out;
  out.distance = d;
  out.exact = true;
  out.level = ClearanceLevel::Capsule;
  out.point = {a.x + s.t * (b.x - a.x), a.y + s.t * (b.y - a.y), a.z + s.t * (b.z - a.z)};
  out.normal = s.normal;
  return out;
}

LinkObstacleDistance fitted_distance_below(const PackedView& packed, std::size_t i, Vec3 centre, double reach,
                                           const LinkModelView& links, const WorldSegments& world,
                                           std::size_t start, std::size_t stop, double fine_cutoff) {
  LinkObstacleDistance out;  // best: distance inf, point 0, normal (0, 0, 1)
  out.exact = true;
  out.level = ClearanceLevel::Primitives;
  const auto kind = static_cast<Kind>(packed.kinds[i]);
  const bool round_obstacle = kind == Kind::Sphere || kind == Kind::Capsule;
  // nothing whose lower bound exceeds `limit` can be the minimum: the best exact value so far, or an upper bound
  // (a segment's midpoint is one of its points, so d(midpoint) - r_p >= the minimum)
  double limit = fine_cutoff;
  for (std::size_t p = start; p < stop; ++p) {
    const Vec3 a = point_at(world.prim_a, p), b = point_at(world.prim_b, p);
    const double radius = links.prim_r[p];
    const Vec3 e = b - a;
    const double length2 = math::dot(e, e);
    // the bounding spheres' bound: the residual of the obstacle's centre off the primitive's axis, taken as
    // (c - a) - u e (the point-segment distance takes c - (a + u e): a different rounding; kept as numba had it)
    const Vec3 o = centre - a;
    const double u = closest_parameter(o, e, length2);
    const double fx = o.x - u * e.x, fy = o.y - u * e.y, fz = o.z - u * e.z;
    if (std::sqrt(fx * fx + fy * fy + fz * fz) - reach - radius > limit) continue;
    if (!round_obstacle) {
      // a signed distance is 1-Lipschitz: d(s(t)) >= d(midpoint) - half the segment's length; and the midpoint's
      // own value bounds the minimum from above
      const Vec3 middle_point{a.x + 0.5 * e.x, a.y + 0.5 * e.y, a.z + 0.5 * e.z};
      const double middle = geometry::obstacle_signed_distance(packed, i, middle_point, kInf).distance - radius;
      limit = py_min(limit, middle);
      if (middle - 0.5 * std::sqrt(length2) > limit) continue;
    }
    const SegmentDistance s = segment_obstacle_distance(packed, i, a, b);
    const double d = s.distance - radius;
    if (d < out.distance) {
      out.distance = d;
      out.normal = s.normal;
      out.point = {a.x + s.t * e.x, a.y + s.t * e.y, a.z + s.t * e.z};
      out.primitive = static_cast<std::int64_t>(p);
      limit = py_min(limit, out.distance);
    }
  }
  if (out.distance == kInf && fine_cutoff < kInf) return bound_only(fine_cutoff, ClearanceLevel::Primitives);
  return out;
}

LinkObstacleDistance link_obstacle_distance_below(const LinkModelView& links, const WorldSegments& world,
                                                  const ObstacleSet& obstacles, std::size_t link, std::size_t i,
                                                  double cutoff, double fine_cutoff,
                                                  const PrimitivePlacement* placement) {
  LinkObstacleDistance out;
  const double lower = capsule_lower_bound(obstacles, i, world, links, link);
  if (lower >= cutoff) {
    out = bound_only(lower, ClearanceLevel::Culled);
  } else {
    out = capsule_level_distance(*obstacles.packed, i, world.capsule_a(link), world.capsule_b(link),
                                 links.cap_r[link]);
    if (!out.exact && !(out.distance >= fine_cutoff)) {
      if (placement != nullptr) placement->place(link);
      out = fitted_distance_below(*obstacles.packed, i, obstacles.centre(i), obstacles.bounds[i], links, world,
                                  static_cast<std::size_t>(links.link_start[link]),
                                  static_cast<std::size_t>(links.link_start[link + 1]), fine_cutoff);
    }
  }
  out.link = static_cast<std::int64_t>(link);
  out.obstacle = static_cast<std::int64_t>(i);
  return out;
}

namespace {
// The closest points of segments a1-b1 and a2-b2 and their distance less r1 and r2.
LinkPairDistance segment_pair(Vec3 a1, Vec3 b1, double r1, Vec3 a2, Vec3 b2, double r2) {
  const SegmentParameters st = detail::closest_segment_points(a1, b1, a2, b2);
  const Vec3 p1{a1.x + st.s * (b1.x - a1.x), a1.y + st.s * (b1.y - a1.y), a1.z + st.s * (b1.z - a1.z)};
  const Vec3 p2{a2.x + st.t * (b2.x - a2.x), a2.y + st.t * (b2.y - a2.y), a2.z + st.t * (b2.z - a2.z)};
  const double dx = p1.x - p2.x, dy = p1.y - p2.y, dz = p1.z - p2.z;
  return {std::sqrt(dx * dx + dy * dy + dz * dz) - r1 - r2, p1, p2};
}

Vec3 row3(const double* rows, std::size_t k) { return {rows[3 * k], rows[3 * k + 1], rows[3 * k + 2]}; }
}  // namespace

LinkPairDistance link_pair_distance(const LinkModelView& links, const WorldSegments& world, std::size_t l1,
                                    std::size_t l2) {
  return segment_pair(world.capsule_a(l1), world.capsule_b(l1), links.self_r[l1], world.capsule_a(l2),
                      world.capsule_b(l2), links.self_r[l2]);
}

void axis_middles(const LinkModelView& links, const WorldSegments& world, AxisMiddle* middles) {
  for (std::size_t c = 0; c < links.capsule_count; ++c) {
    const Vec3 a = world.capsule_a(c), b = world.capsule_b(c);
    double half = 0.0;
    half += (b.x - a.x) * (b.x - a.x);
    half += (b.y - a.y) * (b.y - a.y);
    half += (b.z - a.z) * (b.z - a.z);
    middles[c] = {{0.5 * (a.x + b.x), 0.5 * (a.y + b.y), 0.5 * (a.z + b.z)}, 0.5 * std::sqrt(half)};
  }
}

void PrimitivePlacement::reset() const {
  if (placed != nullptr) std::fill(placed, placed + links->capsule_count, 0);
}

void PrimitivePlacement::place(std::size_t link) const {
  if (placed != nullptr && placed[link]) return;
  world_segment_range(*frames, links->prim_joint, links->prim_a, links->prim_b,
                      static_cast<std::size_t>(links->link_start[link]),
                      static_cast<std::size_t>(links->link_start[link + 1]), world->prim_a, world->prim_b);
  if (placed != nullptr) placed[link] = 1;
}

LinkPairDistance fitted_pair_distance_below(const LinkModelView& links, const WorldSegments& world, std::size_t l1,
                                            std::size_t l2, double cutoff, const PrimitivePlacement* placement) {
  const Vec3 a1 = world.capsule_a(l1), b1 = world.capsule_b(l1), a2 = world.capsule_a(l2), b2 = world.capsule_b(l2);
  const LinkPairDistance bounding = segment_pair(a1, b1, links.cap_r[l1], a2, b2, links.cap_r[l2]);
  const auto first1 = static_cast<std::size_t>(links.link_start[l1]);
  const auto stop1 = static_cast<std::size_t>(links.link_start[l1 + 1]);
  const auto first2 = static_cast<std::size_t>(links.link_start[l2]);
  const auto stop2 = static_cast<std::size_t>(links.link_start[l2 + 1]);
  if (bounding.distance >= cutoff || first1 == stop1 || first2 == stop2) return bounding;
  if (placement != nullptr) {
    placement->place(l1);
    placement->place(l2);
  }
  // each link's primitives measured against the other's bounding capsule (which contains the other's primitives),
  // in one vectorised pass each: l2's that reach below the cutoff from l1's capsule are the candidates
  thread_local std::vector<double> apart;
  thread_local std::vector<std::size_t> near;
  apart.resize(std::max(stop1 - first1, stop2 - first2));
  detail::segment_distances_to(world.prim_a, world.prim_b, first2, stop2, a1, b1, apart.data());
  near.clear();
  for (std::size_t j = first2; j < stop2; ++j)
    if (apart[j - first2] - links.prim_r[j] - links.cap_r[l1] < cutoff) near.push_back(j);
  LinkPairDistance best{cutoff, bounding.first, bounding.second};  // "not below the cutoff" unless a pair is
  if (near.empty()) return best;
  detail::segment_distances_to(world.prim_a, world.prim_b, first1, stop1, a2, b2, apart.data());
  for (std::size_t i = first1; i < stop1; ++i) {
    const double ri = links.prim_r[i];
    // l2's bounding capsule contains its primitives: none of them is nearer primitive i than it
    if (apart[i - first1] - ri - links.cap_r[l2] >= best.distance) continue;
    const Vec3 pa = row3(world.prim_a, i), pb = row3(world.prim_b, i);
    for (const std::size_t j : near) {
      const LinkPairDistance d =
          segment_pair(pa, pb, ri, row3(world.prim_a, j), row3(world.prim_b, j), links.prim_r[j]);
      if (d.distance < best.distance) best = d;
    }
  }
  return best;
}

namespace {

// The link model placed at one configuration q: its joint frames and world segments, owning their buffers (for the
// one-configuration entry points; loops keep their own buffers across configurations).
class PlacedLinks {
 public:
  PlacedLinks(const KinematicsView& kinematics, const LinkModelView& links, const double* q)
      : rotations_(9 * kinematics.joint_count), origins_(3 * kinematics.joint_count),
        caps_(6 * links.capsule_count), prims_(6 * links.primitive_count),
        frames{rotations_.data(), origins_.data()},
        world{caps_.data(), caps_.data() + 3 * links.capsule_count, prims_.data(),
              prims_.data() + 3 * links.primitive_count} {
    joint_transforms(kinematics, q, frames);
    capsule_segments(links, frames, world);
    primitive_segments(links, frames, world);
  }
  PlacedLinks(const PlacedLinks&) = delete;  // frames and world point into this object's buffers
  PlacedLinks& operator=(const PlacedLinks&) = delete;

 private:
  std::vector<double> rotations_, origins_, caps_, prims_;

 public:
  Frames frames;
  WorldSegments world;
};

}  // namespace

void fitted_self_clearances_at(const KinematicsView& kinematics, const LinkModelView& links, const double* q,
                               double* own, double cutoff) {
  const PlacedLinks placed(kinematics, links, q);
  for (std::size_t k = 0; k < links.pair_count; ++k)
    own[k] = fitted_pair_distance_below(links, placed.world, static_cast<std::size_t>(links.self_pairs[2 * k]),
                                        static_cast<std::size_t>(links.self_pairs[2 * k + 1]), cutoff)
                 .distance;
}

void fill_clearances(const LinkModelView& links, const WorldSegments& world, const ObstacleSet& obstacles,
                     double cutoff, double* obstacle, double* own) {
  const std::size_t count = obstacles.count();
  for (std::size_t link = 0; link < links.capsule_count; ++link)
    for (std::size_t i = 0; i < count; ++i)
      obstacle[link * count + i] =
          link_obstacle_distance_below(links, world, obstacles, link, i, cutoff, cutoff).distance;
  for (std::size_t k = 0; k < links.pair_count; ++k)
    own[k] = link_pair_distance(links, world, static_cast<std::size_t>(links.self_pairs[2 * k]),
                                static_cast<std::size_t>(links.self_pairs[2 * k + 1]))
                 .distance;
}

void clearances(const LinkModelView& links, const Frames& frames, const ObstacleSet& obstacles, WorldSegments& world,
                double* obstacle, double* own) {
  capsule_segments(links, frames, world);
  primitive_segments(links, frames, world);
  fill_clearances(links, world, obstacles, kInf, obstacle, own);
}

void clearances_at(const KinematicsView& kinematics, const LinkModelView& links, const double* q,
                   const ObstacleSet& obstacles, double* obstacle, double* own, double cutoff) {
  const PlacedLinks placed(kinematics, links, q);
  fill_clearances(links, placed.world, obstacles, cutoff, obstacle, own);
}

void covering_clearances(const KinematicsView& kinematics, const LinkModelView& links, const double* qs,
                         std::size_t count, const PackedView& packed, double* obstacle, double* own) {
  const std::size_t n = kinematics.joint_count, caps = links.capsule_count, m = packed.obstacle_count;
  std::vector<double> rotations(9 * n), origins(3 * n), ends(6 * caps);
  Frames frames{rotations.data(), origins.data()};
  WorldSegments world{ends.data(), ends.data() + 3 * caps, nullptr, nullptr};
  for (std::size_t k = 0; k < count; ++k) {
    joint_transforms(kinematics, qs + k * n, frames);
    capsule_segments(links, frames, world);
    double* row = obstacle + k * caps * m;
    for (std::size_t l = 0; l < caps; ++l)
      for (std::size_t i = 0; i < m; ++i)
        row[l * m + i] =
            segment_obstacle_distance(packed, i, world.capsule_a(l), world.capsule_b(l)).distance - links.self_r[l];
    for (std::size_t p = 0; p < links.pair_count; ++p)
      own[k * links.pair_count + p] =
          link_pair_distance(links, world, static_cast<std::size_t>(links.self_pairs[2 * p]),
                             static_cast<std::size_t>(links.self_pairs[2 * p + 1]))
              .distance;
  }
}

void covering_needed(const KinematicsView& kinematics, const LinkModelView& links, const double* qs,
                     std::size_t count, const PackedView& packed, const double* travel, const double* weights,
                     const double* slack, std::uint8_t* needed) {
  const std::size_t n = kinematics.joint_count, caps = links.capsule_count, m = packed.obstacle_count;
  const std::size_t pairs = caps * m + links.pair_count;
  std::vector<double> rotations(9 * n), origins(3 * n), ends(6 * caps * count);  // per k: caps a, then caps b
  std::vector<double> reach(count);
  const double* reached = nullptr;  // the weights `reach` was computed with
  Frames frames{rotations.data(), origins.data()};
  const auto world_at = [&](std::size_t k) {
    double* a = ends.data() + 6 * caps * k;
    return WorldSegments{a, a + 3 * caps, nullptr, nullptr};
  };
  for (std::size_t k = 0; k < count; ++k) {
    joint_transforms(kinematics, qs + k * n, frames);
    WorldSegments world = world_at(k);
    capsule_segments(links, frames, world);
  }
  for (std::size_t p = 0; p < pairs; ++p) {
    std::uint8_t* out = needed + p * count;
    if (!(slack[p] < kInf)) {  // no bound for this pair (the caller's infinite slack): needed everywhere, not computed
      std::fill(out, out + count, std::uint8_t{1});
      continue;
    }
    const double* w = weights + p * n;
    // a pair's reach along the path, computed again only when its weights differ from the last computed pair's (an
    // object's obstacle pairs share its weights: the reach is computed once per object, not once per obstacle)
    if (reached == nullptr || !std::equal(w, w + n, reached)) {
      for (std::size_t k = 0; k < count; ++k) {
        double sum = 0.0;
        for (std::size_t j = 0; j < n; ++j) sum += w[j] * travel[k * n + j];
        reach[k] = sum;
      }
      reached = w;
    }
    const double* row = reach.data();
    std::size_t k = 0;
    while (k < count) {
      const WorldSegments world = world_at(k);
      double bound;
      if (p < caps * m) {
        const std::size_t l = p / m, i = p % m;
        bound = segment_obstacle_distance(packed, i, world.capsule_a(l), world.capsule_b(l)).distance -
                links.self_r[l];
      } else {
        const std::size_t s = p - caps * m;
        bound = link_pair_distance(links, world, static_cast<std::size_t>(links.self_pairs[2 * s]),
                                   static_cast<std::size_t>(links.self_pairs[2 * s + 1]))
                    .distance;
      }
      bound -= slack[p];
      if (!(bound > 0.0)) {
        out[k++] = 1;
        continue;
      }
      // clear from k up to (not including) the first k' whose reach is at least reach[k] + bound
      const std::size_t stop =
          static_cast<std::size_t>(std::lower_bound(row + k + 1, row + count, row[k] + bound) - row);
      for (; k < stop; ++k) out[k] = 0;
    }
  }
}

}  // namespace pfield::robot
