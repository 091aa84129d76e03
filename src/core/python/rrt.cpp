// Bindings of the global fallback (pfield.planning.global_search): a thin list of defs over planning/rrt.hpp (the
// search: its state checker, trees, RRT-Connect and shortcutting) and planning/track.hpp (the field's tracking of
// the searched path, the capsule overlap test of the tracked motion). No arithmetic here: the core computes.
//
// A Robot binds pfield.planning._whole_body_layout.RobotArrays once, a Scene the packed obstacles with their
// bounding spheres and offsets for that robot (both read in place). They hold the same arrays as
// pfield._core.whole_body's Robot and Scene, whose classes live in that binding file's private namespace; when they
// move into a shared binding header, these two go and the functions below take those.
#include <nanobind/nanobind.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/tuple.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "planning/rrt.hpp"
#include "planning/track.hpp"
#include "planning/whole_body.hpp"
#include "python/arrays.hpp"
#include "python/packed.hpp"
#include "robot/robot.hpp"

namespace pfield::python {
// A named namespace, not an anonymous one: nanobind tells bound C++ types apart by their type names, and
// pfield._core.whole_body's Robot, Scene and robot_distance's Obstacles are pfield::python::(anonymous)::Robot ...
namespace global_search {

using namespace nb::literals;
using planning::SearchStatus;
using planning::StateChecker;
using planning::StepResult;
using planning::Trees;
using planning::WholeBodyParams;

using Ints = nb::ndarray<const std::int64_t, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
using IntMatrix = nb::ndarray<const std::int64_t, nb::ndim<2>, nb::c_contig, nb::device::cpu>;
using Pairs = nb::ndarray<const std::int64_t, nb::shape<-1, 2>, nb::c_contig, nb::device::cpu>;
using Rotations = nb::ndarray<const double, nb::shape<-1, 3, 3>, nb::c_contig, nb::device::cpu>;
using Matrix = nb::ndarray<const double, nb::ndim<2>, nb::c_contig, nb::device::cpu>;
using Matrix3 = nb::ndarray<const double, nb::shape<3, 3>, nb::c_contig, nb::device::cpu>;
using Point = nb::ndarray<const double, nb::shape<3>, nb::c_contig, nb::device::cpu>;
using Quaternion = nb::ndarray<const double, nb::shape<4>, nb::c_contig, nb::device::cpu>;
using Cancel = nb::ndarray<const std::uint8_t, nb::shape<1>, nb::c_contig, nb::device::cpu>;
template <int Columns>
using OutRows = nb::ndarray<double, nb::shape<-1, Columns>, nb::c_contig, nb::device::cpu>;
using OutMatrix = nb::ndarray<double, nb::ndim<2>, nb::c_contig, nb::device::cpu>;
using OutVector = nb::ndarray<double, nb::ndim<1>, nb::c_contig, nb::device::cpu>;

constexpr std::size_t kParamCount = sizeof(WholeBodyParams) / sizeof(double);
static_assert(kParamCount == 20, "WholeBodyParams is _whole_body_layout.PARAMS's 20 doubles");

void require(bool condition, const std::string& message) {
  if (!condition) throw std::invalid_argument(message);
}

bool joints_within(const std::int64_t* joints, std::size_t count, std::size_t n) {
  return std::all_of(joints, joints + count,
                     [n](std::int64_t j) { return j >= -1 && j < static_cast<std::int64_t>(n); });
}

// RobotArrays, read in place for the object's life, every index checked once.
class Robot {
 public:
  Robot(const Ints& parents, const Rotations& place_rot, const Rows<3>& place_pos, const Rows<3>& axes,
        const Ints& kinds, const IntMatrix& support, std::int64_t ee_joint, const Matrix3& ee_rot, const Point& ee_pos,
        const Ints& cap_joint, const Rows<3>& cap_a, const Rows<3>& cap_b, const Vector& cap_r, const Pairs& self_pairs,
        const Vector& lower, const Vector& upper, const Vector& max_velocity, const Vector& max_acceleration,
        const Ints& link_start, const Ints& prim_joint, const Rows<3>& prim_a, const Rows<3>& prim_b,
        const Vector& prim_r, const Vector& self_r)
      : ints_{parents, kinds, cap_joint, link_start, prim_joint},
        support_(support),
        pairs_(self_pairs),
        rotations_(place_rot),
        ee_rot_(ee_rot),
        ee_pos_(ee_pos),
        rows_{place_pos, axes, cap_a, cap_b, prim_a, prim_b},
        vectors_{cap_r, lower, upper, max_velocity, max_acceleration, prim_r, self_r} {
    const std::size_t n = parents.shape(0), caps = cap_joint.shape(0), prims = prim_joint.shape(0);
    require(n > 0, "robot: needs at least one joint");
    require(place_rot.shape(0) == n && place_pos.shape(0) == n && axes.shape(0) == n && kinds.shape(0) == n &&
                support.shape(0) == n && support.shape(1) == n && lower.shape(0) == n && upper.shape(0) == n &&
                max_velocity.shape(0) == n && max_acceleration.shape(0) == n,
            "robot: the kinematic arrays and limits need one entry per joint (support: n x n)");
    for (std::size_t i = 0; i < n; ++i) {
      require(parents.data()[i] >= -1 && parents.data()[i] < static_cast<std::int64_t>(i),
              "robot: parents must list joints in tree order (-1 <= parent < child)");
      require(kinds.data()[i] == 0 || kinds.data()[i] == 1, "robot: kinds must be 0 (revolute) or 1 (prismatic)");
    }
    require(ee_joint >= -1 && ee_joint < static_cast<std::int64_t>(n), "robot: ee_joint out of range");
    require(cap_a.shape(0) == caps && cap_b.shape(0) == caps && cap_r.shape(0) == caps && self_r.shape(0) == caps,
            "robot: cap_a, cap_b (caps, 3), cap_r, self_r (caps,) must match cap_joint");
    require(prim_a.shape(0) == prims && prim_b.shape(0) == prims && prim_r.shape(0) == prims,
            "robot: prim_a, prim_b (prims, 3), prim_r (prims,) must match prim_joint");
    require(joints_within(cap_joint.data(), caps, n) && joints_within(prim_joint.data(), prims, n),
            "robot: a capsule's or primitive's joint is out of range");
    require(link_start.shape(0) == caps + 1, "robot: link_start must have caps + 1 entries");
    const std::int64_t* start = link_start.data();
    require(start[0] >= 0 && start[caps] <= static_cast<std::int64_t>(prims),
            "robot: link_start must lie within the primitives");
    for (std::size_t l = 0; l < caps; ++l) require(start[l] <= start[l + 1], "robot: link_start must not decrease");
    const std::int64_t* pairs = self_pairs.data();
    for (std::size_t k = 0; k < 2 * self_pairs.shape(0); ++k)
      require(pairs[k] >= 0 && pairs[k] < static_cast<std::int64_t>(caps), "robot: self pair out of range");
    view_.kinematics = {n,           parents.data(), place_rot.data(), place_pos.data(), axes.data(), kinds.data(),
                        support.data(), ee_joint,     ee_rot.data(),    ee_pos.data()};
    view_.links = {caps,          cap_joint.data(),    cap_a.data(), cap_b.data(), cap_r.data(),
                   self_r.data(), self_pairs.shape(0), pairs,        prims,        link_start.data(),
                   prim_joint.data(), prim_a.data(),   prim_b.data(), prim_r.data()};
    view_.limits = {lower.data(), upper.data(), max_velocity.data(), max_acceleration.data()};
  }

  const robot::RobotView& view() const { return view_; }
  std::size_t joints() const { return view_.kinematics.joint_count; }

 private:
  // the arrays, kept alive for the views
  Ints ints_[5];
  IntMatrix support_;
  Pairs pairs_;
  Rotations rotations_;
  Matrix3 ee_rot_;
  Point ee_pos_;
  Rows<3> rows_[6];
  Vector vectors_[7];
  robot::RobotView view_;
};

// The packed obstacles (PackedObstacles' eight arrays), bounding spheres and start offsets for one robot.
class Scene {
 public:
  Scene(const Robot& robot, const Kinds& kinds, const Rows<16>& rows, const Triangles& triangles,
        const PseudoNormals& pseudo_normals, const Rows<3>& bvh_lower, const Rows<3>& bvh_upper, const Nodes& bvh_nodes,
        const MeshTable& mesh_table, const Rows<3>& centres, const Vector& bounds, const Matrix& obstacle_offsets,
        const Vector& self_offsets)
      : kinds_(kinds), rows_(rows), triangles_(triangles), pseudo_normals_(pseudo_normals), bvh_lower_(bvh_lower),
        bvh_upper_(bvh_upper), bvh_nodes_(bvh_nodes), mesh_table_(mesh_table), centres_(centres), bounds_(bounds),
        obstacle_offsets_(obstacle_offsets), self_offsets_(self_offsets),
        packed_(packed_view(kinds, rows, triangles, pseudo_normals, bvh_lower, bvh_upper, bvh_nodes, mesh_table)) {
    const std::size_t count = kinds.shape(0);
    const robot::LinkModelView& links = robot.view().links;
    require(centres.shape(0) == count && bounds.shape(0) == count,
            "scene: centres (M, 3) and bounds (M,) need one row per obstacle");
    require(obstacle_offsets.shape(0) == links.capsule_count && obstacle_offsets.shape(1) == count,
            "scene: obstacle_offsets must be (caps, M)");
    require(self_offsets.shape(0) == links.pair_count, "scene: self_offsets must have one entry per self pair");
    view_ = {{&packed_, centres.data(), bounds.data()}, obstacle_offsets.data(), self_offsets.data()};
    capsule_count_ = links.capsule_count;
    pair_count_ = links.pair_count;
  }

  const planning::WholeBodyScene& view() const { return view_; }
  void require_fits(const Robot& robot) const {
    require(robot.view().links.capsule_count == capsule_count_ && robot.view().links.pair_count == pair_count_,
            "scene: built for another robot");
  }

 private:
  Kinds kinds_;
  Rows<16> rows_;
  Triangles triangles_;
  PseudoNormals pseudo_normals_;
  Rows<3> bvh_lower_, bvh_upper_;
  Nodes bvh_nodes_;
  MeshTable mesh_table_;
  Rows<3> centres_;
  Vector bounds_;
  Matrix obstacle_offsets_;
  Vector self_offsets_;
  geometry::PackedView packed_;
  planning::WholeBodyScene view_;
  std::size_t capsule_count_ = 0, pair_count_ = 0;
};

// Packed obstacles alone (the point space's).
class Obstacles {
 public:
  Obstacles(const Kinds& kinds, const Rows<16>& rows, const Triangles& triangles, const PseudoNormals& pseudo_normals,
            const Rows<3>& bvh_lower, const Rows<3>& bvh_upper, const Nodes& bvh_nodes, const MeshTable& mesh_table)
      : kinds_(kinds), rows_(rows), triangles_(triangles), pseudo_normals_(pseudo_normals), bvh_lower_(bvh_lower),
        bvh_upper_(bvh_upper), bvh_nodes_(bvh_nodes), mesh_table_(mesh_table),
        packed_(packed_view(kinds, rows, triangles, pseudo_normals, bvh_lower, bvh_upper, bvh_nodes, mesh_table)) {}

  const geometry::PackedView& view() const { return packed_; }

 private:
  Kinds kinds_;
  Rows<16> rows_;
  Triangles triangles_;
  PseudoNormals pseudo_normals_;
  Rows<3> bvh_lower_, bvh_upper_;
  Nodes bvh_nodes_;
  MeshTable mesh_table_;
  geometry::PackedView packed_;
};

// A rows x columns NumPy copy of `data`.
NumpyArray matrix(const double* data, std::size_t rows, std::size_t columns) {
  auto [array, out] = new_array({rows, columns});
  std::copy(data, data + rows * columns, out);
  return array;
}

// One search's validity test (the core's StateChecker) with what it views kept alive.
class Checker {
 public:
  Checker(nb::object robot, nb::object scene, double margin, double resolution)
      : owners_{std::move(robot), std::move(scene)} {
    const Robot& bound = nb::cast<const Robot&>(owners_[0]);
    const Scene& where = nb::cast<const Scene&>(owners_[1]);
    where.require_fits(bound);
    checker_ = std::make_unique<StateChecker>(bound.view(), where.view(), margin, resolution);
  }
  explicit Checker(nb::object obstacles, double margin, double resolution) : owners_{std::move(obstacles)} {
    checker_ = std::make_unique<StateChecker>(nb::cast<const Obstacles&>(owners_[0]).view(), margin, resolution);
  }

  std::size_t dimension() const { return checker_->dimension(); }
  std::int64_t states_checked() const { return checker_->states_checked(); }

  void require_state(const Vector& q, const char* name) const {
    require(q.shape(0) == dimension(), std::string(name) + ": expected one value per dimension of the state space");
  }

  bool state_valid(const Vector& q) {
    require_state(q, "q");
    return checker_->state_valid(q.data());
  }

  bool edge_valid(const Vector& a, const Vector& b) {
    require_state(a, "a");
    require_state(b, "b");
    nb::gil_scoped_release release;
    return checker_->edge_valid(a.data(), b.data());
  }

  std::tuple<SearchStatus, NumpyArray> connect(Trees& trees, const Vector& lower, const Vector& upper, double step,
                                               std::int64_t budget, std::optional<Cancel> cancel) {
    const std::size_t n = dimension();
    require(trees.dimension == n, "trees: built for another state space");
    require_state(lower, "lower");
    require_state(upper, "upper");
    planning::SearchOutcome outcome;
    {
      nb::gil_scoped_release release;
      outcome = planning::rrt_connect(*checker_, trees, lower.data(), upper.data(), step, budget,
                                      cancel ? cancel->data() : nullptr);
    }
    return {outcome.status, matrix(outcome.path.data(), outcome.rows, n)};
  }

  NumpyArray shortcut(const Matrix& path, std::int64_t attempts, Trees& trees) {
    const std::size_t n = dimension();
    require(path.shape(1) == n && path.shape(0) > 0, "path: expected (K >= 1, dimension)");
    std::vector<double> out;
    {
      nb::gil_scoped_release release;
      out = planning::shortcut(*checker_, path.data(), path.shape(0), attempts, trees.random);
    }
    return matrix(out.data(), out.size() / n, n);
  }

 private:
  std::vector<nb::object> owners_;  // kept alive: the checker views their arrays
  std::unique_ptr<StateChecker> checker_;
};

struct TrackOutcome {
  std::int64_t status;
  std::int64_t count;
  StepResult last;
};

TrackOutcome track_path(const Robot& robot, const Scene& scene, const Vector& q0, const Matrix& waypoints,
                        const Point& goal_position, const Quaternion& goal_orientation, const Vector& params,
                        std::int64_t max_iterations, double gain, double lead, const Cancel& cancel,
                        OutMatrix& joints, OutMatrix& velocities, OutRows<3>& positions, OutRows<4>& orientations,
                        OutRows<6>& twists, OutVector& clearances) {
  scene.require_fits(robot);
  const std::size_t n = robot.joints();
  require(params.shape(0) == kParamCount, "params: expected _whole_body_layout.PARAMS's 20 numbers");
  require(max_iterations >= 0, "max_iterations: expected >= 0");
  require(q0.shape(0) == n && waypoints.shape(1) == n && waypoints.shape(0) > 0,
          "q0 (n,), waypoints (K >= 1, n): one value per joint");
  const auto rows = static_cast<std::size_t>(max_iterations) + 1;
  require(joints.shape(0) >= rows && joints.shape(1) == n && velocities.shape(0) >= rows &&
              velocities.shape(1) == n && positions.shape(0) >= rows && orientations.shape(0) >= rows &&
              twists.shape(0) >= rows && clearances.shape(0) >= rows,
          "track: the outputs need max_iterations + 1 rows (joints, velocities: n columns)");
  WholeBodyParams p{};
  std::copy(params.data(), params.data() + kParamCount, reinterpret_cast<double*>(&p));
  const double* g = goal_position.data();
  const double* o = goal_orientation.data();
  const planning::Goal goal{{g[0], g[1], g[2]}, {o[0], o[1], o[2], o[3]}};
  planning::WholeBodyPlanResult result;
  {
    nb::gil_scoped_release release;
    result = planning::track_path(
        q0.data(), waypoints.data(), waypoints.shape(0), robot.view(), scene.view(), goal, p,
        {max_iterations, gain, lead}, cancel.data(),
        {joints.data(), velocities.data(), positions.data(), orientations.data(), twists.data(), clearances.data()});
  }
  return {static_cast<std::int64_t>(result.status), result.count, result.last};
}

}  // namespace global_search

void bind_rrt(nb::module_& m) {
  using namespace global_search;
  m.doc() = "The global fallback: RRT-Connect, shortcutting and the field's tracking of the searched path "
            "(pfield.planning.global_search's compiled core).";
  nb::enum_<SearchStatus>(m, "SearchStatus", "How a chunk of the search ended.")
      .value("FOUND", SearchStatus::Found, "a path was found")
      .value("SEARCHING", SearchStatus::Searching, "the chunk's budget ran out, or the cancel flag was set")
      .value("EXHAUSTED", SearchStatus::Exhausted, "a tree is full");

  m.def("seeded_state", &planning::seeded_state, "seed"_a, "The xorshift state a search seeded by seed starts from.");
  m.def(
      "uniforms",
      [](std::uint64_t state, std::size_t count) {
        auto [array, out] = new_array({count});
        planning::uniforms(state, out, count);
        return std::make_tuple(array, state);
      },
      "state"_a, "count"_a, "(count numbers in [0, 1) of the xorshift64* stream from state, the state after them).");

  nb::class_<Robot>(m, "Robot", "A robot's RobotArrays (pfield.planning._whole_body_layout), read in place.")
      .def(nb::init<const Ints&, const Rotations&, const Rows<3>&, const Rows<3>&, const Ints&, const IntMatrix&,
                    std::int64_t, const Matrix3&, const Point&, const Ints&, const Rows<3>&, const Rows<3>&,
                    const Vector&, const Pairs&, const Vector&, const Vector&, const Vector&, const Vector&,
                    const Ints&, const Ints&, const Rows<3>&, const Rows<3>&, const Vector&, const Vector&>(),
           "parents"_a, "place_rot"_a, "place_pos"_a, "axes"_a, "kinds"_a, "support"_a, "ee_joint"_a, "ee_rot"_a,
           "ee_pos"_a, "cap_joint"_a, "cap_a"_a, "cap_b"_a, "cap_r"_a, "self_pairs"_a, "lower"_a, "upper"_a,
           "max_velocity"_a, "max_acceleration"_a, "link_start"_a, "prim_joint"_a, "prim_a"_a, "prim_b"_a,
           "prim_r"_a, "self_r"_a, "RobotArrays' fields in order (Robot(*arrays)).");
  nb::class_<Scene>(m, "Scene", "Packed obstacles, bounding spheres and offsets for one robot, read in place.")
      .def(nb::init<const Robot&, const Kinds&, const Rows<16>&, const Triangles&, const PseudoNormals&,
                    const Rows<3>&, const Rows<3>&, const Nodes&, const MeshTable&, const Rows<3>&, const Vector&,
                    const Matrix&, const Vector&>(),
           "robot"_a, "kinds"_a, "rows"_a, "triangles"_a, "pseudo_normals"_a, "bvh_lower"_a, "bvh_upper"_a,
           "bvh_nodes"_a, "mesh_table"_a, "centres"_a, "bounds"_a, "obstacle_offsets"_a, "self_offsets"_a,
           "Scene(robot, *packed, centres, bounds, obstacle_offsets, self_offsets).");
  nb::class_<Obstacles>(m, "Obstacles", "Packed obstacles (the point space's), read in place.")
      .def(nb::init<const Kinds&, const Rows<16>&, const Triangles&, const PseudoNormals&, const Rows<3>&,
                    const Rows<3>&, const Nodes&, const MeshTable&>(),
           "kinds"_a, "rows"_a, "triangles"_a, "pseudo_normals"_a, "bvh_lower"_a, "bvh_upper"_a, "bvh_nodes"_a,
           "mesh_table"_a, "Obstacles(*packed).");

  nb::class_<Trees>(m, "Trees", "Both trees of one search and its random stream.")
      .def(
          "__init__",
          [](Trees* self, const Vector& start, const Matrix& goals, std::int64_t capacity, std::uint64_t seed) {
            const std::size_t n = start.shape(0);
            require(n > 0 && goals.shape(1) == n && goals.shape(0) > 0,
                    "trees: start (n,) and goals (G >= 1, n) must have the same dimension");
            require(capacity >= 2 && static_cast<std::size_t>(capacity) >= goals.shape(0),
                    "trees: capacity must be >= 2 and hold every goal");
            new (self) Trees(start.data(), goals.data(), goals.shape(0), n, static_cast<std::size_t>(capacity), seed);
          },
          "start"_a, "goals"_a, "capacity"_a, "seed"_a,
          "Tree 0 rooted at start, tree 1 at every row of goals, the stream seeded by seed (splitmix64).")
      .def_prop_ro("counts", [](const Trees& t) { return std::make_tuple(t.counts[0], t.counts[1]); },
                   "nodes in tree 0 and tree 1")
      .def_ro("next", &Trees::next, "the tree that extends next")
      .def_ro("random", &Trees::random, "the xorshift64* state")
      .def(
          "nodes",
          [](const Trees& t, std::int64_t tree) {
            require(tree == 0 || tree == 1, "tree: expected 0 or 1");
            return matrix(t.node(tree, 0), static_cast<std::size_t>(t.counts[tree]), t.dimension);
          },
          "tree"_a, "A copy of tree's nodes (count, n).")
      .def(
          "parents",
          [](const Trees& t, std::int64_t tree) {
            require(tree == 0 || tree == 1, "tree: expected 0 or 1");
            const auto count = static_cast<std::size_t>(t.counts[tree]);
            auto [array, out] = new_array_of<std::int64_t>({count});
            const std::int64_t* first = t.parents.data() + tree * static_cast<std::int64_t>(t.capacity);
            std::copy(first, first + count, out);
            return array;
          },
          "tree"_a, "A copy of tree's parent indices (count,), -1 for a root.");

  nb::class_<Checker>(m, "Checker", "The validity test of one search; counts the states it checks.")
      .def(nb::init<nb::object, nb::object, double, double>(), "robot"_a, "scene"_a, "margin"_a, "resolution"_a,
           "Joint space: every link-obstacle and self pair keeps margin plus its offset.")
      .def(nb::init<nb::object, double, double>(), "obstacles"_a, "margin"_a, "resolution"_a,
           "Point space (R^3): the signed distance to every obstacle is at least margin.")
      .def_prop_ro("dimension", &Checker::dimension)
      .def_prop_ro("states_checked", &Checker::states_checked, "states checked so far")
      .def("state_valid", &Checker::state_valid, "q"_a, "Whether q is valid (one check).")
      .def("edge_valid", &Checker::edge_valid, "a"_a, "b"_a,
           "Whether the straight edge a -> b is valid (a assumed valid), sampled every resolution.")
      .def("connect", &Checker::connect, "trees"_a, "lower"_a, "upper"_a, "step"_a, "budget"_a,
           "cancel"_a.none() = nb::none(),
           "RRT-Connect on trees for about budget more state checks: (SearchStatus, path (K, n) when FOUND). The GIL "
           "is released; cancel[0] != 0 ends the chunk (SEARCHING) at the next iteration.")
      .def("shortcut", &Checker::shortcut, "path"_a, "attempts"_a, "trees"_a,
           "The shortened path (random shortcuts drawn from trees' stream, then a greedy pass).");

  nb::class_<TrackOutcome>(m, "TrackResult", "How the tracking of a searched path ended.")
      .def_ro("status", &TrackOutcome::status, "the PlanStatus value")
      .def_ro("count", &TrackOutcome::count, "waypoints recorded, the start included")
      .def_ro("last", &TrackOutcome::last, "the last step evaluated (its nearest pairs name a failure's culprit)");
  m.def("track_path", &track_path, "robot"_a, "scene"_a, "q0"_a, "waypoints"_a, "goal_position"_a,
        "goal_orientation"_a, "params"_a, "max_iterations"_a, "gain"_a, "lead"_a, "cancel"_a, "joints"_a,
        "velocities"_a, "positions"_a, "orientations"_a, "twists"_a, "clearances"_a,
        "The field's damper QP following waypoints from q0 into the outputs (max_iterations + 1 rows each); the GIL "
        "is released and cancel[0] read every step.");
  m.def(
      "overlapping_waypoints",
      [](const Robot& robot, const Scene& scene, const Matrix& qs) {
        scene.require_fits(robot);
        require(qs.shape(1) == robot.joints(), "qs: expected (N, n)");
        const std::size_t count = qs.shape(0);
        auto [array, out] = new_array_of<bool>({count});
        {
          nb::gil_scoped_release release;
          planning::overlapping_waypoints(qs.data(), count, robot.view(), scene.view(), out);
        }
        return array;
      },
      "robot"_a, "scene"_a, "qs"_a,
      "Which configurations have a link capsule overlapping an obstacle or another capsule (scene offsets zero).");
}

}  // namespace pfield::python
