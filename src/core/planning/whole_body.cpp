// The whole-body step, loop and stepper (whole_body.hpp), statement for statement as the numba kernels they
// replaced (issue 32: the step, the plan loop and the flat stepper): the same sums in the same order and Python's
// min/max tie rules, compiled without fused multiply-adds (CMakeLists.txt), so the same bits.
#include "planning/whole_body.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "field/forces.hpp"
#include "math/linalg.hpp"
#include "planning/damper_rows.hpp"
#include "robot/distance.hpp"
#include "robot/kinematics.hpp"

namespace pfield::planning {

robot::PrimitivePlacement primitive_placement(const robot::LinkModelView& links, WholeBodyWorkspace& ws) {
  return {&links, &ws.frames, &ws.world, ws.placed.data()};
}

namespace {

using field::stepped_damper_speed;
using math::Quat;
using math::Vec3;
using robot::detail::py_max;
using robot::detail::py_min;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr std::size_t kTaskRows = 6;  // the end-effector twist: linear, then angular

// Damper rows and null-space repulsion (ws.free) of every link-obstacle pair within Q: one row per pair, at the
// closest point of the link's deciding segment (scan_link_obstacle_pairs with cutoff Q, planning/damper_rows.hpp).
// A pair's distance less its start offset, or with `hold` max(d, d_s). The clearance takes every pair's value (a
// lower bound beyond Q), the nearest pair every pair that passed the cheap bound.
void obstacle_rows(const robot::RobotView& robot, const WholeBodyScene& scene, const WholeBodyParams& p,
                   WholeBodyWorkspace& ws, ConstraintRows& rows, bool hold) {
  const robot::LinkModelView& links = robot.links;
  const robot::ObstacleSet& obstacles = scene.obstacles;
  const std::size_t count = obstacles.count(), n = ws.joint_count;
  const double influence = p.influence_distance, dt = p.dt, safety = p.safety_distance;
  const double speed = p.damper_gain * p.max_linear_velocity, null_scale = p.null_space_gain * p.max_linear_velocity;
  double clearance = kInf, worst = kInf;
  std::int64_t culprit_c = -1, culprit_o = -1;
  const auto culled = [&](std::size_t, std::size_t, double lower) { clearance = py_min(clearance, lower); };
  const auto evaluated = [&](std::size_t c, std::size_t i, const robot::LinkObstacleDistance& pair) {
    double d = pair.distance;
    clearance = py_min(clearance, d);
    d = hold ? py_max(d, safety) : d - scene.obstacle_offsets[c * count + i];
    if (d < worst) {
      worst = d;
      culprit_c = static_cast<std::int64_t>(c);
      culprit_o = static_cast<std::int64_t>(i);
    }
    const std::int64_t joint = links.cap_joint[c];
    if (!pair.exact || d >= influence || joint < 0) return;  // not exact: a lower bound, at least Q
    const double bound = -stepped_damper_speed(d, influence, safety, speed, dt);
    const double* row =
        rows.add_point_row(robot.kinematics, ws.frames, joint, pair.point, pair.normal, bound, ws.jlin.data());
    const double push =
        null_scale * field::khatib_magnitude(d, p.repulsive_gain, influence, p.max_repulsive_force) /
        p.max_repulsive_force;
    for (std::size_t j = 0; j < n; ++j) ws.free[j] += push * row[j];
  };
  const robot::PrimitivePlacement placement = primitive_placement(links, ws);
  scan_link_obstacle_pairs(links, ws.world, obstacles, influence, &placement, culled, evaluated);
  ws.result.clearance = clearance;
  ws.result.nearest_capsule = static_cast<double>(culprit_c);
  ws.result.nearest_obstacle = static_cast<double>(culprit_o);
  ws.result.nearest_distance = worst;
}

// Damper rows of the self pairs within Q, on the covering capsules (on the fitted primitives with
// scene.fitted_self): n^T (J_1(p1) - J_2(p2)) qd >= -s with n from the second link's closest point to the first's.
// Offsets and hold as obstacle_rows.
void self_rows(const robot::RobotView& robot, const WholeBodyScene& scene, const WholeBodyParams& p,
               WholeBodyWorkspace& ws, ConstraintRows& rows, bool hold) {
  const robot::LinkModelView& links = robot.links;
  const std::size_t n = ws.joint_count;
  const double influence = p.influence_distance, dt = p.dt, safety = p.safety_distance;
  const double speed = p.damper_gain * p.max_linear_velocity;
  double clearance = kInf;
  std::int64_t nearest = -1;
  double* jlin2 = ws.jlin2.data();
  // the fitted level needs the primitives of the links in pairs whose bounding capsules come within the influence
  // distance: placed by the pair that first needs them, unless a link-obstacle pair of this step placed them
  const robot::PrimitivePlacement placement = primitive_placement(links, ws);
  const double* radii = scene.fitted_self ? links.cap_r : links.self_r;  // the capsules the pairs are measured on
  for (std::size_t k = 0; k < links.pair_count; ++k) {
    const auto c1 = static_cast<std::size_t>(links.self_pairs[2 * k]);
    const auto c2 = static_cast<std::size_t>(links.self_pairs[2 * k + 1]);
    // the capsules' bounding spheres first: a pair they keep at least the influence distance and the nearest pair's
    // distance away gives no row and is not the nearest (its d is at least that bound), so it is not measured
    const double gap = robot::sphere_gap(ws.middles[c1], radii[c1], ws.middles[c2], radii[c2]) - robot::kSphereSlack;
    const double lower = hold ? py_max(gap, safety) : gap - scene.self_offsets[k];
    if (lower >= influence && lower >= clearance) continue;
    // below the influence distance exactly; a farther pair (d >= its distance) gives no row either way
    const robot::LinkPairDistance pair = scene.fitted_self
                                             ? robot::fitted_pair_distance_below(links, ws.world, c1, c2, influence,
                                                                                 &placement)
                                             : robot::link_pair_distance(links, ws.world, c1, c2);
    const double d = hold ? py_max(pair.distance, safety) : pair.distance - scene.self_offsets[k];
    if (d < clearance) {
      clearance = d;
      nearest = static_cast<std::int64_t>(k);
    }
    if (d >= influence) continue;
    const Vec3& p1 = pair.first;
    const Vec3& p2 = pair.second;
    const double dx = p1.x - p2.x, dy = p1.y - p2.y, dz = p1.z - p2.z;
    const double dist = std::sqrt(dx * dx + dy * dy + dz * dz);
    if (dist < 1e-12) continue;
    const Vec3 normal{dx / dist, dy / dist, dz / dist};
    const double bound = -stepped_damper_speed(d, influence, safety, speed, dt);
    double* row = rows.add_point_row(robot.kinematics, ws.frames, links.cap_joint[c1], p1, normal, bound,
                                     ws.jlin.data());
    robot::linear_point_jacobian(robot.kinematics, ws.frames, links.cap_joint[c2], p2, jlin2);
    for (std::size_t j = 0; j < n; ++j)
      row[j] -= normal.x * jlin2[j] + normal.y * jlin2[n + j] + normal.z * jlin2[2 * n + j];
  }
  ws.result.self_clearance = clearance;
  ws.result.nearest_self_pair = static_cast<double>(nearest);
}

// Damper rows +-qd_j >= -s_j(gap) of the joints within joint_influence of a finite limit (lower, then upper).
void joint_limit_rows(const double* q, const robot::RobotView& robot, const WholeBodyParams& p, ConstraintRows& rows) {
  const std::size_t n = rows.n;
  const robot::JointLimitsView& limits = robot.limits;
  for (std::size_t j = 0; j < n; ++j) {
    for (const double side : {1.0, -1.0}) {
      const double limit = side > 0.0 ? limits.lower[j] : limits.upper[j];
      if (!std::isfinite(limit)) continue;
      const double gap = side * (q[j] - limit);
      if (gap >= p.joint_influence) continue;
      double* row =
          rows.add(-stepped_damper_speed(gap, p.joint_influence, p.joint_safety, limits.max_velocity[j], p.dt));
      std::fill(row, row + n, 0.0);
      row[j] = side;
    }
  }
}

// Uniform scaling of ws.x into the velocity limits, then the rate limit |qd_j - previous_j| <= a_j dt unless it
// makes a damper row fail that the unlimited qd kept (previous null: no rate limit).
void limit_speed(const double* previous, const robot::RobotView& robot, const WholeBodyParams& p,
                 WholeBodyWorkspace& ws, const ConstraintRows& rows) {
  const std::size_t n = ws.joint_count;
  const robot::JointLimitsView& limits = robot.limits;
  double* x = ws.x.data();
  double scale = 1.0;
  for (std::size_t j = 0; j < n; ++j)
    if (std::abs(x[j]) * scale > limits.max_velocity[j]) scale = limits.max_velocity[j] / std::abs(x[j]);
  for (std::size_t j = 0; j < n; ++j) x[j] *= scale;
  if (previous == nullptr) return;
  double* limited = ws.limited.data();
  for (std::size_t j = 0; j < n; ++j) {
    const double step = limits.max_acceleration[j] * p.dt;
    limited[j] = py_min(py_max(x[j], previous[j] - step), previous[j] + step);
  }
  for (std::size_t k = 0; k < rows.count; ++k) {
    const double* a = rows.a + k * n;
    double with_limit = 0.0, without = 0.0;
    for (std::size_t j = 0; j < n; ++j) {
      with_limit += a[j] * limited[j];
      without += a[j] * x[j];
    }
    if (with_limit < rows.b[k] - 1e-9 && with_limit < without) return;
  }
  std::copy(limited, limited + n, x);
}

}  // namespace

WholeBodyWorkspace::WholeBodyWorkspace(std::size_t joints, std::size_t capsules, std::size_t obstacle_count,
                                       std::size_t pairs, std::size_t primitives)
    : joint_count(joints),
      max_rows(capsules * obstacle_count + pairs + 2 * joints),
      rotations(9 * joints),
      origins(3 * joints),
      jacobian(kTaskRows * joints),
      jlin(3 * joints),
      jlin2(3 * joints),
      rows(max_rows * joints),
      bounds(max_rows),
      h(joints * joints),
      rhs(joints),
      x(joints),
      free(joints),
      limited(joints),
      segment_ends(6 * (capsules + primitives)),
      placed(capsules),
      middles(capsules),
      qp(max_rows, joints),
      frames{rotations.data(), origins.data()},
      world{segment_ends.data(), segment_ends.data() + 3 * capsules, segment_ends.data() + 6 * capsules,
            segment_ends.data() + 6 * capsules + 3 * primitives} {}

WholeBodyWorkspace::WholeBodyWorkspace(const robot::RobotView& robot, const WholeBodyScene& scene)
    : WholeBodyWorkspace(robot.kinematics.joint_count, robot.links.capsule_count, scene.obstacles.count(),
                         robot.links.pair_count, robot.links.primitive_count) {}

void task(const robot::RobotView& robot, const Goal& goal, const WholeBodyParams& params, WholeBodyWorkspace& ws) {
  const robot::KinematicsView& kinematics = robot.kinematics;
  const std::size_t n = ws.joint_count;
  const robot::FramePose pose = robot::end_effector_pose(kinematics, ws.frames);
  double* jac = ws.jacobian.data();
  robot::point_jacobian(kinematics, ws.frames, kinematics.ee_joint, pose.position, jac);
  const Quat quat = math::from_matrix(pose.rotation);
  const double ex = goal.position.x - pose.position.x, ey = goal.position.y - pose.position.y,
               ez = goal.position.z - pose.position.z;
  const Vec3 force = field::attraction({ex, ey, ez}, params.attractive_gain, params.attractive_threshold);
  const Vec3 v = field::soft_saturate(force, params.max_linear_velocity);
  const Vec3 r = math::rotation_error(quat, goal.orientation);
  const double k = params.rotational_attractive_gain;
  const Vec3 w = field::soft_saturate({k * r.x, k * r.y, k * r.z}, params.max_angular_velocity);
  const double twist[kTaskRows] = {v.x, v.y, v.z, w.x, w.y, w.z};
  const double rw = params.rotation_weight;
  const double weights[kTaskRows] = {1.0, 1.0, 1.0, rw, rw, rw};
  // normal equations of the weighted least squares: H = J^T W J + lambda^2 I, rhs = J^T W xd
  double* h = ws.h.data();
  for (std::size_t i = 0; i < n; ++i) {
    double s = 0.0;
    for (std::size_t row = 0; row < kTaskRows; ++row) s += jac[row * n + i] * weights[row] * twist[row];
    ws.rhs[i] = s;
    for (std::size_t j = 0; j <= i; ++j) {
      s = 0.0;
      for (std::size_t row = 0; row < kTaskRows; ++row) s += jac[row * n + i] * weights[row] * jac[row * n + j];
      h[i * n + j] = s;
      h[j * n + i] = s;
    }
    h[i * n + i] += params.damping;
  }
  StepResult& out = ws.result;
  out.position[0] = pose.position.x, out.position[1] = pose.position.y, out.position[2] = pose.position.z;
  out.orientation[0] = quat.x, out.orientation[1] = quat.y, out.orientation[2] = quat.z, out.orientation[3] = quat.w;
  out.position_error = std::sqrt(ex * ex + ey * ey + ez * ez);
  out.rotation_error = std::sqrt(r.x * r.x + r.y * r.y + r.z * r.z);
}

void step_segments(const robot::RobotView& robot, WholeBodyWorkspace& ws) {
  robot::capsule_segments(robot.links, ws.frames, ws.world);
  robot::axis_middles(robot.links, ws.world, ws.middles.data());
  primitive_placement(robot.links, ws).reset();  // a link's primitives are placed by the first pair that needs them
}

std::size_t velocity_from_segments(const double* q, const double* previous, const robot::RobotView& robot,
                                   const WholeBodyScene& scene, const WholeBodyParams& params, WholeBodyWorkspace& ws,
                                   double free_weight, bool hold, const Goal* posture) {
  const std::size_t n = ws.joint_count;
  std::fill(ws.free.begin(), ws.free.end(), 0.0);
  ConstraintRows rows{ws.rows.data(), ws.bounds.data(), n, 0};
  obstacle_rows(robot, scene, params, ws, rows, hold);
  self_rows(robot, scene, params, ws, rows, hold);
  joint_limit_rows(q, robot, params, rows);
  // the joint goal's pull, uncapped (the speed limit scales the whole step; capping it at half or a quarter of each
  // joint's velocity limit took the Panda's bookshelf_small p95 from 95 to 133 and 136 ms)
  if (posture != nullptr && posture->joints != nullptr)
    for (std::size_t j = 0; j < n; ++j) ws.free[j] += posture->joint_gain * (posture->joints[j] - q[j]);
  for (std::size_t j = 0; j < n; ++j) ws.rhs[j] += free_weight * ws.free[j];
  math::solve_qp(ws.h.data(), n, ws.rhs.data(), rows.view(), n, ws.x.data(), ws.qp, kDamperQpSettings);
  limit_speed(previous, robot, params, ws, rows);
  const double* jac = ws.jacobian.data();
  for (std::size_t r = 0; r < kTaskRows; ++r) {
    double s = 0.0;
    for (std::size_t j = 0; j < n; ++j) s += jac[r * n + j] * ws.x[j];
    ws.result.twist[r] = s;
  }
  return rows.count;
}

std::size_t constrained_velocity(const double* q, const double* previous, const robot::RobotView& robot,
                                 const WholeBodyScene& scene, const WholeBodyParams& params, WholeBodyWorkspace& ws,
                                 double free_weight, const Goal* posture) {
  step_segments(robot, ws);
  return velocity_from_segments(q, previous, robot, scene, params, ws, free_weight, false, posture);
}

std::size_t joint_velocity_step(const double* q, const double* previous, const robot::RobotView& robot,
                                const WholeBodyScene& scene, const Goal& goal, const WholeBodyParams& params,
                                WholeBodyWorkspace& ws) {
  robot::joint_transforms(robot.kinematics, q, ws.frames);
  task(robot, goal, params, ws);
  return constrained_velocity(q, previous, robot, scene, params, ws, params.damping, &goal);
}

std::size_t autonomy_step(const double* q, const double* previous, const robot::RobotView& robot,
                          const WholeBodyScene& scene, const Goal& goal, const WholeBodyParams& params,
                          WholeBodyWorkspace& ws) {
  robot::joint_transforms(robot.kinematics, q, ws.frames);
  step_segments(robot, ws);
  task(robot, goal, params, ws);
  return velocity_from_segments(q, previous, robot, scene, params, ws, params.damping, true);
}

bool record_step(std::int64_t k, std::int64_t total, const std::vector<double>& q, const WholeBodyWorkspace& ws,
                 const WholeBodyParams& params, bool may_reach, const std::uint8_t* cancel, const WholeBodyPath& path,
                 WholeBodyPlanResult& result) {
  const std::size_t n = ws.joint_count;
  const StepResult& out = ws.result;
  // the plan ends at waypoint `last` with a zero velocity and twist there
  const auto end_at = [&](PlanStatus status, std::int64_t last) {
    result.status = status;
    result.count = last + 1;
    std::fill(path.velocities + last * n, path.velocities + (last + 1) * n, 0.0);
    std::fill(path.twists + kTaskRows * last, path.twists + kTaskRows * (last + 1), 0.0);
    return true;
  };
  std::copy(q.begin(), q.end(), path.joints + k * n);
  std::copy(out.position, out.position + 3, path.positions + 3 * k);
  std::copy(out.orientation, out.orientation + 4, path.orientations + 4 * k);
  path.clearances[k] = out.clearance;
  // the last step brought capsules into contact (an infeasible squeeze): stop before it
  if (out.nearest_distance < 0.0 || out.self_clearance < 0.0)
    return end_at(out.nearest_distance < 0.0 ? PlanStatus::Collision : PlanStatus::SelfCollision,
                  std::max<std::int64_t>(k, 1) - 1);
  if (may_reach && out.position_error <= params.goal_tolerance && out.rotation_error <= params.rotation_tolerance)
    return end_at(PlanStatus::Reached, k);
  std::copy(ws.x.begin(), ws.x.end(), path.velocities + k * n);
  std::copy(out.twist, out.twist + kTaskRows, path.twists + kTaskRows * k);
  if (k == total - 1) return true;  // the iteration limit: result's status and count as they start
  if (__atomic_load_n(cancel, __ATOMIC_RELAXED) != 0) {
    result.status = PlanStatus::Cancelled;
    result.count = k + 1;
    return true;
  }
  return false;
}

void advance(std::vector<double>& q, std::vector<double>& previous, const WholeBodyWorkspace& ws,
             const robot::JointLimitsView& limits, double dt) {
  for (std::size_t j = 0; j < ws.joint_count; ++j) {
    q[j] = py_min(py_max(q[j] + ws.x[j] * dt, limits.lower[j]), limits.upper[j]);
    previous[j] = ws.x[j];
  }
}

WholeBodyPlanResult plan_whole_body(const double* q0, const robot::RobotView& robot, const WholeBodyScene& scene,
                                    const Goal& goal, const WholeBodyParams& params, std::int64_t max_iterations,
                                    const std::uint8_t* cancel, const WholeBodyPath& path) {
  const std::size_t n = robot.kinematics.joint_count;
  WholeBodyWorkspace ws(robot, scene);
  std::vector<double> q(q0, q0 + n), previous(n, 0.0);
  const std::int64_t total = max_iterations + 1;
  const auto window = static_cast<std::int64_t>(params.stagnation_steps);
  const double dt = params.dt;
  const StepResult& out = ws.result;
  Progress progress{kInf, kInf, kInf, kInf};
  WholeBodyPlanResult result;
  result.count = total;
  for (std::int64_t k = 0; k < total; ++k) {
    // the rate limit from the previous step's velocity (zero at the start), as the numba loop had it (dt > 0 here)
    joint_velocity_step(q.data(), dt > 0.0 ? previous.data() : nullptr, robot, scene, goal, params, ws);
    if (record_step(k, total, q, ws, params, true, cancel, path, result)) break;
    if (progress.stuck(k, window, params.stagnation_progress, out.position_error, out.rotation_error)) {
      result.status = PlanStatus::Stagnation;
      result.count = k + 1;
      break;
    }
    advance(q, previous, ws, robot.limits, dt);
  }
  result.last = out;
  return result;
}

WholeBodyStepper::WholeBodyStepper(const robot::RobotView& robot, const WholeBodyScene& scene, const Goal& goal,
                                   const WholeBodyParams& params)
    : robot_(robot),
      scene_(scene),
      goal_(goal),
      params_(params),
      ws_(robot, scene),
      q_(robot.kinematics.joint_count),
      previous_(robot.kinematics.joint_count) {}

bool WholeBodyStepper::step(const double* q, std::size_t q_size, const double* previous, std::size_t previous_size,
                            double dt, double limit_tolerance) {
  const std::size_t n = ws_.joint_count;
  if (!(std::isfinite(dt) && dt >= 0.0) || q_size != n) return false;
  std::copy(q, q + n, q_.begin());
  const robot::JointLimitsView& limits = robot_.limits;
  if (robot::check_limits(q_.data(), limits.lower, limits.upper, n, limit_tolerance).status !=
      robot::LimitCheck::Status::Ok)
    return false;
  const double* prev = nullptr;
  if (previous != nullptr) {
    if (previous_size != n) return false;
    for (std::size_t j = 0; j < n; ++j)
      if (!std::isfinite(previous[j])) return false;
    // rule 3 of the output contract: a previous command beyond the velocity limits was never sent; joints without
    // a positive finite limit keep theirs
    for (std::size_t j = 0; j < n; ++j) {
      const double limit = limits.max_velocity[j], v = previous[j];
      const bool bounded = limit > 0.0 && limit < kInf;
      previous_[j] = bounded && v > limit ? limit : (bounded && v < -limit ? -limit : v);
    }
    if (dt > 0.0) prev = previous_.data();
  }
  WholeBodyParams params = params_;
  if (dt > 0.0) params.dt = dt;
  autonomy_step(q_.data(), prev, robot_, scene_, goal_, params, ws_);
  return true;
}

}  // namespace pfield::planning
