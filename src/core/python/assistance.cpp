// Bindings of shared-control assistance (pfield.shared_control.assistance): a thin list of defs over
// shared_control/assist.hpp. An AssistanceScene is an AssistanceScene's core: its obstacles (a robot.Obstacles,
// python/robot_arrays.hpp) with their velocities, read in place, and its parameters, copied; a WholeBody binds a
// robot.Robot to a scene, owns the workspace and, with a goal, the field's step. Answers are structs with named
// read-only fields; their vectors are read-only NumPy views of the answer's own memory. The output contract
// (safety/limits.hpp) is applied to the core's commands here, by its one compiled copy; the core computes.
#include <nanobind/nanobind.h>
#include <nanobind/stl/optional.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

#include "math/vec3.hpp"
#include "planning/whole_body.hpp"
#include "python/arrays.hpp"
#include "python/robot_arrays.hpp"
#include "safety/limits.hpp"
#include "shared_control/assist.hpp"

namespace pfield::python {
namespace {

using namespace nb::literals;
using shared_control::Arbitration;
using shared_control::AssistParams;
using shared_control::JointAssistance;
using shared_control::JointAssistParams;
using shared_control::PointAssistance;

// The task-space answer: the core's, and the output contract's outcome on its command (applied).
struct PointAnswer : PointAssistance {
  safety::Outcome outcome = safety::Outcome::Within;
};

using Twist6 = nb::ndarray<const double, nb::shape<6>, nb::c_contig, nb::device::cpu>;
template <std::size_t N>
using ReadOnly = nb::ndarray<nb::numpy, const double, nb::shape<N>>;

static_assert(sizeof(math::Vec3) == 3 * sizeof(double), "a Vec3 is three contiguous doubles (viewed as (3,))");

// A read-only (N,) NumPy view of N doubles owned by the Python object `owner`.
template <std::size_t N>
ReadOnly<N> view(const double* data, nb::handle owner) {
  return ReadOnly<N>(data, {N}, owner);
}
template <std::size_t N>
ReadOnly<N> view(const math::Vec3& v, nb::handle owner) {
  static_assert(N == 3);
  return ReadOnly<N>(&v.x, {N}, owner);
}

// An AssistanceScene's core: its obstacles (held: read in place) and their velocities (M, 3); the parameters
// copied.
class AssistScene {
 public:
  AssistScene(nb::handle_t<ObstacleArrays> obstacles, const Rows<3>& velocities, const AssistParams& params)
      : obstacles_(obstacles), velocities_(velocities), params_(params),
        moving_{obstacles_->set(), velocities.data()} {
    require(velocities.shape(0) == obstacles_->count(), "scene: velocities need one row per obstacle");
  }

  const shared_control::MovingObstacles& obstacles() const { return moving_; }
  const AssistParams& params() const { return params_; }

  PointAnswer assist_point(const Point& position, const Twist6& user, const Point& autonomy_linear,
                           const Point& autonomy_angular, Arbitration mode, double goal_share) const {
    const double* p = position.data();
    double autonomy[6];
    std::copy_n(autonomy_linear.data(), 3, autonomy);
    std::copy_n(autonomy_angular.data(), 3, autonomy + 3);
    PointAnswer answer;
    static_cast<PointAssistance&>(answer) = shared_control::assist_point(
        obstacles_->packed(), velocities_.data(), {p[0], p[1], p[2]}, user.data(), autonomy, params_, mode, goal_share);
    answer.outcome = safety::limit_twist(answer.blended, params_.max_linear_velocity, params_.max_angular_velocity);
    return answer;
  }

 private:
  Held<ObstacleArrays> obstacles_;
  Rows<3> velocities_;
  AssistParams params_;
  shared_control::MovingObstacles moving_;
};

// A whole-body answer: the core's struct, the joint velocities (a new NumPy array of its own) and the output
// contract's outcomes on (qd, blended) and on the autonomy's (qd_auto, twist) (applied).
struct JointAnswer : JointAssistance {
  NumpyArray joint_velocities;
  safety::Outcome outcome = safety::Outcome::Within;
  safety::Outcome autonomy_outcome = safety::Outcome::Within;
};

// The whole-body assistance of one robot in one scene (robot and scene kept alive: the core views their arrays).
class WholeBodyAssist {
 public:
  WholeBodyAssist(nb::handle_t<RobotArrays> robot, nb::handle_t<AssistScene> scene,
                  const JointAssistParams& joint_params, double limit_tolerance, std::optional<Point> goal_position,
                  std::optional<Quaternion> goal_orientation, std::optional<Vector> step_params)
      : robot_(robot), scene_(scene), limit_tolerance_(limit_tolerance) {
    autonomy_qd_.resize(robot_->joints());
    const bool goal = goal_position.has_value();
    require(goal == goal_orientation.has_value() && goal == step_params.has_value(),
            "whole body: give the goal position, orientation and step parameters together, or none");
    if (!goal) {
      core_.emplace(robot_->view(), scene_->obstacles(), scene_->params(), joint_params);
      return;
    }
    core_.emplace(robot_->view(), scene_->obstacles(), scene_->params(), joint_params,
                  goal_pose(*goal_position, *goal_orientation), whole_body_params(*step_params));
  }

  std::size_t joints() const { return core_->joint_count(); }

  // The assistance alone at a validated q (no goal: the autonomy vector is zero).
  JointAnswer assist(const Vector& q, const Twist6& user, Arbitration mode, double goal_share,
                     std::optional<Vector> user_joints) {
    require(q.shape(0) == joints(), "q: expected one value per joint");
    JointAnswer answer;
    auto [qd, data] = new_array({joints()});
    static_cast<JointAssistance&>(answer) =
        core_->assist(q.data(), command(user, user_joints), mode, goal_share, data);
    answer.outcome = contract(data, answer.blended);
    answer.joint_velocities = std::move(qd);
    return answer;
  }

  // The field's step and the assistance on it, or None when the step refuses q, previous or dt.
  nb::object step(const Vector& q, std::optional<Vector> previous, double dt, const Twist6& user, Arbitration mode,
                  std::optional<Vector> user_joints) {
    require(core_->has_step(), "whole body: bound without a goal, it has no step");
    const bool given = previous.has_value();
    const shared_control::OperatorCommand operator_command = command(user, user_joints);
    JointAnswer answer;
    auto [qd, data] = new_array({joints()});
    if (!core_->step(q.data(), q.shape(0), given ? previous->data() : nullptr, given ? previous->shape(0) : 0, dt,
                     limit_tolerance_, operator_command, mode, answer, data))
      return nb::none();
    answer.outcome = contract(data, answer.blended);
    // the autonomy vector's joint velocities and twist by one factor (only the twist is reported)
    const double* qd_auto = core_->autonomy_joint_velocities();
    std::copy(qd_auto, qd_auto + joints(), autonomy_qd_.begin());
    answer.autonomy_outcome = contract(autonomy_qd_.data(), answer.autonomy);
    answer.joint_velocities = std::move(qd);
    return nb::cast(std::move(answer));
  }

 private:
  // The operator's twist, or with user_joints (validated: n finite values) its joint velocities instead.
  shared_control::OperatorCommand command(const Twist6& user, const std::optional<Vector>& user_joints) const {
    if (!user_joints.has_value()) return {user.data(), nullptr};
    require(user_joints->shape(0) == joints(), "user_joints: expected one value per joint");
    return {user.data(), user_joints->data()};
  }

  // The output contract on a whole-body command in place (pfield.safety.limit_joint_command).
  safety::Outcome contract(double* qd, double* twist) const {
    const AssistParams& params = scene_->params();
    return safety::limit_joint_command(qd, joints(), twist, core_->robot().limits.max_velocity,
                                       params.max_linear_velocity, params.max_angular_velocity);
  }

  Held<RobotArrays> robot_;  // the core views their arrays
  Held<AssistScene> scene_;
  double limit_tolerance_;
  std::optional<shared_control::WholeBodyAssistance> core_;
  std::vector<double> autonomy_qd_;  // the step's qd_auto under the output contract (its twist is reported)
};

}  // namespace

void bind_assistance(nb::module_& m) {
  m.doc() = "Shared-control assistance: the operator's command arbitrated with the field's, its dampers, the nearest "
            "obstacle (pfield.shared_control.assistance's compiled core).";
  nb::enum_<Arbitration>(m, "Arbitration", "How alpha is chosen (pfield.shared_control.ARBITRATIONS).")
      .value("linear", Arbitration::Linear, "alpha = clip((Q - d)/(Q - d_s), 0, 1)")
      .value("linear_goal", Arbitration::LinearGoal, "at least the goal share clip(1 - |g - p|/R, 0, 1)")
      .value("safety_only", Arbitration::SafetyOnly, "alpha = 0: the operator's command, its approach limited");

  m.def("servo_scale", &shared_control::servo_scale, "distance"_a, "threshold"_a,
        "MoveIt Servo's collision velocity scale exp(k (d - d_t)), k = -ln(0.001)/d_t, for 0 < d < d_t (1 beyond, "
        "0 in collision).");
  m.def("obstacle_share", &shared_control::obstacle_share, "distance"_a, "influence"_a, "safety"_a,
        "alpha_obs = clip((Q - d)/(Q - d_s), 0, 1).");

  nb::class_<AssistParams>(m, "Params", "A scene's settings (FieldConfig's and AssistanceOptions.scene_threshold).")
      .def(
          "__init__",
          [](AssistParams* self, double influence_distance, double safety_distance, double damper_gain,
             double max_linear_velocity, double max_linear_acceleration, double max_angular_velocity,
             double scale_threshold) {
            new (self) AssistParams{influence_distance,      safety_distance,      damper_gain, max_linear_velocity,
                                    max_linear_acceleration, max_angular_velocity, scale_threshold};
          },
          "influence_distance"_a, "safety_distance"_a, "damper_gain"_a, "max_linear_velocity"_a,
          "max_linear_acceleration"_a, "max_angular_velocity"_a, "scale_threshold"_a)
      .def_ro("influence_distance", &AssistParams::influence_distance, "Q (m)")
      .def_ro("safety_distance", &AssistParams::safety_distance, "d_s (m)")
      .def_ro("damper_gain", &AssistParams::damper_gain, "the damper's speed at Q (m/s) before its caps")
      .def_ro("max_linear_velocity", &AssistParams::max_linear_velocity, "m/s")
      .def_ro("max_linear_acceleration", &AssistParams::max_linear_acceleration, "m/s^2")
      .def_ro("max_angular_velocity", &AssistParams::max_angular_velocity, "rad/s")
      .def_ro("scale_threshold", &AssistParams::scale_threshold, "MoveIt Servo's threshold d_t (m)");
  nb::class_<JointAssistParams>(m, "JointParams", "The whole body's settings (AssistanceOptions).")
      .def(
          "__init__",
          [](JointAssistParams* self, double damping, double joint_limit_margin, double singularity_threshold,
             double goal_tolerance, double rotation_tolerance, double stall_speed, double goal_radius) {
            new (self) JointAssistParams{damping,            joint_limit_margin, singularity_threshold, goal_tolerance,
                                         rotation_tolerance, stall_speed,        goal_radius};
          },
          "damping"_a, "joint_limit_margin"_a, "singularity_threshold"_a, "goal_tolerance"_a,
          "rotation_tolerance"_a, "stall_speed"_a, "goal_radius"_a)
      .def_ro("damping", &JointAssistParams::damping, "lambda of the damped least squares")
      .def_ro("joint_limit_margin", &JointAssistParams::joint_limit_margin, "rad or m")
      .def_ro("singularity_threshold", &JointAssistParams::singularity_threshold, "on sigma_min(J)")
      .def_ro("goal_tolerance", &JointAssistParams::goal_tolerance, "m")
      .def_ro("rotation_tolerance", &JointAssistParams::rotation_tolerance, "rad")
      .def_ro("stall_speed", &JointAssistParams::stall_speed, "m/s and rad/s")
      .def_ro("goal_radius", &JointAssistParams::goal_radius, "R (m)");

  nb::class_<PointAnswer>(m, "PointAssistance", "The task-space answer at one robot point.")
      .def_prop_ro("blended",
                   [](nb::handle_t<PointAnswer> self) {
                     return view<6>(nb::inst_ptr<PointAnswer>(self)->blended, self);
                   },
                   "(6,) the command under the dampers and the output contract (m/s, rad/s), a read-only view")
      .def_ro("alpha", &PointAssistance::alpha)
      .def_ro("speed_scale", &PointAssistance::speed_scale)
      .def_ro("nearest", &PointAssistance::nearest, "the nearest obstacle's index, -1 without obstacles")
      .def_ro("distance", &PointAssistance::distance, "its signed distance (m), inf without obstacles")
      .def_prop_ro("normal",
                   [](nb::handle_t<PointAnswer> self) {
                     return view<3>(nb::inst_ptr<PointAnswer>(self)->normal, self);
                   },
                   "(3,) grad d, from the obstacle toward the robot (0 without obstacles)")
      .def_prop_ro("obstacle_point",
                   [](nb::handle_t<PointAnswer> self) {
                     return view<3>(nb::inst_ptr<PointAnswer>(self)->obstacle_point, self);
                   },
                   "(3,) p - d n (p without obstacles)")
      .def_ro("time_to_collision", &PointAssistance::time_to_collision, "s")
      .def_ro("limited", &PointAssistance::limited, "a damper changed the blend")
      .def_prop_ro("outcome", [](const PointAnswer& a) { return static_cast<int>(a.outcome); },
                   "the output contract's outcome on the command (0 within, 1 scaled, 2 halted)");

  nb::class_<AssistScene>(m, "AssistanceScene", "An AssistanceScene's obstacles (read in place) and parameters.")
      .def(nb::init<nb::handle_t<ObstacleArrays>, const Rows<3>&, const AssistParams&>(), "obstacles"_a,
           "velocities"_a, "params"_a, "obstacles: a robot.Obstacles; velocities (M, 3) m/s, one row per obstacle.")
      .def("assist_point", &AssistScene::assist_point, "position"_a, "user"_a, "autonomy_linear"_a,
           "autonomy_angular"_a, "mode"_a, "goal_share"_a,
           "The task-space assistance at a robot point (3,) for the operator's twist (6,) and the autonomy twist's "
           "parts (3,) each.");

  nb::class_<JointAnswer>(m, "JointAssistance", "The whole-body answer.")
      .def_prop_ro("joint_velocities", [](const JointAnswer& a) { return a.joint_velocities; },
                   nb::rv_policy::automatic,
                   "(n,) qd under the output contract (an array of its own)")
      .def_prop_ro("blended",
                   [](nb::handle_t<JointAnswer> self) {
                     return view<6>(nb::inst_ptr<JointAnswer>(self)->blended, self);
                   },
                   "(6,) J qd under the output contract, a read-only view")
      .def_ro("alpha", &JointAnswer::alpha)
      .def_ro("speed_scale", &JointAnswer::speed_scale)
      .def_prop_ro("nearest_link", [](const JointAnswer& a) { return a.nearest.link; }, "-1 when none")
      .def_prop_ro("nearest", [](const JointAnswer& a) { return a.nearest.obstacle; }, "the obstacle, -1 when none")
      .def_prop_ro("distance", [](const JointAnswer& a) { return a.nearest.distance; }, "m, inf when none")
      .def_prop_ro("normal",
                   [](nb::handle_t<JointAnswer> self) {
                     return view<3>(nb::inst_ptr<JointAnswer>(self)->nearest.normal, self);
                   },
                   "(3,) from the obstacle toward the link")
      .def_prop_ro("robot_point",
                   [](nb::handle_t<JointAnswer> self) {
                     return view<3>(nb::inst_ptr<JointAnswer>(self)->nearest.point, self);
                   },
                   "(3,) the link's witness point")
      .def_prop_ro("obstacle_point",
                   [](nb::handle_t<JointAnswer> self) {
                     return view<3>(nb::inst_ptr<JointAnswer>(self)->obstacle_point, self);
                   },
                   "(3,) robot_point - d n")
      .def_ro("time_to_collision", &JointAnswer::time_to_collision, "s")
      .def_ro("limited", &JointAnswer::limited, "the damper corrected qd")
      .def_ro("at_limit", &JointAnswer::at_limit)
      .def_ro("singular", &JointAnswer::singular)
      .def_prop_ro("outcome", [](const JointAnswer& a) { return static_cast<int>(a.outcome); },
                   "the output contract's outcome on (qd, blended)")
      .def_ro("at_goal", &JointAnswer::at_goal)
      .def_ro("stalled", &JointAnswer::stalled)
      .def_prop_ro("autonomy",
                   [](nb::handle_t<JointAnswer> self) {
                     return view<6>(nb::inst_ptr<JointAnswer>(self)->autonomy, self);
                   },
                   "(6,) the step's twist under the output contract (with a goal)")
      .def_prop_ro("autonomy_outcome", [](const JointAnswer& a) { return static_cast<int>(a.autonomy_outcome); },
                   "the output contract's outcome on the step's (qd_auto, twist)");

  nb::class_<WholeBodyAssist>(m, "WholeBody",
                              "A robot's whole-body assistance in a scene: its workspace and field step.")
      .def(nb::init<nb::handle_t<RobotArrays>, nb::handle_t<AssistScene>, const JointAssistParams&, double,
                    std::optional<Point>, std::optional<Quaternion>, std::optional<Vector>>(),
           "robot"_a, "scene"_a, "params"_a, "limit_tolerance"_a, "goal_position"_a.none() = nb::none(),
           "goal_orientation"_a.none() = nb::none(), "step_params"_a.none() = nb::none(),
           "robot: a robot.Robot, scene: an AssistanceScene; with the goal (3,), (4,) (x, y, z, w) and the step's "
           "parameters (_whole_body_layout.PARAMS, copied), the field's step as well.")
      .def_prop_ro("joint_count", &WholeBodyAssist::joints)
      .def("assist", &WholeBodyAssist::assist, "q"_a, "user"_a, "mode"_a, "goal_share"_a,
           "user_joints"_a.none() = nb::none(),
           "The assistance alone at a validated q (the autonomy vector zero); with user_joints (n, validated) the "
           "operator's joint velocities instead of the twist user's map.")
      .def("step", &WholeBodyAssist::step, "q"_a.noconvert(), "previous"_a.none().noconvert(), "dt"_a, "user"_a,
           "mode"_a, "user_joints"_a.none() = nb::none(),
           "The field's step at q and the assistance on it, or None when q (n values within the limits up to "
           "limit_tolerance), previous (n finite values) or dt (finite, >= 0) is refused; user_joints as in assist.");
}

}  // namespace pfield::python
