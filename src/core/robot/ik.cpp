// Damped least-squares IK (ik.hpp): pfield/robot/ik.py's ik_iterate statement for statement.
#include "robot/ik.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "math/dls.hpp"

namespace pfield::robot {

namespace {

// Python's min(max(v, lower), upper): v unless lower > v, then that unless upper < it (NaN stays NaN).
double clip(double v, double lower, double upper) {
  const double above = lower > v ? lower : v;
  return upper < above ? upper : above;
}

}  // namespace

IKSolver::IKSolver(const KinematicsView& kinematics, const double* lower, const double* upper,
                   const IKSettings& settings)
    : kinematics_(kinematics),
      lower_(lower),
      upper_(upper),
      settings_(settings),
      buffer_(20 * kinematics.joint_count),
      rotations_(buffer_.data()),
      origins_(rotations_ + 9 * kinematics.joint_count),
      jacobian_(origins_ + 3 * kinematics.joint_count),
      step_(jacobian_ + 6 * kinematics.joint_count),
      scratch_(step_ + kinematics.joint_count),
      frozen_(kinematics.joint_count) {}

IKSolver::Error IKSolver::error(const FramePose& pose, const IKTarget& target) {
  const math::Quat quat = math::from_matrix(pose.rotation);
  e_[0] = target.position.x - pose.position.x;
  e_[1] = target.position.y - pose.position.y;
  e_[2] = target.position.z - pose.position.z;
  const Vec3 r = math::rotation_error(quat, target.orientation);
  e_[3] = r.x, e_[4] = r.y, e_[5] = r.z;
  return {std::sqrt(e_[0] * e_[0] + e_[1] * e_[1] + e_[2] * e_[2]), std::sqrt(r.x * r.x + r.y * r.y + r.z * r.z)};
}

void IKSolver::clamp(const double* values, double* q) const {
  // ik.py's np.minimum(np.maximum(seed, lower), upper): for the values met here (no NaN) Python's tie rule too
  for (std::size_t j = 0; j < kinematics_.joint_count; ++j) q[j] = clip(values[j], lower_[j], upper_[j]);
}

IKOutcome IKSolver::iterate(double* q, const IKTarget& target) {
  const std::size_t n = kinematics_.joint_count;
  Frames frames{rotations_, origins_};
  double* const step = step_;
  std::uint8_t* const frozen = frozen_.data();
  const std::int64_t last = settings_.max_iterations;
  Error err{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
  for (std::int64_t iteration = 0; iteration <= last; ++iteration) {
    const FramePose pose = end_effector_kinematics(kinematics_, q, frames, jacobian_);
    err = error(pose, target);
    if (err.position <= settings_.position_tolerance && err.rotation <= settings_.rotation_tolerance)
      return {true, iteration, err.position, err.rotation};
    if (iteration == last) break;
    std::fill(frozen, frozen + n, std::uint8_t{0});
    for (int attempt = 0; attempt < 3; ++attempt) {  // freeze joints pushed past a limit, then recompute the step
      math::damped_least_squares(jacobian_, 6, n, frozen, settings_.damping, e_, step);
      bool changed = false;
      for (std::size_t j = 0; j < n; ++j) {
        if (frozen[j] == 0 && ((q[j] <= lower_[j] && step[j] < 0.0) || (q[j] >= upper_[j] && step[j] > 0.0))) {
          frozen[j] = 1;
          changed = true;
        }
      }
      if (!changed) break;
    }
    // np.max(np.abs(step)), as the numba kernel took it: the first NaN, else the largest
    double largest = std::abs(step[0]);
    for (std::size_t j = 1; j < n && !std::isnan(largest); ++j) {
      const double v = std::abs(step[j]);
      if (std::isnan(v) || v > largest) largest = v;
    }
    const double scale = largest <= settings_.max_step ? 1.0 : settings_.max_step / largest;
    for (std::size_t j = 0; j < n; ++j) q[j] = clip(q[j] + scale * step[j], lower_[j], upper_[j]);
  }
  return {false, last, err.position, err.rotation};
}

IKOutcome IKSolver::solve(const double* seed, const IKTarget& target, double* q) {
  clamp(seed, q);
  return iterate(q, target);
}

IKInput IKSolver::solve_checked(const double* seed, const double* target, double limit_tolerance, double* q,
                                IKOutcome& outcome) {
  if (!(std::isfinite(target[0]) && std::isfinite(target[1]) && std::isfinite(target[2])))
    return IKInput::BadPosition;
  const double norm2 = target[3] * target[3] + target[4] * target[4] + target[5] * target[5] + target[6] * target[6];
  if (!(std::abs(norm2 - 1.0) <= 2.0 * kUnitQuaternionTolerance)) return IKInput::BadOrientation;
  const std::size_t n = kinematics_.joint_count;
  std::copy(seed, seed + n, scratch_);
  if (check_limits(scratch_, lower_, upper_, n, limit_tolerance).status != LimitCheck::Status::Ok)
    return IKInput::BadSeed;
  outcome = solve(seed, {{target[0], target[1], target[2]}, {target[3], target[4], target[5], target[6]}}, q);
  return IKInput::Valid;
}

IKPathOutcome IKSolver::solve_path(const double* seed, const double* positions, const double* orientations,
                                   std::size_t count, double* qs) {
  const std::size_t n = kinematics_.joint_count;
  const double* previous = seed;
  for (std::size_t k = 0; k < count; ++k) {
    const double* p = positions + 3 * k;
    const double* o = orientations + 4 * k;
    double* q = qs + k * n;
    const IKOutcome outcome = solve(previous, {{p[0], p[1], p[2]}, {o[0], o[1], o[2], o[3]}}, q);
    if (!outcome.success) return {static_cast<std::int64_t>(k), outcome.position_error, outcome.rotation_error};
    previous = q;
  }
  return {};
}

}  // namespace pfield::robot
