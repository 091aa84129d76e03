// Bindings of shared-control assistance (pfield.shared_control.assistance): a thin list of defs over
// shared_control/assist.hpp. A Scene is an AssistanceScene's core (its packed obstacles, bounding spheres and
// velocities read in place, its parameters copied); a WholeBody binds a robot (RobotArrays) to a scene, owns the
// workspace and, with a goal, the field's step. (Their C++ names differ from other binding files' classes: nanobind
// knows a type by its mangled name, and an anonymous namespace's Scene is the same name in every file.) Answers are
// structs with named read-only fields; their vectors are read-only NumPy views of the answer's own memory. No
// arithmetic here beyond the output contract, applied to the core's commands as pfield.safety applies it (this file
// is compiled like python/safety.cpp: the same bits); the core computes.
#include <nanobind/nanobind.h>
#include <nanobind/stl/optional.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <optional>
#include <stdexcept>
#include <utility>
#include <vector>

#include "math/vec3.hpp"
#include "planning/whole_body.hpp"
#include "python/arrays.hpp"
#include "python/packed.hpp"
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

using Point = nb::ndarray<const double, nb::shape<3>, nb::c_contig, nb::device::cpu>;
using Twist6 = nb::ndarray<const double, nb::shape<6>, nb::c_contig, nb::device::cpu>;
using Quaternion = nb::ndarray<const double, nb::shape<4>, nb::c_contig, nb::device::cpu>;
template <std::size_t N>
using ReadOnly = nb::ndarray<nb::numpy, const double, nb::shape<N>>;

static_assert(sizeof(math::Vec3) == 3 * sizeof(double), "a Vec3 is three contiguous doubles (viewed as (3,))");
constexpr std::size_t kStepParams = sizeof(planning::WholeBodyParams) / sizeof(double);
static_assert(kStepParams == 20, "WholeBodyParams is _whole_body_layout.PARAMS's 20 doubles");

void require(bool condition, const char* message) {
  if (!condition) throw std::invalid_argument(message);
}

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

// An AssistanceScene's core: the packed obstacles (PackedObstacles' eight arrays), their bounding spheres and
// velocities (M, 3), read in place; the parameters copied.
class AssistScene {
 public:
  AssistScene(const Kinds& kinds, const Rows<16>& rows, const Triangles& triangles, const PseudoNormals& pseudo_normals,
        const Rows<3>& bvh_lower, const Rows<3>& bvh_upper, const Nodes& bvh_nodes, const MeshTable& mesh_table,
        const Rows<3>& centres, const Vector& bounds, const Rows<3>& velocities, const AssistParams& params)
      : kinds_(kinds), rows_(rows), triangles_(triangles), pseudo_normals_(pseudo_normals), bvh_lower_(bvh_lower),
        bvh_upper_(bvh_upper), bvh_nodes_(bvh_nodes), mesh_table_(mesh_table), centres_(centres), bounds_(bounds),
        velocities_(velocities), params_(params),
        packed_(packed_view(kinds, rows, triangles, pseudo_normals, bvh_lower, bvh_upper, bvh_nodes, mesh_table)) {
    const std::size_t count = kinds.shape(0);
    require(centres.shape(0) == count && bounds.shape(0) == count && velocities.shape(0) == count,
            "scene: centres, bounds and velocities need one row per obstacle");
    obstacles_ = {{&packed_, centres.data(), bounds.data()}, velocities.data()};
  }

  const shared_control::MovingObstacles& obstacles() const { return obstacles_; }
  const AssistParams& params() const { return params_; }

  PointAnswer assist_point(const Point& position, const Twist6& user, const Point& autonomy_linear,
                           const Point& autonomy_angular, Arbitration mode, double goal_share) const {
    const double* p = position.data();
    double autonomy[6];
    std::copy_n(autonomy_linear.data(), 3, autonomy);
    std::copy_n(autonomy_angular.data(), 3, autonomy + 3);
    PointAnswer answer;
    static_cast<PointAssistance&>(answer) = shared_control::assist_point(
        packed_, velocities_.data(), {p[0], p[1], p[2]}, user.data(), autonomy, params_, mode, goal_share);
    answer.outcome = safety::limit_twist(answer.blended, params_.max_linear_velocity, params_.max_angular_velocity);
    return answer;
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
  Rows<3> velocities_;
  AssistParams params_;
  geometry::PackedView packed_;
  shared_control::MovingObstacles obstacles_;
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
  WholeBodyAssist(nb::object robot, nb::object scene, const JointAssistParams& joint_params, double limit_tolerance,
            std::optional<Point> goal_position, std::optional<Quaternion> goal_orientation,
            std::optional<Vector> step_params)
      : robot_owner_(std::move(robot)), scene_owner_(std::move(scene)),
        scene_(&nb::cast<const AssistScene&>(scene_owner_)), limit_tolerance_(limit_tolerance) {
    const RobotArrays& arrays = nb::cast<const RobotArrays&>(robot_owner_);
    const AssistScene& where = *scene_;
    autonomy_qd_.resize(arrays.joints());
    const bool goal = goal_position.has_value();
    require(goal == goal_orientation.has_value() && goal == step_params.has_value(),
            "whole body: give the goal position, orientation and step parameters together, or none");
    if (!goal) {
      core_.emplace(arrays.view(), where.obstacles(), where.params(), joint_params);
      return;
    }
    require(step_params->shape(0) == kStepParams, "step_params: expected _whole_body_layout.PARAMS's 20 numbers");
    planning::WholeBodyParams params{};
    std::memcpy(&params, step_params->data(), sizeof(params));
    const double* g = goal_position->data();
    const double* o = goal_orientation->data();
    core_.emplace(arrays.view(), where.obstacles(), where.params(), joint_params,
                  planning::Goal{{g[0], g[1], g[2]}, {o[0], o[1], o[2], o[3]}}, params);
  }

  std::size_t joints() const { return core_->joint_count(); }

  // The assistance alone at a validated q (no goal: the autonomy vector is zero).
  JointAnswer assist(const Vector& q, const Twist6& user, Arbitration mode, double goal_share) {
    require(q.shape(0) == joints(), "q: expected one value per joint");
    JointAnswer answer;
    auto [qd, data] = new_array({joints()});
    static_cast<JointAssistance&>(answer) = core_->assist(q.data(), user.data(), mode, goal_share, data);
    answer.outcome = contract(data, answer.blended);
    answer.joint_velocities = std::move(qd);
    return answer;
  }

  // The field's step and the assistance on it, or None when the step refuses q, previous or dt.
  nb::object step(const Vector& q, std::optional<Vector> previous, double dt, const Twist6& user, Arbitration mode) {
    require(core_->has_step(), "whole body: bound without a goal, it has no step");
    const bool given = previous.has_value();
    JointAnswer answer;
    auto [qd, data] = new_array({joints()});
    if (!core_->step(q.data(), q.shape(0), given ? previous->data() : nullptr, given ? previous->shape(0) : 0, dt,
                     limit_tolerance_, user.data(), mode, answer, data))
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
  // The output contract on a whole-body command in place (pfield.safety.limit_joint_command).
  safety::Outcome contract(double* qd, double* twist) const {
    const AssistParams& params = scene_->params();
    return safety::limit_joint_command(qd, joints(), twist, core_->robot().limits.max_velocity,
                                       params.max_linear_velocity, params.max_angular_velocity);
  }

  nb::object robot_owner_, scene_owner_;
  const AssistScene* scene_;
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

  nb::class_<AssistScene>(m, "Scene", "An AssistanceScene's obstacles (read in place) and parameters.")
      .def(nb::init<const Kinds&, const Rows<16>&, const Triangles&, const PseudoNormals&, const Rows<3>&,
                    const Rows<3>&, const Nodes&, const MeshTable&, const Rows<3>&, const Vector&, const Rows<3>&,
                    const AssistParams&>(),
           "kinds"_a, "rows"_a, "triangles"_a, "pseudo_normals"_a, "bvh_lower"_a, "bvh_upper"_a, "bvh_nodes"_a,
           "mesh_table"_a, "centres"_a, "bounds"_a, "velocities"_a, "params"_a,
           "Scene(*packed, centres, bounds, velocities, params): bounding spheres (M, 3), (M,), velocities (M, 3).")
      .def("assist_point", &AssistScene::assist_point, "position"_a, "user"_a, "autonomy_linear"_a,
           "autonomy_angular"_a, "mode"_a, "goal_share"_a,
           "The task-space assistance at a robot point (3,) for the operator's twist (6,) and the autonomy twist's "
           "parts (3,) each.");

  nb::class_<RobotArrays>(m, "Robot", "A robot's RobotArrays (pfield.planning._whole_body_layout), read in place.")
      .def(nb::init<const RobotArrays::Ints&, const RobotArrays::Rotations&, const Rows<3>&, const Rows<3>&,
                    const RobotArrays::Ints&, const RobotArrays::IntMatrix&, std::int64_t, const RobotArrays::Matrix3&,
                    const RobotArrays::Point&, const RobotArrays::Ints&, const Rows<3>&, const Rows<3>&,
                    const Vector&, const RobotArrays::Pairs&, const Vector&, const Vector&, const Vector&,
                    const Vector&, const RobotArrays::Ints&, const RobotArrays::Ints&, const Rows<3>&, const Rows<3>&,
                    const Vector&, const Vector&>(),
           "parents"_a, "place_rot"_a, "place_pos"_a, "axes"_a, "kinds"_a, "support"_a, "ee_joint"_a, "ee_rot"_a,
           "ee_pos"_a, "cap_joint"_a, "cap_a"_a, "cap_b"_a, "cap_r"_a, "self_pairs"_a, "lower"_a, "upper"_a,
           "max_velocity"_a, "max_acceleration"_a, "link_start"_a, "prim_joint"_a, "prim_a"_a, "prim_b"_a,
           "prim_r"_a, "self_r"_a, "RobotArrays' fields in order (Robot(*arrays)).")
      .def_prop_ro("joint_count", &RobotArrays::joints);

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
      .def(nb::init<nb::object, nb::object, const JointAssistParams&, double, std::optional<Point>,
                    std::optional<Quaternion>, std::optional<Vector>>(),
           "robot"_a, "scene"_a, "params"_a, "limit_tolerance"_a, "goal_position"_a.none() = nb::none(),
           "goal_orientation"_a.none() = nb::none(), "step_params"_a.none() = nb::none(),
           "robot: a Robot, scene: a Scene; with the goal (3,), (4,) (x, y, z, w) and the step's parameters "
           "(_whole_body_layout.PARAMS, copied), the field's step as well.")
      .def_prop_ro("joint_count", &WholeBodyAssist::joints)
      .def("assist", &WholeBodyAssist::assist, "q"_a, "user"_a, "mode"_a, "goal_share"_a,
           "The assistance alone at a validated q (the autonomy vector zero).")
      .def("step", &WholeBodyAssist::step, "q"_a.noconvert(), "previous"_a.none().noconvert(), "dt"_a, "user"_a,
           "mode"_a,
           "The field's step at q and the assistance on it, or None when q (n values within the limits up to "
           "limit_tolerance), previous (n finite values) or dt (finite, >= 0) is refused.");
}

}  // namespace pfield::python
