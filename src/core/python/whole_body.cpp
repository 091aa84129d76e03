// Bindings of the whole-body field (pfield.planning.whole_body, WholeBodyStepper): a thin list of defs over
// planning/whole_body.hpp. A Planner is a robot.Scene (the robot among its obstacles, python/robot_arrays.hpp) with
// the goal and parameters; its plan and steps then take q only. A Stepper is WholeBodyStepper's state: its
// workspace and checks, one call per step, under the output contract (safety/limits.hpp). No arithmetic here: the
// core computes.
#include <nanobind/nanobind.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/tuple.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <tuple>
#include <utility>
#include <vector>

#include "planning/whole_body.hpp"
#include "python/arrays.hpp"
#include "python/robot_arrays.hpp"
#include "robot/robot.hpp"
#include "safety/limits.hpp"

namespace pfield::python {
namespace {

using namespace nb::literals;
using planning::StepResult;
using planning::WholeBodyParams;

constexpr std::size_t kStepSize = sizeof(StepResult) / sizeof(double);
static_assert(kStepSize == 21, "StepResult is _whole_body_layout.STEP_OUT's 21 doubles");

// A robot in a scene with a goal and parameters: the planning loop and the single steps.
class Planner {
 public:
  Planner(nb::handle_t<SceneArrays> scene, const Point& goal_position, const Quaternion& goal_orientation,
          const Vector& params, std::optional<Vector> goal_joints, double joint_gain)
      : scene_(scene), goal_(goal_pose(goal_position, goal_orientation)), params_(whole_body_params(params)) {
    if (goal_joints) {
      require(goal_joints->shape(0) == this->joints(), "goal_joints: expected one value per joint");
      joint_goal_.assign(goal_joints->data(), goal_joints->data() + goal_joints->shape(0));
      goal_.joints = joint_goal_.data();
      goal_.joint_gain = joint_gain;
    }
  }
  // goal_.joints points into joint_goal_: a copy would point into the original
  Planner(const Planner&) = delete;
  Planner& operator=(const Planner&) = delete;

  const robot::RobotView& robot() const { return scene_->robot().view(); }
  const planning::WholeBodyScene& scene() const { return scene_->view(); }
  const planning::Goal& goal() const { return goal_; }
  const WholeBodyParams& params() const { return params_; }
  std::size_t joints() const { return scene_->robot().joints(); }

  PathOutcome plan(const Vector& q0, std::int64_t max_iterations, const Cancel& cancel, OutMatrix& joints,
                   OutMatrix& velocities, OutRows<3>& positions, OutRows<4>& orientations, OutRows<6>& twists,
                   OutVector& clearances) const {
    require(params_.stagnation_steps >= 1.0, "params: stagnation_steps must be >= 1");
    require(q0.shape(0) == this->joints(), "q0: expected one value per joint");
    const planning::WholeBodyPath path =
        path_outputs(max_iterations, this->joints(), joints, velocities, positions, orientations, twists, clearances);
    planning::WholeBodyPlanResult result;
    {
      nb::gil_scoped_release release;
      result = planning::plan_whole_body(q0.data(), robot(), scene(), goal_, params_, max_iterations, cancel.data(),
                                         path);
    }
    return PathOutcome(result);
  }

  // One step (the planner's, or shared control's with hold) at q: (row: STEP_OUT then qd (n,), damper rows).
  std::tuple<NumpyArray, std::int64_t> step(const Vector& q, std::optional<Vector> previous, bool autonomy) const {
    const std::size_t n = joints();
    require(q.shape(0) == n && (!previous || previous->shape(0) == n), "q, previous: expected one value per joint");
    planning::WholeBodyWorkspace ws(robot(), scene());
    const double* prev = previous ? previous->data() : nullptr;
    const auto step = autonomy ? planning::autonomy_step : planning::joint_velocity_step;
    const std::size_t m = step(q.data(), prev, robot(), scene(), goal_, params_, ws);
    auto [row, data] = new_array({kStepSize + n});
    std::copy_n(reinterpret_cast<const double*>(&ws.result), kStepSize, data);
    std::copy(ws.x.begin(), ws.x.end(), data + kStepSize);
    return {row, static_cast<std::int64_t>(m)};
  }

 private:
  Held<SceneArrays> scene_;  // the robot and obstacles the core views
  std::vector<double> joint_goal_;  // the posture goal_ points to (empty: none)
  planning::Goal goal_;
  WholeBodyParams params_;
};

// WholeBodyStepper's state: the planner's robot, scene and goal, its parameters (dt swapped per call), the
// workspace, and the output contract's limits.
class Stepper {
 public:
  Stepper(nb::handle_t<Planner> planner, const Vector& velocity_limits, double max_linear, double max_angular,
          double limit_tolerance)
      : planner_(planner),
        stepper_(planner_->robot(), planner_->scene(), planner_->goal(), planner_->params()),
        velocity_limits_(velocity_limits.data(), velocity_limits.data() + velocity_limits.shape(0)),
        max_linear_(max_linear), max_angular_(max_angular), limit_tolerance_(limit_tolerance) {
    require(velocity_limits_.size() == stepper_.joint_count(), "velocity_limits: expected one per joint");
    velocities_.resize(stepper_.joint_count());
  }

  // The step at q under the output contract (pfield.safety.limit_joint_command): its row (STEP_OUT then qd,
  // 21 + n) into out, or, for twist(), its twist. False (nothing written) when an input breaks the stepper's rules
  // (the caller then validates, and raises). q and previous are read as Doubles (the control loop's hot path).
  bool step(const Doubles& q, const std::optional<Doubles>& previous, double dt) {
    const bool given = previous.has_value();
    return stepper_.step(q.data, q.size, given ? previous->data : nullptr, given ? previous->size : 0, dt,
                         limit_tolerance_);
  }

  // row(): the contract's outcome (0, 1, 2), or -1 when refused (out untouched).
  int row(const Doubles& q, const std::optional<Doubles>& previous, double dt, OutDoubles out) {
    const std::size_t n = stepper_.joint_count();
    require(out.size == kStepSize + n, "out: expected the row's 21 + n values");
    if (!step(q, previous, dt)) return -1;
    std::copy_n(reinterpret_cast<const double*>(&stepper_.result()), kStepSize, out.data);
    std::copy_n(stepper_.joint_velocities(), n, out.data + kStepSize);
    return static_cast<int>(safety::limit_joint_command(out.data + kStepSize, n, out.data, velocity_limits_.data(),
                                                        max_linear_, max_angular_));
  }

  // twist(): (linear (3,), angular (3,), the contract's outcome), new read-only arrays that
  // pfield.spatial.twist_from_checked adopts; (None, None, -1) when refused.
  std::tuple<nb::object, nb::object, int> twist(const Doubles& q, const std::optional<Doubles>& previous, double dt) {
    if (!step(q, previous, dt)) return {nb::none(), nb::none(), -1};
    const std::size_t n = stepper_.joint_count();
    double twist[6];
    std::copy(stepper_.joint_velocities(), stepper_.joint_velocities() + n, velocities_.begin());
    std::copy_n(stepper_.result().twist, 6, twist);
    const int outcome = static_cast<int>(safety::limit_joint_command(velocities_.data(), n, twist,
                                                                     velocity_limits_.data(), max_linear_, max_angular_));
    return {readonly_copy(twist, 3), readonly_copy(twist + 3, 3), outcome};
  }

 private:
  Held<Planner> planner_;  // the stepper views its robot and scene
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
  nb::class_<PathOutcome>(m, "PlanResult", "How a whole-body plan or a tracking (rrt.track_path) ended.")
      .def_ro("status", &PathOutcome::status, "the PlanStatus value")
      .def_ro("count", &PathOutcome::count, "waypoints recorded, the start included")
      .def_ro("last", &PathOutcome::last, "the last step evaluated (its nearest pairs name a failure's culprit)");

  nb::class_<Planner>(m, "Planner", "A robot in a scene (robot.Scene) with a goal pose and parameters.")
      .def(nb::init<nb::handle_t<SceneArrays>, const Point&, const Quaternion&, const Vector&, std::optional<Vector>,
                    double>(),
           "scene"_a, "goal_position"_a, "goal_orientation"_a, "params"_a, "goal_joints"_a.none() = nb::none(),
           "joint_gain"_a = 0.0,
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
      .def(nb::init<nb::handle_t<Planner>, const Vector&, double, double, double>(), "planner"_a, "velocity_limits"_a,
           "max_linear"_a, "max_angular"_a, "limit_tolerance"_a)
      .def("row", &Stepper::row, "q"_a, "previous"_a.none(), "dt"_a, "out"_a,
           "The step's row (STEP_OUT then qd) at q under the output contract into out (21 + n,): the contract's "
           "outcome, or -1 when q (n values within the limits up to limit_tolerance), previous (n finite values) or "
           "dt (finite, >= 0) is refused. Arrays: C-contiguous float64 (else TypeError).")
      .def("twist", &Stepper::twist, "q"_a, "previous"_a.none(), "dt"_a,
           "row's twist alone (the autonomy vector's call): (linear (3,), angular (3,), outcome), new read-only "
           "arrays, or (None, None, -1).");
}

}  // namespace pfield::python
