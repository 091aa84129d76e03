// The global fallback's search: RRT-Connect with compiled state and edge checks, then shortcutting.
//
// RRT-Connect (Kuffner & LaValle, "RRT-Connect: an efficient approach to single-query path planning", ICRA 2000):
// two trees grow from the start and the goal; each iteration extends one tree by at most `step` toward a uniform
// sample of the box [lower, upper] and then greedily connects the other tree toward the new node; the trees swap
// roles every iteration. The path found is shortened by random shortcutting (Geraerts & Overmars, "Creating
// high-quality paths for motion planning", IJRR 2007) and a final greedy pass.
//
// Two state spaces share the code (StateChecker):
//   * joint space: a state is valid when every link keeps margin + the pair's offset from every obstacle and every
//     self pair keeps margin + its offset (capsules_valid, on the whole-body planner's two-level link model);
//   * point space: an end-effector position in R^3, valid when its signed distance to every obstacle is at least
//     margin.
// An edge is valid when every state on it, interpolated so that no coordinate moves more than `resolution` (rad or
// m) between checks, is valid (planning/segment_free.hpp gives the order).
//
// The random numbers are a xorshift64* stream (Vigna, "An experimental exploration of Marsaglia's xorshift
// generators", 2016) seeded by splitmix64, so a search is a pure function of its seed. Everything here keeps the
// operation order of the numba kernels it replaced (issue 32), so a seed gives the same draws, trees, paths and
// check counts as it did there (tests/planning/test_core_rrt.py holds digests of those kernels' results, beside
// oracles).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "geometry/packed.hpp"
#include "geometry/sdf.hpp"
#include "planning/whole_body.hpp"
#include "robot/clearance.hpp"
#include "robot/robot.hpp"

namespace pfield::planning {

// The splitmix64 mix of `seed` (Steele, Lea & Flood, "Fast splittable pseudorandom number generators", OOPSLA
// 2014): a well-mixed xorshift state, never 0 (a zero state would stay 0).
std::uint64_t seeded_state(std::uint64_t seed);

// The next number in [0, 1) of the xorshift64* stream in `state` (advanced): the top 53 bits of the product.
inline double uniform(std::uint64_t& state) {
  std::uint64_t x = state;
  x ^= x >> 12;
  x ^= x << 25;
  x ^= x >> 27;
  state = x;
  return static_cast<double>((x * 0x2545F4914F6CDD1DULL) >> 11) * (1.0 / 9007199254740992.0);
}

// `count` numbers of the stream into out (for the test that holds the draws to the generator written out in Python
// integers).
void uniforms(std::uint64_t& state, double* out, std::size_t count);

// The scratch of the joint-space state check, sized once per robot: joint frames and world segments; the fitted
// primitives of a link are moved into the world only when some pair of that link reaches the fine level.
struct CapsuleWorkspace {
  explicit CapsuleWorkspace(const robot::RobotView& robot);
  CapsuleWorkspace(const CapsuleWorkspace&) = delete;  // the views point into it
  CapsuleWorkspace& operator=(const CapsuleWorkspace&) = delete;

  std::vector<double> rotations, origins;  // (n, 3, 3), (n, 3)
  std::vector<double> segment_ends;        // capsules a, b (caps, 3) each, then primitives a, b (prims, 3)
  std::vector<unsigned char> placed;       // (caps,) whether the link's primitives are in `world` for this q
  std::vector<robot::AxisMiddle> middles;  // (caps,) each capsule's axis for this q
  // Capsules on one joint (a gripper's links) as a group with one bounding sphere per q: an obstacle that clears the
  // sphere clears each of them without its own signed distance.
  std::vector<std::int64_t> group_of;      // (caps,) the capsule's group, -1 when alone on its joint
  std::vector<robot::AxisMiddle> groups;   // (groups,) each group's sphere for this q: centre and radius
  std::vector<double> group_share;         // (groups,) 1 / its number of capsules
  std::vector<double> group_distance;      // (groups, M) obstacle i's distance from group g's sphere, NaN: not yet
  robot::Frames frames;
  robot::WorldSegments world;
  robot::PrimitivePlacement placement;     // places a link's primitives on first use (flags: placed)
  // The scene's boxes as columns (use_boxes), so that a point's distance to all of them is one SIMD pass: each
  // link's axis midpoint and each group's sphere centre; box_at holds one pass's values.
  geometry::BoxColumns boxes;
  std::vector<double> box_at;              // (boxes,)

  // From now on the checks among these obstacles measure points against their boxes in one pass.
  void use_boxes(const geometry::PackedView& packed);
};

// Whether configuration q keeps every link-obstacle pair (c, i) at least margin + obstacle_offsets[c, i] apart and
// every self pair k at least margin + self_offsets[k], stopping at the first pair that is not. Pairs are decided by
// exact lower bounds first: the signed distance at the capsule axis's midpoint less half its length and the radius
// (d is 1-Lipschitz), the obstacle's bounding sphere against the link's bounding capsule, then the
// two-level distance robot::link_obstacle_distance_below with cutoff = fine_cutoff = that need (which decides
// "below the need" as exact values would). Self pairs on the covering capsules (robot::link_pair_distance), or with
// scene.fitted_self on the fitted primitives, after two lower bounds: the capsules' bounding spheres (centres at
// the axes' midpoints, radii half the axis plus the capsule's), then (fitted) the pair's table where the robot has one
// (robot.pair_tables, robot/pair_tables.hpp: the primitives' own verdict or none), then the capsules themselves.
bool capsules_valid(const robot::RobotView& robot, const WholeBodyScene& scene, const double* q, double margin,
                    CapsuleWorkspace& ws);

// Regions of the state space known to be invalid (issue 34): a state q is in region b when
// sum_j weights[b, j] |q_j - centres[b, j]| < radii[b]. The global fallback adds one where the exact mesh check found
// its searched path in contact: with weights bounding how fast that pair's mesh distance changes (m/rad) and the
// radius the contact's depth plus the search margin, every state of the region is closer than the margin on the
// meshes, whatever the link model says there (a link model that over-covers a pair in one place and under-covers
// it in another, as the UR5's forearm and wrist_2, cannot tell such states from clear ones).
struct ForbiddenRegions {
  std::size_t dimension = 0;
  std::vector<double> centres, weights, radii;  // (B, dimension), (B, dimension), (B,)

  // Whether q (dimension,) lies in some region.
  bool contains(const double* q) const;
};

enum class StateSpace : std::int64_t { Joint = 0, Point = 1 };

// The validity test of one search, counting the states it checks. Views must outlive it.
class StateChecker {
 public:
  // Joint space: the robot's configurations among the scene's obstacles, with its offsets.
  StateChecker(const robot::RobotView& robot, const WholeBodyScene& scene, double margin, double resolution);
  // Point space: positions in R^3 among the packed obstacles.
  StateChecker(const geometry::PackedView& packed, double margin, double resolution);
  StateChecker(const StateChecker&) = delete;
  StateChecker& operator=(const StateChecker&) = delete;

  StateSpace space() const { return space_; }
  std::size_t dimension() const { return dimension_; }
  std::int64_t states_checked() const { return states_checked_; }

  // From now on, states in `region` (ForbiddenRegions of one region: centre, weights (dimension,), radius) are
  // invalid.
  void forbid(const double* centre, const double* weights, double radius);

  // Whether state q (dimension,) is valid; counts one check.
  bool state_valid(const double* q);
  // Whether the straight edge a -> b is valid (a is assumed valid): samples every `resolution`, coarse to fine.
  bool edge_valid(const double* a, const double* b);

 private:
  StateSpace space_;
  std::size_t dimension_;
  const robot::RobotView* robot_ = nullptr;
  const WholeBodyScene* scene_ = nullptr;
  const geometry::PackedView* packed_ = nullptr;
  double margin_, resolution_;
  std::int64_t states_checked_ = 0;
  std::vector<double> point_;  // an edge's sample
  std::unique_ptr<CapsuleWorkspace> capsules_;  // joint space only
  ForbiddenRegions forbidden_;
};

// Both trees of one search: node k of tree t is nodes[(t * capacity + k) * dimension ..], its parent parents[t *
// capacity + k] (-1: a root), counts[t] nodes; `next` the tree that extends next, `random` the xorshift state.
struct Trees {
  // Tree 0 rooted at start (dimension,), tree 1 at every row of goals (goal_count, dimension): several goal
  // configurations of one goal pose, whichever the search reaches first. goal_count <= capacity.
  Trees(const double* start, const double* goals, std::size_t goal_count, std::size_t dimension, std::size_t capacity,
        std::uint64_t seed);

  std::size_t dimension, capacity;
  std::vector<double> nodes;            // (2, capacity, dimension); rows beyond counts[t] unset
  std::vector<std::int64_t> parents;    // (2, capacity)
  std::int64_t counts[2];
  std::int64_t next = 0;
  std::uint64_t random;

  double* node(std::int64_t t, std::int64_t k) { return nodes.data() + (t * capacity + k) * dimension; }
  const double* node(std::int64_t t, std::int64_t k) const { return nodes.data() + (t * capacity + k) * dimension; }
};

enum class SearchStatus : std::int64_t {
  Found = 0,      // a path was found
  Searching = 1,  // the chunk's budget ran out, or *cancel was set (call again, or stop)
  Exhausted = 2,  // a tree is full
};

struct SearchOutcome {
  SearchStatus status = SearchStatus::Searching;
  std::vector<double> path;  // (rows, dimension) from start to a goal root when Found, else empty
  std::size_t rows = 0;
};

// RRT-Connect on `trees` until `budget` more state checks are done (checked before each iteration, so a chunk may
// overrun it by one iteration's checks). lower, upper (dimension,): the sampling box;
// step: the largest extension (Euclidean norm). cancel (or null) is read atomically every iteration: when set, the
// chunk ends (Searching) at once. bound (or null), a count of the checker's states, is read atomically every
// iteration too: no iteration starts once the checker has checked that many (a search racing this one found a path
// with fewer checks, pfield.planning.global_search's race of seeds).
SearchOutcome rrt_connect(StateChecker& checker, Trees& trees, const double* lower, const double* upper, double step,
                          std::int64_t budget, const std::uint8_t* cancel, const std::int64_t* bound = nullptr);

// A shorter valid path through a subset of path's vertices (rows, dimension): `attempts` random shortcuts i -> j
// (drawn from `random`, continuing the search's stream), then a greedy pass joining each kept vertex to the farthest
// later one it sees. Returns the rows of the shortened path.
std::vector<double> shortcut(StateChecker& checker, const double* path, std::size_t rows, std::int64_t attempts,
                             std::uint64_t& random);

// Share of a path's length that a partial shortcut of `shorten` must save to be tried (checked): each tried shortcut
// checks its whole new segment, and most of the shortening's time on MotionBenchMaker's UR5 scenes went to shortcuts
// that each saved a few thousandths of the path. Measured on every valid problem (issue 34, pfield alone, one run
// each): UR5 (700) median plan 27.0 -> 23.4 -> 21.6 ms and p95 224 -> 206 -> 191 ms with 0 / 0.002 / 0.005, median
// path lengths per scene +0.0-2.5 % at 0.005; Panda (399) median 6.8 -> 6.4 ms, lengths +0.0-2.1 %; every problem
// solved, no claim in collision, either way.
constexpr double kLeastShortening = 0.005;

// Shortening with points anywhere on the path (Geraerts & Overmars 2007, "partial" shortcuts between random
// configurations on the path rather than its vertices): each of `attempts` draws two arc-length positions s1 < s2
// (from `random`) on different segments, and replaces the part between the points p(s1), p(s2) by the straight
// segment p(s1) -> p(s2) when the result is shorter by at least kLeastShortening of the path's length, that segment
// passes clearance.edge_valid and p(s1) passes checker.state_valid. The cut pieces (vertex -> p(s1), p(s2) -> next
// vertex) are parts of segments already on the path, whose samples were checked every `resolution`, so they are not
// checked again: re-checking them on their own sample grid was 40-45 % of the states this shortening checked on
// MotionBenchMaker's UR5 table scenes (issue 34). Then the greedy vertex pass of `shortcut` with `clearance` (it never
// lengthens, by the triangle inequality, and drops vertices on a straight line). `clearance` is `checker` or a
// stricter one (a larger margin: a new segment keeps room from the obstacles for the tracking that follows it). Every
// segment of the result passed one of the two edge tests, or is a part of one that did (or of one of `path`'s) whose
// ends passed a state test; its Euclidean length never exceeds the input's. Returns the rows (dimension each).
std::vector<double> shorten(StateChecker& checker, StateChecker& clearance, const double* path, std::size_t rows,
                            std::int64_t attempts, std::uint64_t& random);

// The Euclidean length of a polyline (rows, dimension): the sum of |w_{k+1} - w_k|.
double path_length(const double* path, std::size_t rows, std::size_t dimension);

}  // namespace pfield::planning
