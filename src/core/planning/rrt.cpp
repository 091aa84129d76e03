// RRT-Connect and shortcutting (rrt.hpp), statement for statement as the numba kernels it replaced (issue 32): the
// same sums in the same order and Python's min/max tie rules, compiled without fused multiply-adds
// (CMakeLists.txt), so the same draws, the same trees and the same paths.
#include "planning/rrt.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "geometry/sdf.hpp"
#include "planning/segment_free.hpp"
#include "robot/distance.hpp"
#include "robot/kinematics.hpp"
#include "robot/pair_tables.hpp"

namespace pfield::planning {
namespace {

using math::Vec3;
using robot::detail::py_max;

constexpr double kInf = std::numeric_limits<double>::infinity();
using robot::AxisMiddle;
using robot::kSphereSlack;

enum class Extension { Trapped, Advanced, Reached };

struct Extended {
  Extension outcome;
  std::int64_t node;  // the new node, -1 when trapped
};

// The node of tree t's first `count` nodes nearest to q (the first of equals) and its Euclidean distance.
struct Nearest {
  std::int64_t node;
  double distance;
};

Nearest nearest(const Trees& trees, std::int64_t t, std::int64_t count, const double* q) {
  const std::size_t n = trees.dimension;
  double best = kInf;
  std::int64_t best_k = 0;
  for (std::int64_t k = 0; k < count; ++k) {
    const double* node = trees.node(t, k);
    double s = 0.0;
    for (std::size_t j = 0; j < n; ++j) {
      const double diff = node[j] - q[j];
      s += diff * diff;
    }
    if (s < best) best = s, best_k = k;
  }
  return {best_k, std::sqrt(best)};
}

// Grow tree t by at most `step` toward target: a new node at the candidate when the edge to it is valid.
Extended extend(StateChecker& checker, Trees& trees, std::int64_t t, const double* target, double step,
                double* candidate) {
  const std::int64_t count = trees.counts[t];
  if (count >= static_cast<std::int64_t>(trees.capacity)) return {Extension::Trapped, -1};
  const Nearest near = nearest(trees, t, count, target);
  const bool reached = near.distance <= step;
  const double scale = reached ? 1.0 : step / near.distance;
  const double* from = trees.node(t, near.node);
  for (std::size_t j = 0; j < trees.dimension; ++j) candidate[j] = from[j] + scale * (target[j] - from[j]);
  if (!checker.edge_valid(from, candidate)) return {Extension::Trapped, -1};
  std::copy(candidate, candidate + trees.dimension, trees.node(t, count));
  trees.parents[t * trees.capacity + count] = near.node;
  trees.counts[t] = count + 1;
  return {reached ? Extension::Reached : Extension::Advanced, count};
}

// The nodes from the root of tree t to node k, root first.
std::vector<const double*> branch(const Trees& trees, std::int64_t t, std::int64_t k) {
  std::vector<const double*> out;
  for (std::int64_t j = k; j >= 0; j = trees.parents[t * trees.capacity + j]) out.push_back(trees.node(t, j));
  std::reverse(out.begin(), out.end());
  return out;
}

}  // namespace

std::uint64_t seeded_state(std::uint64_t seed) {
  std::uint64_t z = seed + 0x9E3779B97F4A7C15ULL;  // unsigned arithmetic wraps, as the numba engine's uint64 did
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  z = z ^ (z >> 31);
  return z != 0 ? z : 1;
}

void uniforms(std::uint64_t& state, double* out, std::size_t count) {
  for (std::size_t k = 0; k < count; ++k) out[k] = uniform(state);
}

CapsuleWorkspace::CapsuleWorkspace(const robot::RobotView& robot)
    : rotations(9 * robot.kinematics.joint_count),
      origins(3 * robot.kinematics.joint_count),
      segment_ends(6 * (robot.links.capsule_count + robot.links.primitive_count)),
      placed(robot.links.capsule_count),
      middles(robot.links.capsule_count),
      frames{rotations.data(), origins.data()} {
  const std::size_t caps = robot.links.capsule_count, prims = robot.links.primitive_count;
  double* ends = segment_ends.data();
  world = {ends, ends + 3 * caps, ends + 6 * caps, ends + 6 * caps + 3 * prims};
  placement = {&robot.links, &frames, &world, placed.data()};
  // runs of two or more capsules on the same joint (the link model lists a joint's capsules together)
  const std::int64_t* joint = robot.links.cap_joint;
  group_of.assign(caps, -1);
  for (std::size_t c = 0, end = 0; c < caps; c = end) {
    for (end = c + 1; end < caps && joint[end] == joint[c];) ++end;
    if (end - c < 2) continue;
    std::fill(group_of.begin() + static_cast<std::ptrdiff_t>(c), group_of.begin() + static_cast<std::ptrdiff_t>(end),
              static_cast<std::int64_t>(groups.size()));
    groups.push_back({});
    group_share.push_back(1.0 / static_cast<double>(end - c));
  }
}

void CapsuleWorkspace::use_boxes(const geometry::PackedView& packed) {
  boxes = geometry::BoxColumns(packed);
  box_at.assign(boxes.size(), 0.0);
}

bool ForbiddenRegions::contains(const double* q) const {
  for (std::size_t r = 0, count = radii.size(); r < count; ++r) {
    const double* centre = centres.data() + r * dimension;
    const double* weight = weights.data() + r * dimension;
    double s = 0.0;
    for (std::size_t j = 0; j < dimension && s < radii[r]; ++j) s += weight[j] * std::abs(q[j] - centre[j]);
    if (s < radii[r]) return true;
  }
  return false;
}

namespace {

// (m) how far beyond its sphere a group's obstacle distance is computed exactly (the signed distances answer with a
// lower bound beyond their cutoff, which is all the test needs): more than any margin and offset
constexpr double kGroupReach = 1.0;

// Each group's bounding sphere at this q: centred at the mean of its capsules' axis midpoints, reaching the
// farthest capsule surface; the group distances marked not yet computed.
void group_spheres(const robot::LinkModelView& links, CapsuleWorkspace& ws, std::size_t obstacle_count) {
  if (ws.groups.empty()) return;
  for (AxisMiddle& sphere : ws.groups) sphere = {{0.0, 0.0, 0.0}, 0.0};
  for (std::size_t c = 0; c < links.capsule_count; ++c) {
    if (ws.group_of[c] < 0) continue;
    const auto g = static_cast<std::size_t>(ws.group_of[c]);
    ws.groups[g].middle = ws.groups[g].middle + ws.group_share[g] * ws.middles[c].middle;
  }
  for (std::size_t c = 0; c < links.capsule_count; ++c) {
    if (ws.group_of[c] < 0) continue;
    AxisMiddle& sphere = ws.groups[static_cast<std::size_t>(ws.group_of[c])];
    const Vec3 apart = ws.middles[c].middle - sphere.middle;
    sphere.half = py_max(sphere.half, std::sqrt(dot(apart, apart)) + ws.middles[c].half + links.cap_r[c]);
  }
  ws.group_distance.assign(ws.groups.size() * obstacle_count, std::numeric_limits<double>::quiet_NaN());
  if (ws.boxes.size() == 0) return;
  // the boxes' distances from each sphere's centre in one pass (the others on first use)
  for (std::size_t g = 0; g < ws.groups.size(); ++g) {
    ws.boxes.distances(ws.groups[g].middle, ws.box_at.data());
    double* row = ws.group_distance.data() + g * obstacle_count;
    for (std::size_t i = 0; i < obstacle_count; ++i)
      if (ws.boxes.slot[i] >= 0) row[i] = ws.box_at[static_cast<std::size_t>(ws.boxes.slot[i])] - ws.groups[g].half;
  }
}

}  // namespace

bool capsules_valid(const robot::RobotView& robot, const WholeBodyScene& scene, const double* q, double margin,
                    CapsuleWorkspace& ws) {
  const robot::LinkModelView& links = robot.links;
  const robot::ObstacleSet& obstacles = scene.obstacles;
  const geometry::PackedView& packed = *obstacles.packed;
  const std::size_t count = obstacles.count();
  robot::joint_transforms(robot.kinematics, q, ws.frames);
  robot::capsule_segments(links, ws.frames, ws.world);
  ws.placement.reset();
  robot::axis_middles(links, ws.world, ws.middles.data());
  group_spheres(links, ws, count);
  for (std::size_t c = 0; c < links.capsule_count; ++c) {
    const AxisMiddle& axis = ws.middles[c];
    const double radius = links.cap_r[c];
    const std::int64_t group = ws.group_of[c];
    double* group_distance = group >= 0 ? ws.group_distance.data() + static_cast<std::size_t>(group) * count : nullptr;
    // a capsule on its own: its axis midpoint against every box in one pass (a group's members go to their sphere)
    const bool columns = group < 0 && ws.boxes.size() > 0;
    if (columns) ws.boxes.distances(axis.middle, ws.box_at.data());
    for (std::size_t i = 0; i < count; ++i) {
      const double need = margin + scene.obstacle_offsets[c * count + i];
      // the group's sphere first (computed once per obstacle and q): a lower bound of every member's distance
      if (group_distance != nullptr) {
        if (std::isnan(group_distance[i])) {
          const AxisMiddle& sphere = ws.groups[static_cast<std::size_t>(group)];
          group_distance[i] = geometry::obstacle_distance(packed, i, sphere.middle, sphere.half + kGroupReach) -
                              sphere.half;
        }
        if (group_distance[i] >= need + kSphereSlack) continue;
      }
      // the signed distance at the axis's midpoint first: for a long box (a cage's bar, a shelf) the obstacle's
      // bounding sphere bounds nothing, and for a sphere it is the two bounding spheres' distance. Its cutoff: a
      // mesh or an ellipsoid farther than the test needs answers with a lower bound, not its exact distance.
      const std::int64_t box = columns ? ws.boxes.slot[i] : -1;
      const double at_middle = box >= 0 ? ws.box_at[static_cast<std::size_t>(box)]
                                        : geometry::obstacle_distance(packed, i, axis.middle, need + axis.half + radius);
      if (at_middle - axis.half - radius >= need) continue;
      const double lower = robot::capsule_lower_bound(obstacles, i, ws.world, links, c);
      if (lower >= need) continue;
      // the two-level distance; its fine level places the link's primitives on first use
      if (robot::link_obstacle_distance_below(links, ws.world, obstacles, c, i, need, need, &ws.placement).distance <
          need)
        return false;
    }
  }
  for (std::size_t k = 0; k < links.pair_count; ++k) {
    const auto l1 = static_cast<std::size_t>(links.self_pairs[2 * k]);
    const auto l2 = static_cast<std::size_t>(links.self_pairs[2 * k + 1]);
    if (!scene.fitted_self) {
      if (robot::link_pair_distance(links, ws.world, l1, l2).distance - scene.self_offsets[k] < margin) return false;
      continue;
    }
    const double need = margin + scene.self_offsets[k];
    // the bounding spheres, then the bounding capsules (they contain the primitives): most pairs end at one of
    // them, their primitives unplaced. kSphereSlack keeps the spheres' bound below the capsules' distance where
    // the two differ only by rounding, so a pair is decided as without it.
    if (robot::sphere_gap(ws.middles[l1], links.cap_r[l1], ws.middles[l2], links.cap_r[l2]) >= need + kSphereSlack)
      continue;
    // then the pair's table, where it has one: the primitives' own verdict for most states (robot/pair_tables.hpp)
    if (robot.pair_tables != nullptr) {
      const robot::PairVerdict said = robot.pair_tables->verdict(k, q, need);
      if (said == robot::PairVerdict::Clear) continue;
      if (said == robot::PairVerdict::Below) return false;
    }
    // then the capsules, whose primitives are placed only when the pair gets that far; "not below need" comes back
    // as need itself or more: compared with need, not as distance - offset < margin
    if (robot::fitted_pair_distance_below(links, ws.world, l1, l2, need, &ws.placement).distance < need) return false;
  }
  return true;
}

StateChecker::StateChecker(const robot::RobotView& robot, const WholeBodyScene& scene, double margin,
                           double resolution)
    : space_(StateSpace::Joint),
      dimension_(robot.kinematics.joint_count),
      robot_(&robot),
      scene_(&scene),
      packed_(scene.obstacles.packed),
      margin_(margin),
      resolution_(resolution),
      point_(dimension_),
      capsules_(std::make_unique<CapsuleWorkspace>(robot)) {
  capsules_->use_boxes(*scene.obstacles.packed);
}

StateChecker::StateChecker(const geometry::PackedView& packed, double margin, double resolution)
    : space_(StateSpace::Point),
      dimension_(3),
      packed_(&packed),
      margin_(margin),
      resolution_(resolution),
      point_(3) {}

void StateChecker::forbid(const double* centre, const double* weights, double radius) {
  forbidden_.dimension = dimension_;
  forbidden_.centres.insert(forbidden_.centres.end(), centre, centre + dimension_);
  forbidden_.weights.insert(forbidden_.weights.end(), weights, weights + dimension_);
  forbidden_.radii.push_back(radius);
}

bool StateChecker::state_valid(const double* q) {
  ++states_checked_;
  if (forbidden_.contains(q)) return false;
  if (space_ == StateSpace::Point)
    return geometry::min_signed_distance(*packed_, {q[0], q[1], q[2]}).nearest.distance >= margin_;
  return capsules_valid(*robot_, *scene_, q, margin_, *capsules_);
}

bool StateChecker::edge_valid(const double* a, const double* b) {
  double largest = 0.0;
  for (std::size_t j = 0; j < dimension_; ++j) largest = py_max(largest, std::abs(b[j] - a[j]));
  const double ratio = std::ceil(largest / resolution_);
  if (!(ratio < 9.0e18)) return false;  // a non-finite end (numba raised there): no edge, no overflowing cast
  const auto steps = std::max<std::int64_t>(1, static_cast<std::int64_t>(ratio));
  double* point = point_.data();
  return samples_valid(steps, steps, [&](double t) {
    for (std::size_t j = 0; j < dimension_; ++j) point[j] = a[j] + t * (b[j] - a[j]);
    return state_valid(point);
  });
}

Trees::Trees(const double* start, const double* goals, std::size_t goal_count, std::size_t dimension,
             std::size_t capacity, std::uint64_t seed)
    : dimension(dimension),
      capacity(capacity),
      nodes(2 * capacity * dimension),
      parents(2 * capacity, -1),
      counts{1, static_cast<std::int64_t>(goal_count)},
      random(seeded_state(seed)) {
  std::copy(start, start + dimension, node(0, 0));
  std::copy(goals, goals + goal_count * dimension, node(1, 0));
}

SearchOutcome rrt_connect(StateChecker& checker, Trees& trees, const double* lower, const double* upper, double step,
                          std::int64_t budget, const std::uint8_t* cancel, const std::int64_t* bound) {
  const std::size_t n = trees.dimension;
  const auto capacity = static_cast<std::int64_t>(trees.capacity);
  std::vector<double> sample(n), candidate(n), target(n);
  const std::int64_t stop = checker.states_checked() + budget;
  SearchOutcome outcome;
  while (checker.states_checked() < stop) {
    if (cancel != nullptr && __atomic_load_n(cancel, __ATOMIC_RELAXED) != 0) return outcome;  // Searching
    if (bound != nullptr && checker.states_checked() >= __atomic_load_n(bound, __ATOMIC_RELAXED)) return outcome;
    if (trees.counts[0] >= capacity || trees.counts[1] >= capacity) {
      outcome.status = SearchStatus::Exhausted;
      return outcome;
    }
    const std::int64_t a = trees.next, b = 1 - a;
    trees.next = b;
    for (std::size_t j = 0; j < n; ++j) sample[j] = lower[j] + uniform(trees.random) * (upper[j] - lower[j]);
    const Extended grown = extend(checker, trees, a, sample.data(), step, candidate.data());
    if (grown.outcome == Extension::Trapped) continue;
    std::copy(trees.node(a, grown.node), trees.node(a, grown.node) + n, target.begin());
    Extended connected{Extension::Advanced, -1};
    std::int64_t other = -1;
    while (connected.outcome == Extension::Advanced) {
      connected = extend(checker, trees, b, target.data(), step, candidate.data());
      if (connected.outcome != Extension::Trapped) other = connected.node;
    }
    if (connected.outcome != Extension::Reached) continue;
    // tree 0's branch, then tree 1's reversed without its last node (the meeting point, already in the first)
    const std::vector<const double*> from_a = branch(trees, a, grown.node), from_b = branch(trees, b, other);
    const std::vector<const double*>& first = a == 0 ? from_a : from_b;
    const std::vector<const double*>& second = a == 0 ? from_b : from_a;
    outcome.rows = first.size() + second.size() - 1;
    outcome.path.resize(outcome.rows * n);
    double* out = outcome.path.data();
    for (const double* row : first) out = std::copy(row, row + n, out);
    for (std::size_t i = 0; i + 1 < second.size(); ++i) out = std::copy(second[second.size() - 2 - i],
                                                                       second[second.size() - 2 - i] + n, out);
    outcome.status = SearchStatus::Found;
    return outcome;
  }
  return outcome;
}

std::vector<double> shortcut(StateChecker& checker, const double* path, std::size_t rows, std::int64_t attempts,
                             std::uint64_t& random) {
  const std::size_t n = checker.dimension();
  if (rows == 0) return {};
  std::vector<unsigned char> keep(rows, 1);
  std::vector<std::size_t> index(rows);
  for (std::size_t k = 0; k < rows; ++k) index[k] = k;
  std::size_t count = rows;
  const auto vertex = [&](std::size_t k) { return path + index[k] * n; };
  for (std::int64_t attempt = 0; attempt < attempts; ++attempt) {
    if (count <= 2) break;
    auto i = static_cast<std::size_t>(uniform(random) * static_cast<double>(count));
    auto j = static_cast<std::size_t>(uniform(random) * static_cast<double>(count));
    if (i > j) std::swap(i, j);
    if (j - i < 2) continue;
    if (checker.edge_valid(vertex(i), vertex(j))) {
      for (std::size_t k = i + 1; k < j; ++k) keep[index[k]] = 0;
      count = 0;
      for (std::size_t k = 0; k < rows; ++k)
        if (keep[k]) index[count++] = k;
    }
  }
  std::vector<double> out(vertex(0), vertex(0) + n);
  std::size_t i = 0;
  while (i + 1 < count) {
    std::size_t j = count - 1;
    while (j > i + 1 && !checker.edge_valid(vertex(i), vertex(j))) --j;
    out.insert(out.end(), vertex(j), vertex(j) + n);
    i = j;
  }
  return out;
}

namespace {

double segment_length(const double* a, const double* b, std::size_t n) {
  double s = 0.0;
  for (std::size_t j = 0; j < n; ++j) s += (b[j] - a[j]) * (b[j] - a[j]);
  return std::sqrt(s);
}

// The point at arc length s of the polyline whose cumulative lengths are `cumulative` (count,), into out; returns
// its segment k (cumulative[k] <= s, k <= count - 2).
std::size_t point_at(const std::vector<double>& path, const std::vector<double>& cumulative, std::size_t n, double s,
                     double* out) {
  const std::size_t count = cumulative.size();
  auto k = static_cast<std::size_t>(std::upper_bound(cumulative.begin(), cumulative.end(), s) - cumulative.begin());
  k = std::min(k == 0 ? 0 : k - 1, count - 2);
  const double length = cumulative[k + 1] - cumulative[k];
  const double t = length > 0.0 ? std::clamp((s - cumulative[k]) / length, 0.0, 1.0) : 0.0;
  const double* a = path.data() + k * n;
  const double* b = a + n;
  for (std::size_t j = 0; j < n; ++j) out[j] = a[j] + t * (b[j] - a[j]);
  return k;
}

}  // namespace

double path_length(const double* path, std::size_t rows, std::size_t dimension) {
  double total = 0.0;
  for (std::size_t k = 0; k + 1 < rows; ++k) total += segment_length(path + k * dimension, path + (k + 1) * dimension,
                                                                     dimension);
  return total;
}

std::vector<double> shorten(StateChecker& checker, StateChecker& clearance, const double* path, std::size_t rows,
                            std::int64_t attempts, std::uint64_t& random) {
  const std::size_t n = checker.dimension();
  if (rows == 0) return {};
  std::vector<double> current(path, path + rows * n), next, cumulative;
  std::vector<double> a(n), b(n);
  const std::int64_t patience = std::max<std::int64_t>(attempts / 4, 1);  // fruitless attempts in a row: stop
  std::int64_t fruitless = 0;
  for (std::int64_t attempt = 0; attempt < attempts && fruitless < patience; ++attempt) {
    ++fruitless;
    const std::size_t count = current.size() / n;
    if (count < 3) break;  // one segment is straight already
    cumulative.assign(count, 0.0);
    for (std::size_t k = 1; k < count; ++k)
      cumulative[k] = cumulative[k - 1] + segment_length(&current[(k - 1) * n], &current[k * n], n);
    const double total = cumulative.back();
    double s1 = uniform(random) * total, s2 = uniform(random) * total;
    if (s1 > s2) std::swap(s1, s2);
    const std::size_t i = point_at(current, cumulative, n, s1, a.data());
    const std::size_t k = point_at(current, cumulative, n, s2, b.data());
    if (k <= i) continue;  // both points on one segment: straight already
    const double* before = &current[i * n];     // the vertex before p(s1)
    const double* after = &current[(k + 1) * n];  // the vertex after p(s2)
    const double length = cumulative[i] + segment_length(before, a.data(), n) + segment_length(a.data(), b.data(), n) +
                          segment_length(b.data(), after, n) + (total - cumulative[k + 1]);
    if (!(length < total - kLeastShortening * total)) continue;  // too little to pay for the new segment's check
    // the cut pieces before -> p(s1) and p(s2) -> after are parts of segments already on the path, whose samples
    // were checked: only the new segment is checked as an edge (it checks p(s2) as its last sample), and p(s1), a
    // point between two checked samples, as a state
    if (!clearance.edge_valid(a.data(), b.data()) || !checker.state_valid(a.data())) continue;
    next.assign(current.begin(), current.begin() + static_cast<std::ptrdiff_t>((i + 1) * n));
    if (segment_length(before, a.data(), n) > 0.0) next.insert(next.end(), a.begin(), a.end());
    if (segment_length(b.data(), after, n) > 0.0) next.insert(next.end(), b.begin(), b.end());
    next.insert(next.end(), current.begin() + static_cast<std::ptrdiff_t>((k + 1) * n), current.end());
    current.swap(next);
    fruitless = 0;
  }
  // the greedy vertex pass (no random shortcuts: attempts 0), which also drops vertices on a straight line
  return shortcut(clearance, current.data(), current.size() / n, 0, random);
}

}  // namespace pfield::planning
