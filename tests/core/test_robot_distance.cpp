// The link distances (src/core/robot/distance, clearance) on cases whose answers are exact: crossing, parallel and
// degenerate segment pairs; segments beside, through and along spheres, boxes and cylinders; and a two-link robot
// whose pairs fall to each level of the link model. Run under the sanitizers (the loops' indexing).
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include "geometry/packed.hpp"
#include "harness.hpp"
#include "robot/clearance.hpp"
#include "robot/distance.hpp"
#include "robot/kinematics.hpp"
#include "robot/robot.hpp"

namespace {

using namespace pfield::robot;
using pfield::geometry::Kind;
using pfield::geometry::kRowWidth;
using pfield::geometry::PackedView;

constexpr double kInf = std::numeric_limits<double>::infinity();

// Primitive obstacles (no meshes) at identity orientation: rows of centre c and sizes s.
struct Scene {
  std::vector<std::int64_t> kinds;
  std::vector<double> rows;
  std::vector<double> centres, bounds;

  void add(Kind kind, Vec3 c, Vec3 s, double bound) {
    kinds.push_back(static_cast<std::int64_t>(kind));
    const std::array<double, kRowWidth> row{c.x, c.y, c.z, 1, 0, 0, 0, 1, 0, 0, 0, 1, s.x, s.y, s.z, -1.0};
    rows.insert(rows.end(), row.begin(), row.end());
    centres.insert(centres.end(), {c.x, c.y, c.z});
    bounds.push_back(bound);
  }
  PackedView view() const {
    PackedView v;
    v.kinds = kinds.data();
    v.rows = rows.data();
    v.obstacle_count = kinds.size();
    return v;
  }
};

}  // namespace

TEST(closest_points_of_crossing_parallel_and_degenerate_segments) {
  const SegmentParameters cross = closest_segment_points({0, 0, 0}, {1, 0, 0}, {0.5, -1, 1}, {0.5, 1, 1});
  CHECK(cross.s == 0.5 && cross.t == 0.5);
  CHECK(segment_segment_distance({0, 0, 0}, {1, 0, 0}, {0.5, -1, 1}, {0.5, 1, 1}) == 1.0);
  // parallel (a e - b^2 = 0): s = 0 first, then t clamped to 0 and s recomputed from it
  const SegmentParameters parallel = closest_segment_points({0, 0, 0}, {1, 0, 0}, {0.25, 1, 0}, {2, 1, 0});
  CHECK(parallel.s == 0.25 && parallel.t == 0.0);
  CHECK(segment_segment_distance({0, 0, 0}, {1, 0, 0}, {0.25, 1, 0}, {2, 1, 0}) == 1.0);
  // points: a == b on either side, or both
  const SegmentParameters point = closest_segment_points({0.5, 0.5, 0}, {0.5, 0.5, 0}, {0, 0, 0}, {1, 0, 0});
  CHECK(point.s == 0.0 && point.t == 0.5);
  CHECK(segment_segment_distance({0, 0, 0}, {0, 0, 0}, {0, 0.75, 0}, {0, 0.75, 0}) == 0.75);
  CHECK(point_segment_distance({0.5, 0.5, 0}, {0, 0, 0}, {1, 0, 0}) == 0.5);
  CHECK(point_segment_distance({2, 0, 0}, {0, 0, 0}, {1, 0, 0}) == 1.0);      // beyond the end
  CHECK(point_segment_distance({0, 0.5, 0}, {1, 0, 0}, {1, 0, 0}) == std::sqrt(1.25));  // a point segment
  CHECK(closest_parameter({0.5, 0, 0}, {1e-8, 0, 0}, 1e-16) == 0.0);      // shorter than 1e-7 m: a point
}

// The batch form the fitted self pairs cull with is the pairwise distance bit for bit, in every branch: skew and
// crossing segments, t clamped below and above, parallel ones, point segments on either side, against a proper
// and a degenerate second segment, and rows after an offset `first`.
TEST(segment_distances_to_a_segment_are_the_pairwise_distances_bit_for_bit) {
  std::vector<double> a, b;
  const auto add = [&](Vec3 p, Vec3 q) {
    a.insert(a.end(), {p.x, p.y, p.z});
    b.insert(b.end(), {q.x, q.y, q.z});
  };
  add({0, 0, 0}, {1, 0, 0});             // not used: before `first`
  add({0.5, -1, 1}, {0.5, 1, 1});        // crossing above the middle
  add({0.25, 1, 0}, {2, 1, 0});          // parallel
  add({-3, 0.5, 0}, {-2, 0.5, 0.3});     // beyond the start: t clamped to 0
  add({3, 0.5, 0}, {4, -0.5, 0.3});      // beyond the end: t clamped to 1
  add({0.5, 0.5, 0}, {0.5, 0.5, 0});     // a point
  add({0.3, 0.2, 0.1}, {0.3, 0.2, 0.1 + 1e-8});  // shorter than 1e-7 m: a point
  std::uint64_t random = 0x9E3779B97F4A7C15ULL;  // and skew segments at random (xorshift64)
  const auto next = [&] {
    random ^= random << 13, random ^= random >> 7, random ^= random << 17;
    return static_cast<double>(random >> 11) * (4.0 / 9007199254740992.0) - 2.0;
  };
  for (int k = 0; k < 40; ++k) add({next(), next(), next()}, {next(), next(), next()});
  const std::size_t rows = a.size() / 3;
  for (const auto& [p2, q2] : {std::pair<Vec3, Vec3>{{0, 0, 0}, {1, 0, 0}}, {{0.1, 0.2, 0.3}, {-0.4, 0.9, 0.2}},
                               {{0.2, 0.1, 0}, {0.2, 0.1, 0}}}) {
    std::vector<double> out(rows - 1, -1.0);
    segment_distances_to(a.data(), b.data(), 1, rows, p2, q2, out.data());
    for (std::size_t k = 1; k < rows; ++k)
      CHECK(out[k - 1] == segment_segment_distance({a[3 * k], a[3 * k + 1], a[3 * k + 2]},
                                                   {b[3 * k], b[3 * k + 1], b[3 * k + 2]}, p2, q2));
  }
}

TEST(segments_beside_through_and_along_round_obstacles) {
  Scene scene;
  scene.add(Kind::Sphere, {0, 0, 0}, {0.25, 0, 0}, 0.25);
  scene.add(Kind::Capsule, {0, 0, 0}, {0.125, 0.5, 0}, 0.625);
  const PackedView packed = scene.view();
  const SegmentDistance beside = segment_obstacle_distance(packed, 0, {-1, 0.5, 0}, {1, 0.5, 0});
  CHECK(beside.distance == 0.25 && beside.t == 0.5 && beside.normal.y == 1.0);
  // through the centre: any normal perpendicular to the segment; (-e_y, e_x, 0) here, with its signed zero
  const SegmentDistance through = segment_obstacle_distance(packed, 0, {-1, 0, 0}, {1, 0, 0});
  CHECK(through.distance == -0.25 && through.t == 0.5);
  CHECK(through.normal.x == 0.0 && std::signbit(through.normal.x) && through.normal.y == 1.0);
  // along the capsule's axis: on it, (0, -e_z, e_y) normalised
  const SegmentDistance along = segment_obstacle_distance(packed, 1, {0, 0, -1}, {0, 0, 1});
  CHECK(along.distance == -0.125 && along.normal.x == 0.0 && along.normal.y == -1.0 && along.normal.z == 0.0);
  // a degenerate segment: the point's own distance
  const SegmentDistance point = segment_obstacle_distance(packed, 1, {0.5, 0, 0.25}, {0.5, 0, 0.25});
  CHECK(point.distance == 0.375 && point.t == 0.0 && point.normal.x == 1.0);
}

TEST(segments_beside_and_through_a_box_and_a_cylinder) {
  Scene scene;
  scene.add(Kind::Box, {0, 0, 0}, {0.25, 0.125, 0.5}, 0.6);
  scene.add(Kind::Cylinder, {0, 0, 0}, {0.25, 0.5, 0}, 0.6);
  const PackedView packed = scene.view();
  // parallel to the +x face, 0.25 off: a flat minimum
  const SegmentDistance beside = segment_obstacle_distance(packed, 0, {0.5, -1, 0}, {0.5, 1, 0});
  CHECK(beside.distance == 0.25 && beside.normal.x == 1.0 && beside.t >= 0.4375 && beside.t <= 0.5625);
  // through along x: deepest (-0.125, by the y faces) from x = -0.125 on; the smallest t wins the tie
  const SegmentDistance through = segment_obstacle_distance(packed, 0, {-1, 0, 0}, {1, 0, 0});
  CHECK(through.distance == -0.125 && through.t == 0.4375 && through.normal.x == -1.0);
  CHECK(box_minimiser(packed, 0, {-1, 0, 0}, {1, 0, 0}) == 0.4375);
  // the cylinder by bisection: within 2^-24 of t = 1/2
  const SegmentDistance side = segment_obstacle_distance(packed, 1, {1, -1, 0}, {1, 1, 0});
  CHECK_NEAR(side.distance, 0.75, 1e-12);
  CHECK_NEAR(side.t, 0.5, 1e-7);
  CHECK_NEAR(side.normal.x, 1.0, 1e-12);
  const SegmentDistance start = convex_minimum(packed, 1, {0.5, 0, 0}, {1, 0, 0});  // moving away: t = 0
  CHECK(start.t == 0.0 && start.distance == 0.25);
}

TEST(a_two_link_robot_reaches_each_level_of_the_link_model) {
  // joint 0 turns about z at the origin; link 0 (the base, joint -1) is a post, link 1 an arm along x carrying two
  // fitted spheres
  const std::vector<std::int64_t> parents{-1}, kinds{0};
  const std::vector<double> place_rot{1, 0, 0, 0, 1, 0, 0, 0, 1}, place_pos{0, 0, 0}, axes{0, 0, 1};
  KinematicsView kinematics;
  kinematics.joint_count = 1;
  kinematics.parents = parents.data();
  kinematics.place_rot = place_rot.data();
  kinematics.place_pos = place_pos.data();
  kinematics.axes = axes.data();
  kinematics.kinds = kinds.data();
  const std::vector<std::int64_t> cap_joint{-1, 0}, self_pairs{0, 1}, link_start{0, 1, 3}, prim_joint{-1, 0, 0};
  const std::vector<double> cap_a{0, 0, 0, 0.25, 0, 0.5}, cap_b{0, 0, 0.5, 1, 0, 0.5}, cap_r{0.125, 0.125},
      self_r{0.0625, 0.0625};
  const std::vector<double> prim_a{0, 0, 0, 0.5, 0, 0.5, 1, 0, 0.5}, prim_b{0, 0, 0.5, 0.5, 0, 0.5, 1, 0, 0.5},
      prim_r{0.0625, 0.0625, 0.0625};
  LinkModelView links{2, cap_joint.data(), cap_a.data(), cap_b.data(), cap_r.data(), self_r.data(), 1,
                      self_pairs.data(), 3, link_start.data(), prim_joint.data(), prim_a.data(), prim_b.data(),
                      prim_r.data()};
  Scene scene;
  scene.add(Kind::Sphere, {0.5, 0, 0.75}, {0.125, 0, 0}, 0.125);   // above the arm's first sphere: near
  scene.add(Kind::Sphere, {0.5, 0, 2.5}, {0.25, 0, 0}, 0.25);      // far above everything
  const PackedView packed = scene.view();
  const ObstacleSet obstacles{&packed, scene.centres.data(), scene.bounds.data()};
  std::vector<double> rotations(9), origins(3), caps(12), prims(18);
  Frames frames{rotations.data(), origins.data()};
  const double q0 = 0.0;
  pfield::robot::joint_transforms(kinematics, &q0, frames);
  WorldSegments world{caps.data(), caps.data() + 6, prims.data(), prims.data() + 9};
  capsule_segments(links, frames, world);
  primitive_segments(links, frames, world);

  // near: the arm's capsule is 0.125 - 0.125 = 0 away, so its primitives decide: the sphere at x = 0.5
  const LinkObstacleDistance near = link_obstacle_distance(links, world, obstacles, 1, 0, kInf);
  CHECK(near.exact && near.level == ClearanceLevel::Primitives && near.primitive == 1);
  CHECK(near.distance == 0.0625 && near.normal.z == -1.0 && near.point.x == 0.5 && near.point.z == 0.5);
  CHECK(near.link == 1 && near.obstacle == 0);
  // far: the bounding capsule stands for the pair
  const LinkObstacleDistance far = link_obstacle_distance(links, world, obstacles, 1, 1, kInf);
  CHECK(far.exact && far.level == ClearanceLevel::Capsule && far.distance == 2.0 - 0.25 - 0.125);
  // culled: the cheap bound is at least the cutoff
  const LinkObstacleDistance culled = link_obstacle_distance_below(links, world, obstacles, 1, 1, 1.0, 1.0);
  CHECK(!culled.exact && culled.level == ClearanceLevel::Culled && culled.distance >= 1.0);
  // every primitive beyond fine_cutoff: fine_cutoff itself, not exact
  const LinkObstacleDistance cut = link_obstacle_distance_below(links, world, obstacles, 1, 0, 0.01, 0.01);
  CHECK(!cut.exact && cut.level == ClearanceLevel::Primitives && cut.distance == 0.01);
  // the self pair: post (x = 0) and arm (from x = 0.25), both at radius 1/16
  const LinkPairDistance pair = link_pair_distance(links, world, 0, 1);
  CHECK(pair.distance == 0.125 && pair.first.z == 0.5 && pair.second.x == 0.25);

  std::vector<double> at_q(4), own_q(1), at_frames(4), own_frames(1);
  clearances_at(kinematics, links, &q0, obstacles, at_q.data(), own_q.data());
  clearances(links, frames, obstacles, world, at_frames.data(), own_frames.data());
  CHECK(at_q == at_frames && own_q == own_frames && own_q[0] == 0.125 && at_q[2] == 0.0625);

  // near_segments: only the arm is near an obstacle, so only its primitives move (the post's stays stale)
  std::vector<double> stale(18, -7.0);
  WorldSegments partial{caps.data(), caps.data() + 6, stale.data(), stale.data() + 9};
  near_segments(links, frames, obstacles, partial);
  CHECK(stale[0] == -7.0 && stale[3] == 0.5 && stale[5] == 0.5);

  // placement on first use: a pair the capsule level answers places nothing, one that reaches the fine level places
  // its link's primitives (once: the flag holds them for this configuration) and gets the same value
  std::vector<double> lazy(18, -7.0);
  WorldSegments unplaced{caps.data(), caps.data() + 6, lazy.data(), lazy.data() + 9};
  std::vector<unsigned char> placed(2, 0);
  const PrimitivePlacement placement{&links, &frames, &unplaced, placed.data()};
  const LinkObstacleDistance answered = link_obstacle_distance_below(links, unplaced, obstacles, 1, 1, kInf, kInf,
                                                                     &placement);
  CHECK(answered.level == ClearanceLevel::Capsule && placed[1] == 0 && lazy[3] == -7.0);
  const LinkObstacleDistance fine = link_obstacle_distance_below(links, unplaced, obstacles, 1, 0, kInf, kInf,
                                                                 &placement);
  CHECK(placed[0] == 0 && placed[1] == 1 && lazy[0] == -7.0 && lazy[3] == 0.5 && lazy[5] == 0.5);
  CHECK(fine.level == ClearanceLevel::Primitives && fine.distance == near.distance && fine.primitive == 1);

  // the bounding spheres' gap of the two capsules: centres 0.625 apart in x and 0.25 in z, half lengths 0.25 and
  // 0.375, radii 1/16: at most the capsules' distance (0.125)
  std::vector<AxisMiddle> middles(2);
  axis_middles(links, world, middles.data());
  CHECK(middles[0].half == 0.25 && middles[0].middle.z == 0.25 && middles[1].half == 0.375);
  const double gap = sphere_gap(middles[0], 0.0625, middles[1], 0.0625);
  CHECK(gap == std::sqrt(0.625 * 0.625 + 0.25 * 0.25) - 0.3125 - 0.4375 && gap <= pair.distance);
}
