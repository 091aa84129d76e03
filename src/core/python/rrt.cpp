// Bindings of the global fallback (pfield.planning.global_search): a thin list of defs over planning/rrt.hpp (the
// search: its state checker, trees, RRT-Connect and shortcutting) and planning/track.hpp (the field's tracking of
// the searched path, the capsule overlap test of the tracked motion). The joint space is a robot.Scene, the point
// space robot.Obstacles (python/robot_arrays.hpp). No arithmetic here: the core computes.
#include <nanobind/nanobind.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/tuple.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "planning/rrt.hpp"
#include "planning/track.hpp"
#include "planning/whole_body.hpp"
#include "python/arrays.hpp"
#include "python/robot_arrays.hpp"

namespace pfield::python {
namespace {

using namespace nb::literals;
using planning::SearchStatus;
using planning::StateChecker;
using planning::Trees;

// A rows x columns NumPy copy of `data`.
NumpyArray matrix(const double* data, std::size_t rows, std::size_t columns) {
  auto [array, out] = new_array({rows, columns});
  std::copy(data, data + rows * columns, out);
  return array;
}

// One search's validity test (the core's StateChecker) with the scene or obstacles it views kept alive.
class Checker {
 public:
  Checker(nb::handle_t<SceneArrays> scene, double margin, double resolution) : owner_(nb::borrow(scene)) {
    const SceneArrays& where = nb::cast<const SceneArrays&>(scene);
    checker_ = std::make_unique<StateChecker>(where.robot().view(), where.view(), margin, resolution);
  }
  Checker(nb::handle_t<ObstacleArrays> obstacles, double margin, double resolution) : owner_(nb::borrow(obstacles)) {
    checker_ = std::make_unique<StateChecker>(nb::cast<const ObstacleArrays&>(obstacles).packed(), margin,
                                              resolution);
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
                                               std::int64_t budget, std::optional<Cancel> cancel,
                                               std::optional<Bound> bound) {
    const std::size_t n = dimension();
    require(trees.dimension == n, "trees: built for another state space");
    require_state(lower, "lower");
    require_state(upper, "upper");
    planning::SearchOutcome outcome;
    {
      nb::gil_scoped_release release;
      outcome = planning::rrt_connect(*checker_, trees, lower.data(), upper.data(), step, budget,
                                      cancel ? cancel->data() : nullptr, bound ? bound->data() : nullptr);
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

  // (issue 34) a region of invalid states (planning::ForbiddenRegions)
  void forbid(const Vector& centre, const Vector& weights, double radius) {
    require_state(centre, "centre");
    require_state(weights, "weights");
    checker_->forbid(centre.data(), weights.data(), radius);
  }

  // (issue 34) the partial-shortcut shortening of planning::shorten, drawing from trees' stream
  NumpyArray shorten(const Matrix& path, std::int64_t attempts, Trees& trees, Checker& clearance) {
    const std::size_t n = dimension();
    require(path.shape(1) == n && path.shape(0) > 0, "path: expected (K >= 1, dimension)");
    require(clearance.dimension() == n && clearance.checker_->space() == checker_->space(),
            "clearance: expected a checker of the same state space");
    std::vector<double> out;
    {
      nb::gil_scoped_release release;
      out = planning::shorten(*checker_, *clearance.checker_, path.data(), path.shape(0), attempts, trees.random);
    }
    return matrix(out.data(), out.size() / n, n);
  }

 private:
  nb::object owner_;  // the scene or obstacles, kept alive: the checker views their arrays
  std::unique_ptr<StateChecker> checker_;
};

PathOutcome track_path(const SceneArrays& scene, const Vector& q0, const Matrix& waypoints, const Point& goal_position,
                       const Quaternion& goal_orientation, const Vector& params, std::int64_t max_iterations,
                       double gain, double lead, const Cancel& cancel, OutMatrix& joints, OutMatrix& velocities,
                       OutRows<3>& positions, OutRows<4>& orientations, OutRows<6>& twists, OutVector& clearances) {
  const std::size_t n = scene.robot().joints();
  require(q0.shape(0) == n && waypoints.shape(1) == n && waypoints.shape(0) > 0,
          "q0 (n,), waypoints (K >= 1, n): one value per joint");
  const planning::WholeBodyParams p = whole_body_params(params);
  const planning::Goal goal = goal_pose(goal_position, goal_orientation);
  const planning::WholeBodyPath path =
      path_outputs(max_iterations, n, joints, velocities, positions, orientations, twists, clearances);
  planning::WholeBodyPlanResult result;
  {
    nb::gil_scoped_release release;
    result = planning::track_path(q0.data(), waypoints.data(), waypoints.shape(0), scene.robot().view(), scene.view(),
                                  goal, p, {max_iterations, gain, lead}, cancel.data(), path);
  }
  return PathOutcome(result);
}

}  // namespace

void bind_rrt(nb::module_& m) {
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
      .def(nb::init<nb::handle_t<SceneArrays>, double, double>(), "scene"_a, "margin"_a, "resolution"_a,
           "Joint space (a robot.Scene): every link-obstacle and self pair keeps margin plus its offset.")
      .def(nb::init<nb::handle_t<ObstacleArrays>, double, double>(), "obstacles"_a, "margin"_a, "resolution"_a,
           "Point space (R^3): the signed distance to every obstacle is at least margin.")
      .def_prop_ro("dimension", &Checker::dimension)
      .def_prop_ro("states_checked", &Checker::states_checked, "states checked so far")
      .def("state_valid", &Checker::state_valid, "q"_a, "Whether q is valid (one check).")
      .def("forbid", &Checker::forbid, "centre"_a, "weights"_a, "radius"_a,
           "From now on a state q with sum_j weights[j] |q_j - centre[j]| < radius is invalid "
           "(planning::ForbiddenRegions).")
      .def("edge_valid", &Checker::edge_valid, "a"_a, "b"_a,
           "Whether the straight edge a -> b is valid (a assumed valid), sampled every resolution.")
      .def("connect", &Checker::connect, "trees"_a, "lower"_a, "upper"_a, "step"_a, "budget"_a,
           "cancel"_a.none() = nb::none(), "bound"_a.none() = nb::none(),
           "RRT-Connect on trees for about budget more state checks: (SearchStatus, path (K, n) when FOUND). The GIL "
           "is released; cancel[0] != 0 ends the chunk (SEARCHING) at the next iteration, and so does bound[0] (an "
           "int64 array another thread may lower) once states_checked reaches it.")
      .def("shortcut", &Checker::shortcut, "path"_a, "attempts"_a, "trees"_a,
           "The shortened path (random shortcuts drawn from trees' stream, then a greedy pass).")
      .def("shorten", &Checker::shorten, "path"_a, "attempts"_a, "trees"_a, "clearance"_a,
           "The path shortened by attempts partial shortcuts between random points on it (drawn from trees' "
           "stream; never longer; each new segment checked by clearance, this checker or a stricter one), then the "
           "greedy vertex pass with clearance.");

  m.def("track_path", &track_path, "scene"_a, "q0"_a, "waypoints"_a, "goal_position"_a,
        "goal_orientation"_a, "params"_a, "max_iterations"_a, "gain"_a, "lead"_a, "cancel"_a, "joints"_a,
        "velocities"_a, "positions"_a, "orientations"_a, "twists"_a, "clearances"_a,
        "The field's damper QP following waypoints from q0 into the outputs (max_iterations + 1 rows each): a "
        "whole_body.PlanResult; the GIL is released and cancel[0] read every step.");
  m.def(
      "overlapping_waypoints",
      [](const SceneArrays& scene, const Matrix& qs) {
        require(qs.shape(1) == scene.robot().joints(), "qs: expected (N, n)");
        return filled_array<bool>({qs.shape(0)}, [&](bool* out) {
          planning::overlapping_waypoints(qs.data(), qs.shape(0), scene.robot().view(), scene.view(), out);
        });
      },
      "scene"_a, "qs"_a,
      "Which configurations have a link capsule overlapping an obstacle or another capsule (scene offsets zero).");
}

}  // namespace pfield::python
