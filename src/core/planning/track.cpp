// The path tracking (track.hpp), statement for statement as the numba kernel it replaced (issue 32): the same sums
// in the same order and Python's min/max tie rules, compiled without fused multiply-adds (CMakeLists.txt), so the
// same bits, except the stall rule added since, which ends a tracking held still earlier (its waypoints up to
// there are the same).
#include "planning/track.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "planning/rrt.hpp"
#include "robot/distance.hpp"
#include "robot/kinematics.hpp"

namespace pfield::planning {
namespace {

using robot::detail::py_max;
using robot::detail::py_min;

constexpr double kInf = std::numeric_limits<double>::infinity();

// The largest sigma' and sigma'' (1/s, 1/s^2) of q*(sigma) = w_k + sigma d within the profile's share of the limits.
struct SegmentRates {
  double rate;
  double acceleration;
};

SegmentRates segment_rates(const double* direction, const robot::JointLimitsView& limits, std::size_t n) {
  double rate = kInf, accel = kInf;
  for (std::size_t j = 0; j < n; ++j) {
    const double size = std::abs(direction[j]);
    if (size > 1e-12) {
      rate = py_min(rate, limits.max_velocity[j] / size);
      accel = py_min(accel, limits.max_acceleration[j] / size);
    }
  }
  return {kProfileShare * rate, kProfileShare * accel};
}

}  // namespace

void tracking_step(const double* q, const double* previous, const double* reference, const robot::RobotView& robot,
                   const WholeBodyScene& scene, const Goal& goal, const WholeBodyParams& params,
                   WholeBodyWorkspace& ws) {
  robot::joint_transforms(robot.kinematics, q, ws.frames);
  task(robot, goal, params, ws);  // the pose, Jacobian and goal errors; its normal equations are replaced below
  const std::size_t n = ws.joint_count;
  double* h = ws.h.data();
  for (std::size_t i = 0; i < n; ++i) {
    std::fill(h + i * n, h + (i + 1) * n, 0.0);
    h[i * n + i] = 1.0 + params.damping;
    ws.rhs[i] = reference[i];
  }
  constrained_velocity(q, previous, robot, scene, params, ws, 0.0);
}

WholeBodyPlanResult track_path(const double* q0, const double* waypoints, std::size_t count,
                               const robot::RobotView& robot, const WholeBodyScene& scene, const Goal& goal,
                               const WholeBodyParams& params, const TrackSettings& settings,
                               const std::uint8_t* cancel, const WholeBodyPath& path) {
  const std::size_t n = robot.kinematics.joint_count;
  const robot::JointLimitsView& limits = robot.limits;
  WholeBodyWorkspace ws(robot, scene);
  const StepResult& out = ws.result;
  const std::int64_t total = settings.max_iterations + 1;
  std::vector<double> q(q0, q0 + n), previous(n, 0.0);
  std::vector<double> target(waypoints, waypoints + n), direction(n, 0.0), reference(n, 0.0);
  const double dt = params.dt;
  const auto vertex = [&](std::int64_t k) { return waypoints + k * static_cast<std::int64_t>(n); };
  std::int64_t segment = 0;
  double sigma = 1.0, rate = 0.0;  // sigma = 1: start the first segment at the first step
  double top = 0.0, accel = 0.0;
  const std::int64_t settle_limit = std::max<std::int64_t>(settings.max_iterations / 4, 1);
  std::int64_t settled_for = 0;
  // the stall rule: for the field's stagnation window, the target has not moved along the path and the arm has not
  // moved by the field's stagnation progress (max norm) either
  const auto stall_window = std::max<std::int64_t>(static_cast<std::int64_t>(params.stagnation_steps), 1);
  std::int64_t progress_at = 0;
  std::vector<double> anchor(q0, q0 + n);
  WholeBodyPlanResult result;
  result.count = total;
  const std::int64_t last = static_cast<std::int64_t>(count) - 1;
  for (std::int64_t k = 0; k < total; ++k) {
    if (sigma >= 1.0 && segment < last) {
      ++segment;
      for (std::size_t j = 0; j < n; ++j) direction[j] = vertex(segment)[j] - vertex(segment - 1)[j];
      sigma = 0.0, rate = 0.0;
      const SegmentRates rates = segment_rates(direction.data(), limits, n);
      top = rates.rate, accel = rates.acceleration;
      if (!std::isfinite(top)) sigma = 1.0, top = 0.0, accel = 0.0;  // a repeated vertex (and inf * 0 would be NaN)
    }
    double lag = 0.0;
    for (std::size_t j = 0; j < n; ++j) lag = py_max(lag, std::abs(target[j] - q[j]));
    bool advanced = false;  // the target moved along the path this step
    if (sigma < 1.0 && lag <= settings.lead) {
      rate = py_min(py_min(rate + accel * dt, top), std::sqrt(2.0 * accel * (1.0 - sigma)));
      const double before = sigma;
      sigma = py_min(sigma + rate * dt, 1.0);
      advanced = sigma > before;
    } else {
      rate = 0.0;
    }
    for (std::size_t j = 0; j < n; ++j) {
      target[j] = segment > 0 ? vertex(segment - 1)[j] + sigma * direction[j] : vertex(0)[j];
      // the lag correction k_p e, no faster than the joint can brake to rest within |e| at the acceleration the
      // profile leaves: a stronger pull overshoots into a limit cycle
      const double error = target[j] - q[j];
      const double braking = 2.0 * (1.0 - kProfileShare) * limits.max_acceleration[j];
      const double pull = py_min(settings.gain * std::abs(error), std::sqrt(braking * std::abs(error)));
      reference[j] = rate * direction[j] + std::copysign(pull, error);
    }
    tracking_step(q.data(), k > 0 ? previous.data() : nullptr, reference.data(), robot, scene, goal, params, ws);
    const bool finished = segment == last && sigma >= 1.0;
    if (record_step(k, total, q, ws, params, finished, cancel, path, result)) break;
    double moved = 0.0;
    for (std::size_t j = 0; j < n; ++j) moved = py_max(moved, std::abs(q[j] - anchor[j]));
    if (advanced || moved >= params.stagnation_progress) {
      progress_at = k;
      std::copy(q.begin(), q.end(), anchor.begin());
    }
    if (!finished && k - progress_at >= stall_window) {  // held still by a damper or a joint limit: no use going on
      result.status = PlanStatus::Stagnation;
      result.count = k + 1;
      break;
    }
    if (finished && ++settled_for > settle_limit) {
      result.status = PlanStatus::Stagnation;
      result.count = k + 1;
      break;
    }
    advance(q, previous, ws, limits, dt);
  }
  result.last = out;
  return result;
}

void overlapping_waypoints(const double* qs, std::size_t count, const robot::RobotView& robot,
                           const WholeBodyScene& scene, bool* out) {
  const std::size_t n = robot.kinematics.joint_count;
  CapsuleWorkspace ws(robot);
  ws.use_boxes(*scene.obstacles.packed);
  for (std::size_t k = 0; k < count; ++k) out[k] = !capsules_valid(robot, scene, qs + k * n, 0.0, ws);
}

}  // namespace pfield::planning
