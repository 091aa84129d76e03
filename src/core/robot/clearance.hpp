// Clearances of the two-level link model: link-obstacle and link-link (self) distances, over the robot view of
// robot/robot.hpp. The same operations in the same order as the numba kernels they replaced (issue 32), so the same
// bits (tests/robot/test_core_distance.py holds digests of those kernels' results, beside oracles).
//
// Each link l has a bounding capsule (cap_a[l]-cap_b[l], cap_r[l], containing everything below) and its fitted
// primitives link_start[l] .. link_start[l + 1] (pfield.robot.geometry); self_r[l] is the radius of the ungrown
// covering capsule, used for self pairs (link_pair_distance). Near (bounding capsule closer than kFineRange =
// 10 cm) a link-obstacle distance is the minimum over the link's primitives; farther, the bounding capsule's own
// distance stands for it (a lower bound, at most the capsule's over-approximation off, where a few centimetres do
// not matter and the fine model's cost would be wasted). Every obstacle also has a bounding sphere (centre, bound:
// pfield.planning.whole_body.obstacle_bounds; bound = inf never culls), which gives the cheapest lower bound.
//
// All segment ends here are world points (WorldSegments, filled by capsule_segments / primitive_segments /
// near_segments from the joint frames, or a link's primitives on first use by a PrimitivePlacement). A closest point
// returned is on the deciding segment (the capsule's or the primitive's axis), where the kernels take the point
// Jacobian; the normal points from the obstacle (or from the second link) towards the link.
//
// ONE link-obstacle distance for every caller: link_obstacle_distance_below. Its users in pfield (the numba engine
// gave each its own copy of the two levels; tests/robot/test_core_distance.py replays the assistance's and the whole
// body's loops on it and gets their results to the bit):
//
//   * the clearances (fill_clearances here: pfield.robot.collision, the planners' start offsets): cutoff =
//     fine_cutoff = the value beyond which only "not below it" matters (inf: every pair exact); the RRT's state
//     check (planning/rrt.cpp capsules_valid) likewise with cutoff = its margin + the pair's offset, after its own
//     cheaper tests (the numba kernel passed fine_cutoff = inf there; fine_cutoff = cutoff decides `distance <
//     cutoff` the same way, with fewer primitives evaluated);
//   * the damper rows of the velocity QP (planning/damper_rows.hpp scan_link_obstacle_pairs: the whole-body
//     step's obstacle_rows and the assistance's rows of every pair within Q), cutoff = fine_cutoff = the
//     influence distance Q: a result with level Culled adds only its distance to the step's clearance (min) and is
//     not a candidate for the nearest pair; any other result is (distance less the pair's start offset); exact
//     results still below Q after the offset give a damper row, for links carried by a joint, at `point` along
//     `normal` (the Jacobian of `point` on the link's joint);
//   * the assistance's nearest pair (shared_control/assist.cpp nearest_link), cutoff = fine_cutoff = the
//     best distance so far: a pair replaces the best when exact && distance < best (the hinted pair alone when the
//     caller knows it); its witness point on the link's surface is then point - (d_O(point) - distance) normal,
//     with d_O the obstacle's signed distance at point (d_O(point) - distance is the deciding segment's radius up
//     to rounding; the numba kernel took it that way, so the port keeps that expression rather than
//     prim_r[primitive]).
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>

#include "geometry/packed.hpp"
#include "robot/distance.hpp"
#include "robot/robot.hpp"

namespace pfield::robot {

// (m) link-obstacle pairs whose bounding capsules are at least this far apart use the capsule's distance.
constexpr double kFineRange = 0.1;
// (m) slack of near_segments' test against rounding: a link's primitives are moved into the world frame when its
// bounding capsule's lower bound is below kFineRange + kFineMargin.
constexpr double kFineMargin = 1e-6;

// The obstacles with their bounding spheres: the packed set and, per obstacle, a centre (M, 3) and a radius (M,)
// about it that contains the shape (inf: never culls, every pair exact).
struct ObstacleSet {
  const geometry::PackedView* packed = nullptr;
  const double* centres = nullptr;
  const double* bounds = nullptr;

  std::size_t count() const { return packed->obstacle_count; }
  Vec3 centre(std::size_t i) const { return {centres[3 * i], centres[3 * i + 1], centres[3 * i + 2]}; }
};

// World ends of the link model's segments at one configuration; the caller owns the storage.
struct WorldSegments {
  double* cap_a = nullptr;   // (caps, 3) bounding capsules
  double* cap_b = nullptr;
  double* prim_a = nullptr;  // (prims, 3) fitted primitives
  double* prim_b = nullptr;

  Vec3 capsule_a(std::size_t l) const { return {cap_a[3 * l], cap_a[3 * l + 1], cap_a[3 * l + 2]}; }
  Vec3 capsule_b(std::size_t l) const { return {cap_b[3 * l], cap_b[3 * l + 1], cap_b[3 * l + 2]}; }
};

// Which level answered a link-obstacle pair.
enum class ClearanceLevel : std::int64_t {
  Culled = 0,      // the obstacle's bounding sphere against the link's bounding capsule: a lower bound >= cutoff
  Capsule = 1,     // the bounding capsule: exact at kFineRange or farther, else a lower bound >= fine_cutoff
  Primitives = 2,  // the fitted primitives: exact, or fine_cutoff itself when every primitive is farther
};

// One link-obstacle pair (or the nearest pair of a search). When not exact, distance is a lower bound of the
// pair's clearance, point is 0 and normal (0, 0, 1).
struct LinkObstacleDistance {
  double distance = std::numeric_limits<double>::infinity();  // m, negative in penetration
  bool exact = false;
  ClearanceLevel level = ClearanceLevel::Culled;
  Vec3 point;                     // world closest point on the deciding segment's axis
  Vec3 normal{0.0, 0.0, 1.0};     // the obstacle's outward unit normal there (towards the link)
  std::int64_t link = -1;         // link (bounding capsule) index
  std::int64_t obstacle = -1;     // obstacle index
  std::int64_t primitive = -1;    // the fitted primitive that decided (level Primitives, exact), else -1
};

// A self pair on the covering capsules: distance less both radii, and the closest points of the two segments.
struct LinkPairDistance {
  double distance = 0.0;
  Vec3 first;   // on link l1's segment
  Vec3 second;  // on link l2's segment
};

// World ends of the segments start .. stop (local ends a, b (., 3) carried by joints; joint -1: the base, ends
// copied) into out_a, out_b.
void world_segment_range(const Frames& frames, const std::int64_t* joints, const double* a, const double* b,
                         std::size_t start, std::size_t stop, double* out_a, double* out_b);

// World ends of every bounding capsule, of every fitted primitive.
void capsule_segments(const LinkModelView& links, const Frames& frames, WorldSegments& world);
void primitive_segments(const LinkModelView& links, const Frames& frames, WorldSegments& world);

// A capsule's axis as its midpoint and half length: every point of the capsule lies within half + its radius of
// the midpoint.
struct AxisMiddle {
  Vec3 middle;
  double half;
};

// Each bounding capsule's axis (world.cap_* filled) into middles (caps,).
void axis_middles(const LinkModelView& links, const WorldSegments& world, AxisMiddle* middles);

// (m) how far a bound computed another way must clear a need to decide a pair as the exact value would: far above
// the rounding of distances of a few metres (~1e-15 m), far below any margin.
constexpr double kSphereSlack = 1e-9;

// The distance of two capsules' bounding spheres (axes m1, m2 with radii r1, r2): at most their distance, up to
// rounding (compare it with a need plus kSphereSlack).
inline double sphere_gap(const AxisMiddle& m1, double r1, const AxisMiddle& m2, double r2) {
  const Vec3 apart = m1.middle - m2.middle;
  return std::sqrt(math::dot(apart, apart)) - (m1.half + r1) - (m2.half + r2);
}

// ||c_i - segment|| - bound_i - r: the cheap lower bound of link's clearance to obstacle i (its bounding sphere
// against the link's bounding capsule, world ends in `world`).
inline double capsule_lower_bound(const ObstacleSet& obstacles, std::size_t i, const WorldSegments& world,
                                  const LinkModelView& links, std::size_t link) {
  return detail::point_segment_distance(obstacles.centre(i), world.capsule_a(link), world.capsule_b(link)) -
         obstacles.bounds[i] - links.cap_r[link];
}

// World ends of the fitted primitives of the links that may reach the fine level (world.cap_* already filled):
// only links whose cheap bound is below kFineRange + kFineMargin for some obstacle. The others keep stale values
// that link_obstacle_distance_below never reads: their capsule level answers (its distance is at least the cheap
// bound, so at least kFineRange; the margin covers rounding). Without obstacles nothing is transformed.
// `placement` (optional): places through it, so that its flags record the links placed for this configuration.
struct PrimitivePlacement;
void near_segments(const LinkModelView& links, const Frames& frames, const ObstacleSet& obstacles,
                   WorldSegments& world, const PrimitivePlacement* placement = nullptr);

// The coarse level: the bounding capsule (axis a-b, radius) against obstacle i. At kFineRange or farther the
// capsule's distance stands for the pair (exact, the closest point on the capsule's axis); nearer, not exact and
// distance is a lower bound of the fitted primitives'. Level Capsule; link and obstacle left for the caller.
LinkObstacleDistance capsule_level_distance(const geometry::PackedView& packed, std::size_t i, Vec3 a, Vec3 b,
                                            double radius);

// The fine level: the minimum over the fitted primitives start .. stop (world ends in `world`, radii prim_r) of
// their distance to obstacle i (bounding sphere: centre, reach), exact below fine_cutoff, else some value at least
// fine_cutoff (fine_cutoff itself, not exact, when every primitive is farther). Primitives are skipped by exact
// lower bounds first: the bounding spheres' distance, and for obstacles other than spheres and capsules the
// signed distance at the primitive's midpoint less half its length (d is 1-Lipschitz), that midpoint value also
// bounding the minimum from above. Level Primitives; link and obstacle left for the caller.
LinkObstacleDistance fitted_distance_below(const geometry::PackedView& packed, std::size_t i, Vec3 centre,
                                           double reach, const LinkModelView& links, const WorldSegments& world,
                                           std::size_t start, std::size_t stop, double fine_cutoff);

// Signed clearance (m) of `link` to obstacle i, exact where it matters (fine_cutoff <= cutoff):
//   * the cheap bound (capsule_lower_bound) >= cutoff: that bound, not exact, level Culled;
//   * else the bounding capsule's level; it answers when exact (kFineRange or farther) or when its bound is at
//     least fine_cutoff (not exact);
//   * else the fitted primitives (fitted_distance_below with fine_cutoff).
// Values below fine_cutoff are exact (the fitted model's), bit for bit those of cutoff = fine_cutoff = inf; a
// pair at least fine_cutoff away gets some value at least fine_cutoff (read it as "not below fine_cutoff").
// world.prim_* must hold the link's primitives whenever its cheap bound is below min(cutoff, kFineRange +
// kFineMargin) (near_segments, or primitive_segments), or `placement` places them when the fine level is reached
// (on first use: a link whose capsule level answers is never placed).
LinkObstacleDistance link_obstacle_distance_below(const LinkModelView& links, const WorldSegments& world,
                                                  const ObstacleSet& obstacles, std::size_t link, std::size_t i,
                                                  double cutoff, double fine_cutoff,
                                                  const PrimitivePlacement* placement = nullptr);

// link_obstacle_distance_below with exact values up to cutoff (fine_cutoff = inf).
inline LinkObstacleDistance link_obstacle_distance(const LinkModelView& links, const WorldSegments& world,
                                                   const ObstacleSet& obstacles, std::size_t link, std::size_t i,
                                                   double cutoff) {
  return link_obstacle_distance_below(links, world, obstacles, link, i, cutoff,
                                      std::numeric_limits<double>::infinity());
}

// Clearance between links l1 and l2 on their covering capsules (radii self_r). Self pairs use the single covering
// capsule of each link (it contains the link's collision surface): the SRDF leaves only links that are not close by
// design, and the fitted primitives would cost about a hundred segment pairs per link pair at every step.
LinkPairDistance link_pair_distance(const LinkModelView& links, const WorldSegments& world, std::size_t l1,
                                    std::size_t l2);

// Clearance between links l1 and l2 on their fitted primitives (the model link-obstacle pairs use), exact below
// `cutoff`: when the bounding capsules (radii cap_r, which contain the primitives) are at least cutoff apart, that
// distance (a lower bound, >= cutoff) with the axes' closest points; else the minimum over the primitive pairs of
// the segment-segment distance less both radii, with the closest points on the deciding primitives' axes, or cutoff
// itself (with the bounding capsules' closest points) when no pair is below it. Exact culls: a primitive of l2 not
// below cutoff from l1's bounding capsule, a primitive of l1 not below the best so far from l2's (each bounding
// capsule contains its link's primitives). world.prim_* must hold both links' primitives whenever the bounding
// capsules are closer than cutoff.
//
// Why (issue 34): the covering capsules of link_pair_distance enclose a whole link in one radius; on a UR5 the
// forearm's (8 cm about a 0.4 m axis) overlaps the wrist's by up to 4.4 cm along motions whose meshes are clear, and
// the global search, whose goals fold the wrist over the forearm, found no path in 10 s where it finds one in 0.1 s
// on the fitted primitives.
//
// `placement` (optional): moves a link's primitives into the world when the pair first needs them, so that a caller
// places only the links of pairs whose bounding capsules come within the cutoff (without it, world.prim_* must
// already hold them, as above).
LinkPairDistance fitted_pair_distance_below(const LinkModelView& links, const WorldSegments& world, std::size_t l1,
                                            std::size_t l2, double cutoff,
                                            const PrimitivePlacement* placement = nullptr);

// The one way a link's fitted primitives are moved into the world at the current joint frames: place(link). With
// flags, which links are there for this configuration, each placed once (reset() at every new configuration: the
// frames changed); without (placed null), every call places.
struct PrimitivePlacement {
  const LinkModelView* links = nullptr;
  const Frames* frames = nullptr;
  const WorldSegments* world = nullptr;
  unsigned char* placed = nullptr;  // (caps,) flags, or null

  void reset() const;
  void place(std::size_t link) const;
};

// fitted_pair_distance_below for every self pair at configuration q (n,) into own (pairs,): exact below cutoff (all
// of them by default), some value at least cutoff for the others.
void fitted_self_clearances_at(const KinematicsView& kinematics, const LinkModelView& links, const double* q,
                               double* own, double cutoff = std::numeric_limits<double>::infinity());

// Link-obstacle clearances into obstacle (caps, M) row-major and self-pair clearances into own (pairs,), from the
// world segments; pairs whose bound is >= cutoff get a bound (link_obstacle_distance_below(cutoff, cutoff)).
void fill_clearances(const LinkModelView& links, const WorldSegments& world, const ObstacleSet& obstacles,
                     double cutoff, double* obstacle, double* own);

// Exact clearances at the joint frames: every world segment into `world` (caller storage), then fill_clearances
// with no cutoff.
void clearances(const LinkModelView& links, const Frames& frames, const ObstacleSet& obstacles, WorldSegments& world,
                double* obstacle, double* own);

// clearances at configuration q (n,): the joint frames by forward kinematics (robot/kinematics.hpp), the
// workspace allocated here; the link-obstacle pairs exact below cutoff (fill_clearances), the self pairs exact.
void clearances_at(const KinematicsView& kinematics, const LinkModelView& links, const double* q,
                   const ObstacleSet& obstacles, double* obstacle, double* own,
                   double cutoff = std::numeric_limits<double>::infinity());

// The covering capsules alone at `count` configurations qs (count, n) row-major (the certificate's bound,
// pfield.planning.certify): for configuration k, capsule l against obstacle i, the axis's signed distance
// (segment_obstacle_distance) less self_r[l], into obstacle[(k * caps + l) * M + i]; self pair p
// (link_pair_distance, radii self_r), into own[k * pairs + p]. No cutoff and no fitted primitives: when capsule l
// contains a body, its value is a lower bound of that body's distance wherever segment_obstacle_distance is the
// exact minimum (spheres, capsules, boxes in closed form; cylinders and ellipsoids by bisection, within
// |b - a| 2^-24 of it; meshes sampled: no bound). pfield's certificate passes ellipsoids and meshes as boxes that
// contain them (pfield.robot.collision._covering_proxy), so every pair it asks about has a bound.
void covering_clearances(const KinematicsView& kinematics, const LinkModelView& links, const double* qs,
                         std::size_t count, const geometry::PackedView& packed, double* obstacle, double* own);

// Where along a path the covering capsules cannot vouch for a pair (the certificate's first stage,
// pfield.planning.certify). Pairs p < caps * M are capsule l = p / M against obstacle i = p % M, the others the self
// pairs p - caps * M. Along the configurations qs (count, n), travel (count, n) is the joint travel accumulated
// from qs[0] (sum of |Δq_j|, non-decreasing) and weights (P, n) the motion bound of each pair (m per rad or m):
// reach[k] = sum_j weights[p, j] travel[k, j] bounds how much pair p closes between configurations 0 and k, and
// reach[k'] - reach[k] between k and k' > k. Walking each pair along the path: at configuration k its
// covering_clearances value less slack[p] is a lower bound b of its distance; b > 0 clears k and every following k'
// with reach[k'] < reach[k] + b (conservative advancement: the pair closes by at most reach[k'] - reach[k]), which
// the walk then skips; b <= 0 marks k needed (needed[p * count + k] = 1, else 0). A pair whose slack is not finite
// (a caller's way of saying it has no bound) is needed at every k, its capsule distance not computed.
void covering_needed(const KinematicsView& kinematics, const LinkModelView& links, const double* qs,
                     std::size_t count, const geometry::PackedView& packed, const double* travel,
                     const double* weights, const double* slack, std::uint8_t* needed);

}  // namespace pfield::robot
