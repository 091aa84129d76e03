// Bindings of the robot's kinematics and IK (pfield.robot.model, pfield.robot.ik): a thin list of defs over
// robot/kinematics.hpp and robot/ik.hpp. A Kinematics views a robot.Robot (python/robot_arrays.hpp: a RobotModel's
// KinematicArrays and limits, bound once) with the scratch of its calls, so each call passes only q. No arithmetic
// here: this file is compiled with fused multiply-adds allowed, the core's robot files are not, and every number
// comes from them.
#include <nanobind/nanobind.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/tuple.h>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "math/dls.hpp"
#include "python/arrays.hpp"
#include "python/robot_arrays.hpp"
#include "robot/ik.hpp"
#include "robot/kinematics.hpp"
#include "robot/robot.hpp"

namespace pfield::python {
namespace {

using namespace nb::literals;
using robot::FramePose;
using robot::Frames;
using robot::IKInput;
using robot::IKOutcome;
using robot::IKPathOutcome;
using robot::IKSettings;
using robot::KinematicsView;
using robot::LimitCheck;
using robot::Vec3;

using Values = nb::ndarray<double, nb::ndim<1>, nb::c_contig, nb::device::cpu>;

Vec3 vec3(const double* v) { return {v[0], v[1], v[2]}; }

NumpyArray copy_rotation(const double* r) {
  auto [out, data] = new_array({3, 3});
  std::copy(r, r + 9, data);
  return out;
}

NumpyArray copy_point(const Vec3& p) {
  auto [out, data] = new_array({3});
  data[0] = p.x, data[1] = p.y, data[2] = p.z;
  return out;
}

// The kinematics of a robot.Robot (kept alive: its tree and limits are read in place) and the workspace of the
// calls that hold the GIL (forward kinematics, Jacobians: one step each).
//
// The public calls (forward_kinematics, jacobian, solve_ik) take q as the caller gave it and apply
// RobotModel.check_joint_angles's rule themselves, by the core's check_limits (n values, finite, within the limits
// up to limit_tolerance, clamped onto them): they answer false / None when q breaks it, and Python then raises the
// error check_joint_angles words. One pass over q instead of a NumPy copy and a second call.
class Kinematics {
 public:
  Kinematics(nb::handle_t<RobotArrays> robot, double limit_tolerance)
      : robot_(robot), limit_tolerance_(limit_tolerance) {
    const std::size_t n = joints();
    rotations_.resize(9 * n);
    origins_.resize(3 * n);
    q_.resize(n);
  }

  const KinematicsView& view() const { return robot_->view().kinematics; }
  const double* lower() const { return robot_->view().limits.lower; }
  const double* upper() const { return robot_->view().limits.upper; }
  std::size_t joints() const { return robot_->joints(); }

  void check_q(const Vector& q, const char* name = "q") const {
    if (q.shape(0) != joints())
      throw std::invalid_argument(std::string(name) + ": expected " + std::to_string(joints()) + " joint values");
  }
  void check_joint(std::int64_t joint) const {
    if (joint < -1 || joint >= static_cast<std::int64_t>(joints()))
      throw std::invalid_argument("joint: expected a joint index or -1 (the base)");
  }

  double limit_tolerance() const { return limit_tolerance_; }

  // q checked and clamped by check_joint_angles's rule into `clamped` (n,); false when it breaks the rule.
  bool accept(const Vector& q, double* clamped) const {
    return q.shape(0) == joints() && accept(q.data(), clamped);
  }
  // The same for n values at q.
  bool accept(const double* q, double* clamped) const {
    std::copy(q, q + joints(), clamped);
    return robot::check_limits(clamped, lower(), upper(), joints(), limit_tolerance_).status ==
           LimitCheck::Status::Ok;
  }

  // (status, index): the first value (n,) not finite or beyond the limits by more than tolerance, the values
  // before it clamped onto the limits in place (all of them when the status is Ok).
  std::tuple<LimitCheck::Status, std::int64_t> check_limits(Values& values, double tolerance) const {
    if (values.shape(0) != joints()) throw std::invalid_argument("values: expected one per joint");
    const LimitCheck check = robot::check_limits(values.data(), lower(), upper(), joints(), tolerance);
    return {check.status, check.index};
  }

  std::tuple<NumpyArray, NumpyArray> joint_frames(const Vector& q) {
    const std::size_t n = joints();
    auto [rotations, r] = new_array({n, 3, 3});
    auto [origins, o] = new_array({n, 3});
    check_q(q);
    Frames frames{r, o};
    robot::joint_transforms(view(), q.data(), frames);
    return {rotations, origins};
  }

  // The end effector's pose at q: (position (3,), unit quaternion x y z w (4,)), new read-only arrays that
  // pfield.spatial.pose_from_checked adopts; None when q breaks check_joint_angles's rule. q is read as Doubles (the
  // hot path of the public RobotModel.forward_kinematics): anything but a C-contiguous float64 array of n values
  // raises TypeError, and Python then converts q by check_joint_angles.
  nb::object forward_kinematics(nb::handle q) {
    if (!accept(doubles(q, joints()), q_.data())) return nb::none();
    Frames frames{rotations_.data(), origins_.data()};
    double pose[7];
    robot::end_effector_pose7(view(), q_.data(), frames, pose);
    return nb::make_tuple(readonly_copy(pose, 3), readonly_copy(pose + 3, 4));
  }

  // The end effector's 6 x n Jacobian at q into out; false (out untouched) when q breaks the rule.
  bool jacobian(const Vector& q, OutMatrix& out) {
    if (out.shape(0) != 6 || out.shape(1) != joints()) throw std::invalid_argument("out: expected a 6 x n array");
    if (!accept(q, q_.data())) return false;
    Frames frames{rotations_.data(), origins_.data()};
    robot::end_effector_kinematics(view(), q_.data(), frames, out.data());
    return true;
  }

  // kappa of the end effector's Jacobian at q (robot::condition_number), or None when q is refused as by jacobian.
  std::optional<double> condition_number(const Vector& q) {
    if (!accept(q, q_.data())) return std::nullopt;
    Frames frames{rotations_.data(), origins_.data()};
    jacobian_.resize(6 * joints());
    robot::end_effector_kinematics(view(), q_.data(), frames, jacobian_.data());
    return robot::condition_number(jacobian_.data(), joints());
  }

  // q_dot (n,) = J^T (J J^T + damping I)^-1 twist (math::damped_least_squares) into out: the joint velocities that
  // realise an end-effector twist (6,: linear, angular, world-aligned) in the damped least-squares sense; false
  // (out untouched) when q is refused as by jacobian. twist and damping come checked (pfield.robot.ik).
  bool differential_ik(const Vector& q, const Vector& twist, double damping, OutVector& out) {
    if (twist.shape(0) != 6 || out.shape(0) != joints())
      throw std::invalid_argument("twist, out: expected 6 values and one per joint");
    if (!accept(q, q_.data())) return false;
    Frames frames{rotations_.data(), origins_.data()};
    jacobian_.resize(6 * joints());
    robot::end_effector_kinematics(view(), q_.data(), frames, jacobian_.data());
    math::damped_least_squares(jacobian_.data(), 6, joints(), nullptr, damping, twist.data(), out.data());
    return true;
  }

  // (rotation (3, 3), position (3,), Jacobian (6, n)) of the end effector at q.
  std::tuple<NumpyArray, NumpyArray, NumpyArray> end_effector_kinematics(const Vector& q) {
    check_q(q);
    auto [jac, data] = new_array({6, joints()});
    Frames frames{rotations_.data(), origins_.data()};
    const FramePose pose = robot::end_effector_kinematics(view(), q.data(), frames, data);
    return {copy_rotation(pose.rotation), copy_point(pose.position), jac};
  }

  NumpyArray end_effector_positions(const Matrix& qs) {
    if (qs.shape(1) != joints()) throw std::invalid_argument("qs: expected (N, n) joint values");
    const std::size_t count = qs.shape(0), n = joints();
    auto [out, data] = new_array({count, 3});
    {
      nb::gil_scoped_release release;
      std::vector<double> rotations(9 * n), origins(3 * n);
      Frames frames{rotations.data(), origins.data()};
      robot::batch_end_effector_positions(view(), qs.data(), count, frames, data);
    }
    return out;
  }

  // The pieces on given joint frames (rotations (n, 3, 3), origins (n, 3)), for tests and the kernels' callers.
  Frames given_frames(const Rotations& rotations, const Rows<3>& origins) const {
    if (rotations.shape(0) != joints() || origins.shape(0) != joints())
      throw std::invalid_argument("rotations, origins: expected one per joint");
    // read only: the functions taking these frames take them as const Frames&
    return {const_cast<double*>(rotations.data()), const_cast<double*>(origins.data())};
  }

  std::tuple<NumpyArray, NumpyArray> frame_pose(const Rotations& rotations, const Rows<3>& origins,
                                                std::int64_t joint, const Matrix3& local_rotation,
                                                const Point& local_position) const {
    check_joint(joint);
    const FramePose pose = robot::frame_pose(given_frames(rotations, origins), joint, local_rotation.data(),
                                             vec3(local_position.data()));
    return {copy_rotation(pose.rotation), copy_point(pose.position)};
  }

  NumpyArray point_jacobian(const Rotations& rotations, const Rows<3>& origins, std::int64_t joint,
                            const Point& point, bool linear_only) const {
    check_joint(joint);
    const Frames frames = given_frames(rotations, origins);
    auto [out, data] = new_array({linear_only ? std::size_t{3} : std::size_t{6}, joints()});
    if (linear_only)
      robot::linear_point_jacobian(view(), frames, joint, vec3(point.data()), data);
    else
      robot::point_jacobian(view(), frames, joint, vec3(point.data()), data);
    return out;
  }

  // solve_ik: the IK from seed to a target pose (a unit quaternion) into q (n,), GIL released; None (q untouched)
  // when the seed breaks check_joint_angles's rule.
  std::optional<IKOutcome> solve_ik(const Vector& seed, const Point& position, const Quaternion& orientation,
                                    const IKSettings& settings, Values& q) const {
    if (q.shape(0) != joints()) throw std::invalid_argument("q: expected one value per joint");
    IKOutcome outcome;
    {
      nb::gil_scoped_release release;
      if (!accept(seed, q.data())) return std::nullopt;
      robot::IKSolver solver(view(), lower(), upper(), settings);
      const double* o = orientation.data();
      outcome = solver.solve(q.data(), {vec3(position.data()), {o[0], o[1], o[2], o[3]}}, q.data());
    }
    return outcome;
  }

  // The IK along a path: (qs (count, n), outcome); rows after a failure are zero.
  std::tuple<NumpyArray, IKPathOutcome> solve_ik_path(const Vector& seed, const Rows<3>& positions,
                                                      const Rows<4>& orientations, const IKSettings& settings) const {
    check_q(seed, "seed");
    const std::size_t count = positions.shape(0), n = joints();
    if (orientations.shape(0) != count) throw std::invalid_argument("orientations: expected one per position");
    auto [qs, data] = new_array({count, n});
    std::fill(data, data + count * n, 0.0);
    IKPathOutcome outcome;
    {
      nb::gil_scoped_release release;
      robot::IKSolver solver(view(), lower(), upper(), settings);
      outcome = solver.solve_path(seed.data(), positions.data(), orientations.data(), count, data);
    }
    return {qs, outcome};
  }

 private:
  Held<RobotArrays> robot_;
  double limit_tolerance_;
  std::vector<double> rotations_, origins_, q_;
  std::vector<double> jacobian_;  // condition_number's (6, n)
};

// IKSolver's state: the target (7), seed (n) and answer q (n) live here, seen from Python as NumPy arrays over
// this memory, so a control loop's call passes nothing.
class PreparedIK {
 public:
  PreparedIK(nb::handle_t<Kinematics> kinematics, const IKSettings& settings)
      : robot_(kinematics),
        solver_(robot_->view(), robot_->lower(), robot_->upper(), settings),
        limit_tolerance_(robot_->limit_tolerance()),
        seed_(robot_->joints(), 0.0),
        q_(robot_->joints(), 0.0) {}

  IKInput solve() {
    nb::gil_scoped_release release;
    return solver_.solve_checked(seed_.data(), target_, limit_tolerance_, q_.data(), outcome_);
  }

  const IKOutcome& outcome() const { return outcome_; }
  bool success() const { return outcome_.success; }
  const IKSettings& settings() const { return solver_.settings(); }

  double target_[7] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0};
  std::vector<double>& seed() { return seed_; }
  std::vector<double>& q() { return q_; }

 private:
  Held<Kinematics> robot_;
  robot::IKSolver solver_;
  double limit_tolerance_;
  std::vector<double> seed_, q_;
  IKOutcome outcome_;
};

nb::ndarray<nb::numpy, double, nb::ndim<1>> view_of(double* data, std::size_t size, nb::handle owner) {
  return nb::ndarray<nb::numpy, double, nb::ndim<1>>(data, {size}, owner);
}

}  // namespace

void bind_robot_kinematics(nb::module_& m) {
  m.doc() = "The robot's forward kinematics, Jacobians and damped least-squares IK (pfield.robot's compiled core).";

  nb::enum_<LimitCheck::Status>(m, "LimitStatus", "check_limits's verdict on joint values")
      .value("Ok", LimitCheck::Status::Ok, "every value finite and within the limits (clamped onto them)")
      .value("BeyondLimits", LimitCheck::Status::BeyondLimits, "a value beyond its limits by more than tolerance")
      .value("NotFinite", LimitCheck::Status::NotFinite, "a value that is NaN or infinite");
  nb::enum_<IKInput>(m, "IKInput", "what a prepared IK solve refused before iterating")
      .value("Valid", IKInput::Valid)
      .value("BadSeed", IKInput::BadSeed, "not finite, or beyond the joint limits")
      .value("BadPosition", IKInput::BadPosition, "a target position that is not finite")
      .value("BadOrientation", IKInput::BadOrientation, "a target quaternion whose norm is not 1 within 1e-9");

  nb::class_<IKSettings>(m, "IKSettings", "The DLS IK's settings (validated by pfield.robot.ik).")
      .def(nb::init<>())
      .def(
          "__init__",
          [](IKSettings* self, std::int64_t max_iterations, double position_tolerance, double rotation_tolerance,
             double damping, double max_step) {
            if (max_iterations < 1) throw std::invalid_argument("max_iterations: must be >= 1");
            new (self) IKSettings{max_iterations, position_tolerance, rotation_tolerance, damping, max_step};
          },
          "max_iterations"_a, "position_tolerance"_a, "rotation_tolerance"_a, "damping"_a, "max_step"_a)
      .def_ro("max_iterations", &IKSettings::max_iterations)
      .def_ro("position_tolerance", &IKSettings::position_tolerance, "m")
      .def_ro("rotation_tolerance", &IKSettings::rotation_tolerance, "rad")
      .def_ro("damping", &IKSettings::damping, "lambda^2 (m^2)")
      .def_ro("max_step", &IKSettings::max_step, "the largest joint move per iteration (rad or m)");

  nb::class_<IKOutcome>(m, "IKOutcome", "One IK solve's outcome.")
      .def_ro("success", &IKOutcome::success, "within both tolerances")
      .def_ro("iterations", &IKOutcome::iterations)
      .def_ro("position_error", &IKOutcome::position_error, "m")
      .def_ro("rotation_error", &IKOutcome::rotation_error, "rad");
  nb::class_<IKPathOutcome>(m, "IKPathOutcome", "A path's IK outcome: the first failed waypoint (-1: none).")
      .def_ro("failed", &IKPathOutcome::failed)
      .def_ro("position_error", &IKPathOutcome::position_error, "m, at the failed waypoint")
      .def_ro("rotation_error", &IKPathOutcome::rotation_error, "rad, at the failed waypoint");

  nb::class_<Kinematics>(m, "Kinematics")
      .def(nb::init<nb::handle_t<RobotArrays>, double>(), "robot"_a, "limit_tolerance"_a,
           "The kinematics of a robot.Robot (its tree and joint limits, read in place for this object's life) with "
           "RobotModel's LIMIT_TOLERANCE.")
      .def_prop_ro("joint_count", &Kinematics::joints)
      .def("check_limits", &Kinematics::check_limits, "values"_a, "tolerance"_a,
           "(LimitStatus, index of the first bad value or -1); values (n,) are clamped onto the limits in place.")
      .def("joint_frames", &Kinematics::joint_frames, "q"_a, "World rotations (n, 3, 3) and origins (n, 3) at q.")
      .def("forward_kinematics", &Kinematics::forward_kinematics, "q"_a,
           "The end effector's world pose at q: (position (3,), unit quaternion x y z w (4,), w >= 0), new "
           "read-only arrays; None when q is not n finite values within the limits "
           "(RobotModel.check_joint_angles); TypeError when q is not a C-contiguous float64 array of n values.")
      .def("jacobian", &Kinematics::jacobian, "q"_a, "out"_a,
           "The end effector's 6 x n world-aligned Jacobian at q into out; False (out untouched) when q is not n "
           "finite values within the limits.")
      .def("condition_number", &Kinematics::condition_number, "q"_a,
           "kappa = sigma_max / sigma_min of the end effector's Jacobian at q (inf at a singularity); None when q is "
           "refused as by jacobian.")
      .def("differential_ik", &Kinematics::differential_ik, "q"_a, "twist"_a, "damping"_a, "out"_a,
           "J^T (J J^T + damping I)^-1 twist at q into out (n,); False (out untouched) when q is refused as by "
           "jacobian.")
      .def("end_effector_kinematics", &Kinematics::end_effector_kinematics, "q"_a,
           "The end effector's (rotation (3, 3), position (3,), Jacobian (6, n)) at q.")
      .def("end_effector_positions", &Kinematics::end_effector_positions, "qs"_a,
           "End-effector world positions (N, 3) of N configurations (N, n).")
      .def("frame_pose", &Kinematics::frame_pose, "rotations"_a, "origins"_a, "joint"_a, "local_rotation"_a,
           "local_position"_a, "World (rotation, position) of a frame fixed to joint (-1: the base), given frames.")
      .def(
          "point_jacobian",
          [](const Kinematics& self, const Rotations& r, const Rows<3>& o, std::int64_t joint, const Point& p) {
            return self.point_jacobian(r, o, joint, p, false);
          },
          "rotations"_a, "origins"_a, "joint"_a, "point"_a,
          "6 x n world-aligned Jacobian of the world point carried by joint, given frames.")
      .def(
          "linear_point_jacobian",
          [](const Kinematics& self, const Rotations& r, const Rows<3>& o, std::int64_t joint, const Point& p) {
            return self.point_jacobian(r, o, joint, p, true);
          },
          "rotations"_a, "origins"_a, "joint"_a, "point"_a, "The linear rows (3 x n) of point_jacobian.")
      .def("solve_ik", &Kinematics::solve_ik, "seed"_a, "position"_a, "orientation"_a, "settings"_a, "q"_a,
           "DLS IK from seed to a target pose (unit quaternion) into q (n,): the IKOutcome, or None (q untouched) "
           "when the seed is not n finite values within the limits.")
      .def("solve_ik_path", &Kinematics::solve_ik_path, "seed"_a, "positions"_a, "orientations"_a, "settings"_a,
           "(qs (count, n), IKPathOutcome): the IK of every waypoint, each seeded from the previous solution.");

  nb::class_<PreparedIK>(m, "IKSolver")
      .def(nb::init<nb::handle_t<Kinematics>, const IKSettings&>(), "kinematics"_a, "settings"_a,
           "An IK solver over a Kinematics that owns its target, seed and answer.")
      .def_prop_ro(
          "target",
          [](nb::handle_t<PreparedIK> self) { return view_of(nb::cast<PreparedIK&>(self).target_, 7, self); },
          "(7,) target position (m) then unit quaternion x y z w, a NumPy view of the object's memory")
      .def_prop_ro(
          "seed",
          [](nb::handle_t<PreparedIK> self) {
            std::vector<double>& seed = nb::cast<PreparedIK&>(self).seed();
            return view_of(seed.data(), seed.size(), self);
          },
          "(n,) the seed, a view")
      .def_prop_ro(
          "q",
          [](nb::handle_t<PreparedIK> self) {
            std::vector<double>& q = nb::cast<PreparedIK&>(self).q();
            return view_of(q.data(), q.size(), self);
          },
          "(n,) the answer, a view")
      .def_prop_ro("outcome", &PreparedIK::outcome, nb::rv_policy::copy, "the last solve's IKOutcome")
      .def_prop_ro("success", &PreparedIK::success, "the last solve's outcome.success")
      .def_prop_ro("settings", &PreparedIK::settings, nb::rv_policy::copy)
      .def("solve", &PreparedIK::solve,
           "Solve from seed for target into q (GIL released); IKInput.Valid, or what it refused (q unchanged).");
}

}  // namespace pfield::python
