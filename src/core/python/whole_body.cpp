// Bindings of the whole-body field (pfield.planning.whole_body, WholeBodyStepper): a thin list of defs over
// planning/whole_body.hpp. A Robot binds pfield.planning._whole_body_layout.RobotArrays once, a Scene the packed
// obstacles with their bounding spheres and start offsets, a Planner both with the goal and parameters; its plan and
// steps then take q only. A Stepper is WholeBodyStepper's state: its workspace and checks, one call per step.
// No arithmetic here beyond the output contract (safety/limits.hpp, applied here as pfield.safety applies it: this
// file is compiled like python/safety.cpp, so the same bits): the core computes.
#include <nanobind/nanobind.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/tuple.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "planning/whole_body.hpp"
#include "python/arrays.hpp"
#include "python/packed.hpp"
#include "robot/robot.hpp"
#include "safety/limits.hpp"

namespace pfield::python {
namespace {

using namespace nb::literals;
using planning::StepResult;
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
constexpr std::size_t kStepSize = sizeof(StepResult) / sizeof(double);
static_assert(kParamCount == 20, "WholeBodyParams is _whole_body_layout.PARAMS's 20 doubles");
static_assert(kStepSize == 21, "StepResult is _whole_body_layout.STEP_OUT's 21 doubles");

void require(bool condition, const std::string& message) {
  if (!condition) throw std::invalid_argument(message);
}

bool joints_within(const std::int64_t* joints, std::size_t count, std::size_t n) {
  return std::all_of(joints, joints + count, [n](std::int64_t j) { return j >= -1 && j < static_cast<std::int64_t>(n); });
}

// RobotArrays (pfield.planning._whole_body_layout), read in place for the object's life, every index checked once.
class Robot {
 public:
  Robot(const Ints& parents, const Rotations& place_rot, const Rows<3>& place_pos, const Rows<3>& axes,
        const Ints& kinds, const IntMatrix& support, std::int64_t ee_joint, const Matrix3& ee_rot, const Point& ee_pos,
        const Ints& cap_joint, const Rows<3>& cap_a, const Rows<3>& cap_b, const Vector& cap_r, const Pairs& self_pairs,
        const Vector& lower, const Vector& upper, const Vector& max_velocity, const Vector& max_acceleration,
        const Ints& link_start, const Ints& prim_joint, const Rows<3>& prim_a, const Rows<3>& prim_b,
        const Vector& prim_r, const Vector& self_r)
      : parents_(parents), place_rot_(place_rot), place_pos_(place_pos), axes_(axes), kinds_(kinds), support_(support),
        ee_rot_(ee_rot), ee_pos_(ee_pos), cap_joint_(cap_joint), cap_a_(cap_a), cap_b_(cap_b), cap_r_(cap_r),
        self_pairs_(self_pairs), lower_(lower), upper_(upper), max_velocity_(max_velocity),
        max_acceleration_(max_acceleration), link_start_(link_start), prim_joint_(prim_joint), prim_a_(prim_a),
        prim_b_(prim_b), prim_r_(prim_r), self_r_(self_r) {
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
    view_.links = {caps,         cap_joint.data(),    cap_a.data(),     cap_b.data(),   cap_r.data(),
                   self_r.data(), self_pairs.shape(0), pairs,            prims,          link_start.data(),
                   prim_joint.data(), prim_a.data(),   prim_b.data(),    prim_r.data()};
    view_.limits = {lower.data(), upper.data(), max_velocity.data(), max_acceleration.data()};
  }

  const robot::RobotView& view() const { return view_; }
  std::size_t joints() const { return view_.kinematics.joint_count; }

 private:
  Ints parents_;
  Rotations place_rot_;
  Rows<3> place_pos_, axes_;
  Ints kinds_;
  IntMatrix support_;
  Matrix3 ee_rot_;
  Point ee_pos_;
  Ints cap_joint_;
  Rows<3> cap_a_, cap_b_;
  Vector cap_r_;
  Pairs self_pairs_;
  Vector lower_, upper_, max_velocity_, max_acceleration_;
  Ints link_start_, prim_joint_;
  Rows<3> prim_a_, prim_b_;
  Vector prim_r_, self_r_;
  robot::RobotView view_;
};

// The whole-body scene (pfield.planning._whole_body_layout.Scene) for one robot: the packed obstacles (the eight
// arrays of PackedObstacles), bounding spheres and start offsets, read in place.
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
  bool fits(const Robot& robot) const {
    return robot.view().links.capsule_count == capsule_count_ && robot.view().links.pair_count == pair_count_;
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

struct PlanOutcome {
  std::int64_t status;
  std::int64_t count;
  StepResult last;
};

// A robot in a scene with a goal and parameters: the planning loop and the single steps (the numba twins' tests).
class Planner {
 public:
  Planner(nb::object robot, nb::object scene, const Point& goal_position, const Quaternion& goal_orientation,
          const Vector& params)
      : robot_owner_(std::move(robot)), scene_owner_(std::move(scene)),
        robot_(&nb::cast<const Robot&>(robot_owner_)), scene_(&nb::cast<const Scene&>(scene_owner_)) {
    require(scene_->fits(*robot_), "planner: the scene was built for another robot");
    require(params.shape(0) == kParamCount, "params: expected _whole_body_layout.PARAMS's 20 numbers");
    std::copy(params.data(), params.data() + kParamCount, reinterpret_cast<double*>(&params_));
    const double* g = goal_position.data();
    const double* o = goal_orientation.data();
    goal_ = {{g[0], g[1], g[2]}, {o[0], o[1], o[2], o[3]}};
  }

  const Robot& robot() const { return *robot_; }
  const Scene& scene() const { return *scene_; }
  const planning::Goal& goal() const { return goal_; }
  const WholeBodyParams& params() const { return params_; }

  PlanOutcome plan(const Vector& q0, std::int64_t max_iterations, const Cancel& cancel, OutMatrix& joints,
                   OutMatrix& velocities, OutRows<3>& positions, OutRows<4>& orientations, OutRows<6>& twists,
                   OutVector& clearances) const {
    const std::size_t n = robot_->joints();
    require(max_iterations >= 0, "max_iterations: expected >= 0");
    require(params_.stagnation_steps >= 1.0, "params: stagnation_steps must be >= 1");
    require(q0.shape(0) == n, "q0: expected one value per joint");
    const auto rows = static_cast<std::size_t>(max_iterations) + 1;
    require(joints.shape(0) >= rows && joints.shape(1) == n && velocities.shape(0) >= rows &&
                velocities.shape(1) == n && positions.shape(0) >= rows && orientations.shape(0) >= rows &&
                twists.shape(0) >= rows && clearances.shape(0) >= rows,
            "plan: the outputs need max_iterations + 1 rows (joints, velocities: n columns)");
    planning::WholeBodyPlanResult result;
    {
      nb::gil_scoped_release release;
      result = planning::plan_whole_body(
          q0.data(), robot_->view(), scene_->view(), goal_, params_, max_iterations, cancel.data(),
          {joints.data(), velocities.data(), positions.data(), orientations.data(), twists.data(), clearances.data()});
    }
    return {static_cast<std::int64_t>(result.status), result.count, result.last};
  }

  // One step (the planner's, or shared control's with hold) at q: (row: STEP_OUT then qd (n,), damper rows).
  std::tuple<NumpyArray, std::int64_t> step(const Vector& q, std::optional<Vector> previous, bool autonomy) const {
    const std::size_t n = robot_->joints();
    require(q.shape(0) == n && (!previous || previous->shape(0) == n), "q, previous: expected one value per joint");
    planning::WholeBodyWorkspace ws(robot_->view(), scene_->view());
    const double* prev = previous ? previous->data() : nullptr;
    const std::size_t m =
        autonomy ? planning::autonomy_step(q.data(), prev, robot_->view(), scene_->view(), goal_, params_, ws)
                 : planning::joint_velocity_step(q.data(), prev, robot_->view(), scene_->view(), goal_, params_, ws);
    auto [row, data] = new_array({kStepSize + n});
    std::copy_n(reinterpret_cast<const double*>(&ws.result), kStepSize, data);
    std::copy(ws.x.begin(), ws.x.end(), data + kStepSize);
    return {row, static_cast<std::int64_t>(m)};
  }

 private:
  nb::object robot_owner_, scene_owner_;  // kept alive: the views point into their arrays
  const Robot* robot_;
  const Scene* scene_;
  planning::Goal goal_{};
  WholeBodyParams params_{};
};

// WholeBodyStepper's state: the planner's robot, scene and goal, its parameters (dt swapped per call), the
// workspace, and the output contract's limits.
class Stepper {
 public:
  Stepper(nb::object planner, const Vector& velocity_limits, double max_linear, double max_angular,
          double limit_tolerance)
      : owner_(std::move(planner)),
        stepper_(nb::cast<const Planner&>(owner_).robot().view(), nb::cast<const Planner&>(owner_).scene().view(),
                 nb::cast<const Planner&>(owner_).goal(), nb::cast<const Planner&>(owner_).params()),
        velocity_limits_(velocity_limits.data(), velocity_limits.data() + velocity_limits.shape(0)),
        max_linear_(max_linear), max_angular_(max_angular), limit_tolerance_(limit_tolerance) {
    require(velocity_limits_.size() == stepper_.joint_count(), "velocity_limits: expected one per joint");
    velocities_.resize(stepper_.joint_count());
  }

  // The step at q under the output contract (pfield.safety.limit_joint_command) into out: its row (STEP_OUT then
  // qd, 21 + n) or, for twist_only, its twist (6). Returns the contract's outcome (0, 1, 2), or -1 (out untouched)
  // when an input breaks the stepper's rules (the caller then validates, and raises). The caller allocates out
  // (np.empty: cheaper than a NumPy array made here and handed over).
  int step(const Vector& q, std::optional<Vector> previous, double dt, OutVector& out, bool twist_only) {
    const std::size_t n = stepper_.joint_count();
    require(out.shape(0) == (twist_only ? 6 : kStepSize + n), "out: expected the row's 21 + n or the twist's 6 values");
    const bool given = previous.has_value();
    if (!stepper_.step(q.data(), q.shape(0), given ? previous->data() : nullptr, given ? previous->shape(0) : 0, dt,
                       limit_tolerance_))
      return -1;
    const StepResult& result = stepper_.result();
    double* data = out.data();
    if (twist_only) {
      std::copy(stepper_.joint_velocities(), stepper_.joint_velocities() + n, velocities_.begin());
      std::copy_n(result.twist, 6, data);
      return static_cast<int>(safety::limit_joint_command(velocities_.data(), n, data, velocity_limits_.data(),
                                                          max_linear_, max_angular_));
    }
    std::copy_n(reinterpret_cast<const double*>(&result), kStepSize, data);
    std::copy_n(stepper_.joint_velocities(), n, data + kStepSize);
    return static_cast<int>(safety::limit_joint_command(data + kStepSize, n, data, velocity_limits_.data(),
                                                        max_linear_, max_angular_));
  }

 private:
  nb::object owner_;  // the planner, kept alive: the stepper views its robot and scene
  planning::WholeBodyStepper stepper_;
  std::vector<double> velocity_limits_;
  double max_linear_, max_angular_, limit_tolerance_;
  std::vector<double> velocities_;  // qd of a twist-only step, scaled with its twist
};

std::tuple<double, double, double> tuple3(const double* v) { return {v[0], v[1], v[2]}; }

}  // namespace

void bind_whole_body(nb::module_& m) {
  m.doc() = "The whole-body field: its step, planning loop and prepared stepper (pfield.planning.whole_body's "
            "compiled core).";
  // WholeBodyParams member -> its index in _whole_body_layout.PARAMS, StepResult member -> its (start, stop) in
  // STEP_OUT: from the structs' own layouts (tests hold them equal to the Python layouts)
  nb::dict params;
#define PFIELD_PARAM(member) params[#member] = offsetof(WholeBodyParams, member) / sizeof(double)
  PFIELD_PARAM(attractive_gain);
  PFIELD_PARAM(rotational_attractive_gain);
  PFIELD_PARAM(attractive_threshold);
  PFIELD_PARAM(max_linear_velocity);
  PFIELD_PARAM(max_angular_velocity);
  PFIELD_PARAM(influence_distance);
  PFIELD_PARAM(safety_distance);
  PFIELD_PARAM(damper_gain);
  PFIELD_PARAM(repulsive_gain);
  PFIELD_PARAM(max_repulsive_force);
  PFIELD_PARAM(dt);
  PFIELD_PARAM(goal_tolerance);
  PFIELD_PARAM(rotation_tolerance);
  PFIELD_PARAM(stagnation_steps);
  PFIELD_PARAM(stagnation_progress);
  PFIELD_PARAM(joint_influence);
  PFIELD_PARAM(joint_safety);
  PFIELD_PARAM(rotation_weight);
  PFIELD_PARAM(damping);
  PFIELD_PARAM(null_space_gain);
#undef PFIELD_PARAM
  m.attr("PARAM_OFFSETS") = params;
  nb::dict step;
#define PFIELD_STEP(member)                                                          \
  step[#member] = nb::make_tuple(offsetof(StepResult, member) / sizeof(double),      \
                                 (offsetof(StepResult, member) + sizeof(StepResult::member)) / sizeof(double))
  PFIELD_STEP(twist);
  PFIELD_STEP(position);
  PFIELD_STEP(orientation);
  PFIELD_STEP(clearance);
  PFIELD_STEP(self_clearance);
  PFIELD_STEP(position_error);
  PFIELD_STEP(rotation_error);
  PFIELD_STEP(nearest_capsule);
  PFIELD_STEP(nearest_obstacle);
  PFIELD_STEP(nearest_distance);
  PFIELD_STEP(nearest_self_pair);
#undef PFIELD_STEP
  m.attr("STEP_SPANS") = step;

  nb::class_<StepResult>(m, "StepResult", "One whole-body step's result (_whole_body_layout.STEP_OUT).")
      .def_prop_ro("twist", [](const StepResult& s) { return std::make_tuple(s.twist[0], s.twist[1], s.twist[2],
                                                                               s.twist[3], s.twist[4], s.twist[5]); },
                   "end-effector twist J qd (m/s, rad/s), world frame")
      .def_prop_ro("position", [](const StepResult& s) { return tuple3(s.position); }, "end-effector position (m)")
      .def_prop_ro("orientation",
                   [](const StepResult& s) {
                     return std::make_tuple(s.orientation[0], s.orientation[1], s.orientation[2], s.orientation[3]);
                   },
                   "end-effector quaternion (x, y, z, w)")
      .def_ro("clearance", &StepResult::clearance, "smallest link-obstacle distance (m)")
      .def_ro("self_clearance", &StepResult::self_clearance, "smallest self-pair distance less its offset (m)")
      .def_ro("position_error", &StepResult::position_error, "m")
      .def_ro("rotation_error", &StepResult::rotation_error, "rad")
      .def_ro("nearest_capsule", &StepResult::nearest_capsule, "link of the closest link-obstacle pair, -1 if none")
      .def_ro("nearest_obstacle", &StepResult::nearest_obstacle, "obstacle of that pair, -1 if none")
      .def_ro("nearest_distance", &StepResult::nearest_distance, "that pair's distance less its offset (m)")
      .def_ro("nearest_self_pair", &StepResult::nearest_self_pair, "the closest self pair, -1 if none");
  nb::class_<PlanOutcome>(m, "PlanResult", "How a whole-body plan ended.")
      .def_ro("status", &PlanOutcome::status, "the PlanStatus value")
      .def_ro("count", &PlanOutcome::count, "waypoints recorded, the start included")
      .def_ro("last", &PlanOutcome::last, "the last step evaluated (its nearest pairs name a failure's culprit)");

  nb::class_<Robot>(m, "Robot", "A robot's RobotArrays (pfield.planning._whole_body_layout), read in place.")
      .def(nb::init<const Ints&, const Rotations&, const Rows<3>&, const Rows<3>&, const Ints&, const IntMatrix&,
                    std::int64_t, const Matrix3&, const Point&, const Ints&, const Rows<3>&, const Rows<3>&,
                    const Vector&, const Pairs&, const Vector&, const Vector&, const Vector&, const Vector&,
                    const Ints&, const Ints&, const Rows<3>&, const Rows<3>&, const Vector&, const Vector&>(),
           "parents"_a, "place_rot"_a, "place_pos"_a, "axes"_a, "kinds"_a, "support"_a, "ee_joint"_a, "ee_rot"_a,
           "ee_pos"_a, "cap_joint"_a, "cap_a"_a, "cap_b"_a, "cap_r"_a, "self_pairs"_a, "lower"_a, "upper"_a,
           "max_velocity"_a, "max_acceleration"_a, "link_start"_a, "prim_joint"_a, "prim_a"_a, "prim_b"_a,
           "prim_r"_a, "self_r"_a, "RobotArrays' fields in order (Robot(*arrays)).");
  nb::class_<Scene>(m, "Scene", "Packed obstacles, bounding spheres and start offsets for one robot, read in place.")
      .def(nb::init<const Robot&, const Kinds&, const Rows<16>&, const Triangles&, const PseudoNormals&,
                    const Rows<3>&, const Rows<3>&, const Nodes&, const MeshTable&, const Rows<3>&, const Vector&,
                    const Matrix&, const Vector&>(),
           "robot"_a, "kinds"_a, "rows"_a, "triangles"_a, "pseudo_normals"_a, "bvh_lower"_a, "bvh_upper"_a,
           "bvh_nodes"_a, "mesh_table"_a, "centres"_a, "bounds"_a, "obstacle_offsets"_a, "self_offsets"_a,
           "Scene(robot, *packed, centres, bounds, obstacle_offsets, self_offsets).");
  nb::class_<Planner>(m, "Planner", "A robot in a scene with a goal pose and parameters.")
      .def(nb::init<nb::object, nb::object, const Point&, const Quaternion&, const Vector&>(), "robot"_a, "scene"_a,
           "goal_position"_a, "goal_orientation"_a, "params"_a,
           "goal (3,) and (4,) (x, y, z, w), params: _whole_body_layout.PARAMS's vector (copied).")
      .def("plan", &Planner::plan, "q0"_a, "max_iterations"_a, "cancel"_a, "joints"_a, "velocities"_a, "positions"_a,
           "orientations"_a, "twists"_a, "clearances"_a,
           "The plan from q0 into the outputs (max_iterations + 1 rows each); the GIL is released and cancel[0] read "
           "every step.")
      .def(
          "joint_velocity_step",
          [](const Planner& p, const Vector& q, std::optional<Vector> previous) { return p.step(q, previous, false); },
          "q"_a, "previous"_a.none() = nb::none(),
          "(row: STEP_OUT then qd, damper rows) of the planner's step at q (rate-limited against previous).")
      .def(
          "autonomy_step",
          [](const Planner& p, const Vector& q, std::optional<Vector> previous) { return p.step(q, previous, true); },
          "q"_a, "previous"_a.none() = nb::none(),
          "(row, damper rows) of shared control's step at q (offsets taken at q).");
  nb::class_<Stepper>(m, "Stepper", "WholeBodyStepper's state: a planner's step with its own workspace.")
      .def(nb::init<nb::object, const Vector&, double, double, double>(), "planner"_a, "velocity_limits"_a,
           "max_linear"_a, "max_angular"_a, "limit_tolerance"_a)
      .def(
          "row",
          [](Stepper& s, const Vector& q, std::optional<Vector> previous, double dt, OutVector& out) {
            return s.step(q, previous, dt, out, false);
          },
          "q"_a.noconvert(), "previous"_a.none().noconvert(), "dt"_a, "out"_a.noconvert(),
          "The step's row (STEP_OUT then qd) at q under the output contract into out (21 + n,): the contract's "
          "outcome, or -1 when q (n values within the limits up to limit_tolerance), previous (n finite values) or "
          "dt (finite, >= 0) is refused.")
      .def(
          "twist",
          [](Stepper& s, const Vector& q, std::optional<Vector> previous, double dt, OutVector& out) {
            return s.step(q, previous, dt, out, true);
          },
          "q"_a.noconvert(), "previous"_a.none().noconvert(), "dt"_a, "out"_a.noconvert(),
          "row's twist alone into out (6,) (the autonomy vector's call): the outcome, or -1.");
}

}  // namespace pfield::python
