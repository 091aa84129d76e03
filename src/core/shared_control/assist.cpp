// Every expression keeps the operand order of the numba kernels this replaced (issue 32), Python's min/max keep
// their tie rules (robot::detail::py_min / py_max), and this file is compiled without fused multiply-adds
// (CMakeLists.txt): the same bits. Before numba was removed, a test ran both on the same random inputs (task space
// among obstacles of every kind, whole body on the Panda with and without the field's step) and found every output
// equal bit for bit, signed zeros included.
#include "shared_control/assist.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "field/forces.hpp"
#include "geometry/sdf.hpp"
#include "math/dls.hpp"
#include "math/linalg.hpp"
#include "planning/damper_rows.hpp"
#include "robot/distance.hpp"
#include "robot/kinematics.hpp"

namespace pfield::shared_control {
namespace {

using robot::detail::clamp01;
using robot::detail::py_max;
using robot::detail::py_min;

constexpr double kInf = std::numeric_limits<double>::infinity();
// (m) a pair the field step holds at d_s by its start offset reads d_s within this
constexpr double kOffsetRounding = 1e-9;
// (6 rows) the end effector's twist
constexpr std::size_t kTwist = 6;

double damper_allowance(double distance, const AssistParams& params) {
  return field::damper_speed(distance, params.influence_distance, params.safety_distance, params.damper_gain,
                             params.max_linear_velocity, params.max_linear_acceleration);
}

// alpha by the arbitration mode from the nearest distance (found: some obstacle was) and the goal share. The task
// space takes linear_goal's goal share with or without obstacles; the whole body only with a nearest pair (without
// one, alpha stays 0): the numba kernels differed so, and so do their ports (share_without_obstacles).
double arbitrated_share(Arbitration mode, bool found, double distance, const AssistParams& params, double goal_share,
                        bool share_without_obstacles) {
  if (mode == Arbitration::SafetyOnly || (!found && !share_without_obstacles)) return 0.0;
  double alpha = found ? obstacle_share(distance, params.influence_distance, params.safety_distance) : 0.0;
  if (mode == Arbitration::LinearGoal) alpha = py_max(alpha, goal_share);
  return alpha;
}

// The point velocity J_p qd of a (3, n) point Jacobian, each sum from 0.0.
Vec3 times(const double* point_jacobian, const double* qd, std::size_t n) {
  double x = 0.0, y = 0.0, z = 0.0;
  for (std::size_t j = 0; j < n; ++j) {
    x += point_jacobian[j] * qd[j];
    y += point_jacobian[n + j] * qd[j];
    z += point_jacobian[2 * n + j] * qd[j];
  }
  return {x, y, z};
}

// The dampers of the obstacles within Q at the robot point, kept between the nearest search and limit_approach
// (the numba kernel recomputed the same signed distances in every sweep); one buffer per thread, reused.
std::vector<MovingDamper>& damper_buffer() {
  thread_local std::vector<MovingDamper> buffer;
  return buffer;
}

// The nearest link point's minimum-norm correction dqd = J_p^T n e / |J_p^T n|^2 of the approach speed's excess e
// over the damper `allowed` (point_jac its (3, n) linear Jacobian, nv its normal, o its obstacle's velocity), on qd
// in place. True when it changed qd (e > 0). The operations of the kernel before the other pairs were held, so the
// same bits wherever this alone holds them all.
bool correct_nearest(const double* point_jac, Vec3 nv, Vec3 o, double allowed, std::size_t n, double* qd) {
  const Vec3 v = times(point_jac, qd, n);
  const double excess = -(nv.x * (v.x - o.x) + nv.y * (v.y - o.y) + nv.z * (v.z - o.z)) - allowed;
  double norm2 = 0.0;
  for (std::size_t j = 0; j < n; ++j) {
    const double direction = point_jac[j] * nv.x + point_jac[n + j] * nv.y + point_jac[2 * n + j] * nv.z;
    norm2 += direction * direction;
  }
  if (!(excess > 0.0 && norm2 > 1e-12)) return false;
  for (std::size_t j = 0; j < n; ++j) {
    const double direction = point_jac[j] * nv.x + point_jac[n + j] * nv.y + point_jac[2 * n + j] * nv.z;
    qd[j] += direction * excess / norm2;
  }
  return true;
}

// The dampers of every link point within Q (assist_joints, in assist.hpp) once the nearest pair's closed form is in
// qd: its rows n^T J_p qd >= n^T v_obs - s(d) into ws; when qd holds them all within the QP's tolerance it stands,
// else qd becomes the QP's answer from the blend ws.blend. True in that case.
bool hold_every_pair(const robot::RobotView& robot, const robot::Frames& frames, const robot::WorldSegments& world,
                     const robot::PrimitivePlacement* placement, const MovingObstacles& obstacles,
                     const AssistParams& params, JointWorkspace& ws, double* qd) {
  const std::size_t n = robot.kinematics.joint_count;
  const robot::LinkModelView& links = robot.links;
  const double influence = params.influence_distance;
  ws.fit_rows(links.capsule_count * obstacles.count());
  planning::ConstraintRows rows{ws.rows.data(), ws.bounds.data(), n, 0};
  const auto culled = [](std::size_t, std::size_t, double) {};
  const auto evaluated = [&](std::size_t c, std::size_t i, const robot::LinkObstacleDistance& pair) {
    const std::int64_t joint = links.cap_joint[c];
    if (!pair.exact || !(pair.distance < influence) || joint < 0) return;  // beyond Q, or a link nothing moves
    const Vec3 nv = pair.normal, o = obstacles.velocity(i);
    const double bound = (nv.x * o.x + nv.y * o.y + nv.z * o.z) - damper_allowance(pair.distance, params);
    rows.add_point_row(robot.kinematics, frames, joint, pair.point, nv, bound, ws.point_jacobian.data());
  };
  planning::scan_link_obstacle_pairs(links, world, obstacles.set, influence, placement, culled, evaluated);
  double worst = 0.0;
  for (std::size_t k = 0; k < rows.count; ++k) {
    const double* a = rows.a + k * n;
    double slack = rows.b[k];
    for (std::size_t j = 0; j < n; ++j) slack -= a[j] * qd[j];
    worst = slack > worst ? slack : worst;
  }
  if (!(worst > planning::kDamperQpSettings.tolerance)) return false;
  std::copy(ws.blend.begin(), ws.blend.end(), qd);
  math::hildreth({ws.identity.data(), n, rows.view(), n}, qd, ws.qp, planning::kDamperQpSettings);
  return true;
}

}  // namespace

double obstacle_share(double distance, double influence, double safety) {
  return clamp01((influence - distance) / (influence - safety));
}

double servo_scale(double distance, double threshold) {
  if (distance >= threshold) return 1.0;
  if (distance <= 0.0) return 0.0;
  const double k = -std::log(0.001) / threshold;
  return std::exp(k * (distance - threshold));
}

Approach limit_approach(const MovingDamper* dampers, std::size_t count, Vec3 v) {
  bool changed = false;
  for (int sweep = 0; sweep < kApproachSweeps; ++sweep) {
    bool moved = false;
    for (std::size_t k = 0; k < count; ++k) {
      const MovingDamper& damper = dampers[k];
      const Vec3 o = damper.velocity;
      const field::Limited hit = field::project_damper({v.x - o.x, v.y - o.y, v.z - o.z}, damper.normal,
                                                       damper.allowed);
      if (hit.changed) {
        v = {hit.v.x + o.x, hit.v.y + o.y, hit.v.z + o.z};
        moved = changed = true;
      }
    }
    if (!moved) break;
  }
  return {v, changed};
}

PointAssistance assist_point(const geometry::PackedView& packed, const double* velocities, Vec3 p, const double* user,
                             const double* autonomy, const AssistParams& params, Arbitration mode, double goal_share) {
  PointAssistance out;
  std::vector<MovingDamper>& dampers = damper_buffer();
  dampers.clear();
  double best = kInf, ttc = kInf;
  std::int64_t nearest = -1;
  Vec3 best_normal;
  for (std::size_t i = 0; i < packed.obstacle_count; ++i) {
    const geometry::SignedDistance sd = geometry::obstacle_signed_distance(packed, i, p);
    const double d = sd.distance;
    const Vec3 n = sd.normal;
    if (d < best) {
      best = d;
      nearest = static_cast<std::int64_t>(i);
      best_normal = n;
    }
    // first-order time to collision: d / (relative approach speed), for the operator's command held
    const double* o = velocities + 3 * i;
    const double approach = -(n.x * (user[0] - o[0]) + n.y * (user[1] - o[1]) + n.z * (user[2] - o[2]));
    if (d <= 0.0)
      ttc = 0.0;
    else if (approach > 0.0)
      ttc = py_min(ttc, d / approach);
    // within Q (written as the numba kernel's skip of d >= Q, so a NaN distance keeps its damper as it did there)
    if (!(d >= params.influence_distance)) dampers.push_back({n, damper_allowance(d, params), {o[0], o[1], o[2]}});
  }
  const double alpha = arbitrated_share(mode, nearest >= 0, best, params, goal_share, true);
  for (std::size_t k = 0; k < kTwist; ++k) out.blended[k] = alpha * autonomy[k] + (1.0 - alpha) * user[k];
  const Approach limited = limit_approach(dampers.data(), dampers.size(), {out.blended[0], out.blended[1],
                                                                           out.blended[2]});
  out.blended[0] = limited.v.x, out.blended[1] = limited.v.y, out.blended[2] = limited.v.z;
  out.alpha = alpha;
  out.speed_scale = servo_scale(best, params.scale_threshold);
  out.nearest = nearest;
  out.distance = best;
  out.normal = best_normal;
  out.obstacle_point = nearest >= 0 ? Vec3{p.x - best * best_normal.x, p.y - best * best_normal.y,
                                           p.z - best * best_normal.z}
                                    : p;
  out.time_to_collision = ttc;
  out.limited = limited.changed;
  return out;
}

NearestLink nearest_link(const robot::LinkModelView& links, const robot::WorldSegments& world,
                         const robot::ObstacleSet& obstacles, std::int64_t hint_link, std::int64_t hint_obstacle,
                         const robot::PrimitivePlacement* placement) {
  const auto caps = static_cast<std::int64_t>(links.capsule_count);
  const auto count = static_cast<std::int64_t>(obstacles.count());
  // the hinted pair alone (when it names one), or every pair
  const bool hinted = 0 <= hint_link && hint_link < caps && 0 <= hint_obstacle && hint_obstacle < count;
  const std::int64_t first_link = hinted ? hint_link : 0, last_link = hinted ? hint_link + 1 : caps;
  const std::int64_t first_obstacle = hinted ? hint_obstacle : 0, last_obstacle = hinted ? hint_obstacle + 1 : count;
  NearestLink best;
  for (std::int64_t c = first_link; c < last_link; ++c)
    for (std::int64_t i = first_obstacle; i < last_obstacle; ++i) {
      // a pair whose bound is no better than the best so far answers that bound, not exact: it cannot be nearer
      const robot::LinkObstacleDistance pair = robot::link_obstacle_distance_below(
          links, world, obstacles, static_cast<std::size_t>(c), static_cast<std::size_t>(i), best.distance,
          best.distance, placement);
      if (pair.exact && pair.distance < best.distance) {
        best.link = c;
        best.obstacle = i;
        best.distance = pair.distance;
        best.normal = pair.normal;
        best.point = pair.point;
      }
    }
  if (best.link >= 0) {
    // the witness point on the surface: the axis point less the radius of the segment that decided
    const double radius =
        geometry::obstacle_signed_distance(*obstacles.packed, static_cast<std::size_t>(best.obstacle), best.point)
            .distance -
        best.distance;
    best.point = {best.point.x - radius * best.normal.x, best.point.y - radius * best.normal.y,
                  best.point.z - radius * best.normal.z};
  }
  return best;
}

bool below_singular_value(const double* gram, std::size_t m, double threshold) {
  double shifted[math::kMaxDlsRows * math::kMaxDlsRows];
  for (std::size_t r = 0; r < m; ++r) {
    for (std::size_t c = 0; c < m; ++c) shifted[r * m + c] = gram[r * m + c];
    shifted[r * m + r] -= threshold * threshold;
  }
  // cholesky_in_place's smallest relative pivot s_j / h_jj is <= 0 exactly when some pivot s_j is (h_jj > 0 on a
  // Gram matrix's diagonal; where h_jj <= 0 it returns 0 and s_j <= h_jj is not positive either)
  return !(math::cholesky_in_place(shifted, m, m) > 0.0);
}

JointWorkspace::JointWorkspace(const robot::RobotView& robot, std::size_t obstacle_count)
    : rotations(9 * robot.kinematics.joint_count),
      origins(3 * robot.kinematics.joint_count),
      jacobian(kTwist * robot.kinematics.joint_count),
      point_jacobian(3 * robot.kinematics.joint_count),
      segment_ends(6 * (robot.links.capsule_count + robot.links.primitive_count)),
      placed(robot.links.capsule_count),
      qd_user(robot.kinematics.joint_count),
      blend(robot.kinematics.joint_count),
      identity(robot.kinematics.joint_count * robot.kinematics.joint_count, 0.0),
      rows(robot.links.capsule_count * obstacle_count * robot.kinematics.joint_count),
      bounds(robot.links.capsule_count * obstacle_count),
      qp(robot.links.capsule_count * obstacle_count, robot.kinematics.joint_count) {
  const std::size_t n = robot.kinematics.joint_count;
  const std::size_t caps = robot.links.capsule_count, prims = robot.links.primitive_count;
  for (std::size_t j = 0; j < n; ++j) identity[j * n + j] = 1.0;
  frames = {rotations.data(), origins.data()};
  double* ends = segment_ends.data();
  world = {ends, ends + 3 * caps, ends + 6 * caps, ends + 6 * caps + 3 * prims};
}

void JointWorkspace::fit_rows(std::size_t count) {
  if (count <= bounds.size()) return;
  const std::size_t n = blend.size();
  rows.resize(count * n);
  bounds.resize(count);
  qp = math::QpWorkspace(count, n);
}

JointAssistance assist_joints(const double* q, const robot::RobotView& robot, const MovingObstacles& obstacles,
                              const AssistParams& params, const JointAssistParams& joint_params, Arbitration mode,
                              double goal_share, const double* qd_auto, const OperatorCommand& user,
                              std::int64_t hint_link, std::int64_t hint_obstacle, JointWorkspace& ws,
                              const JointState* state, double* qd) {
  const robot::KinematicsView& kinematics = robot.kinematics;
  const std::size_t n = kinematics.joint_count;
  JointAssistance out;
  const robot::Frames* frames = &ws.frames;
  const double* jac = ws.jacobian.data();
  const robot::WorldSegments* world = &ws.world;
  // a link's primitives are placed by the first pair that reaches its fine level (the step's rule)
  const robot::PrimitivePlacement own{&robot.links, &ws.frames, &ws.world, ws.placed.data()};
  const robot::PrimitivePlacement* placement = &own;
  if (state == nullptr) {
    robot::end_effector_kinematics(kinematics, q, ws.frames, ws.jacobian.data());
    robot::capsule_segments(robot.links, ws.frames, ws.world);
    own.reset();
  } else {
    frames = state->frames;
    jac = state->jacobian;
    world = state->world;
    placement = state->placement;
  }
  // qd_user = J^T (J J^T + lambda^2 I)^-1 u_user, or the operator's joint velocities; the undamped J J^T's
  // singularity test either way (it describes the arm at q)
  double gram[kTwist * kTwist];
  math::dls_gram(jac, kTwist, n, nullptr, gram);
  out.singular = below_singular_value(gram, kTwist, joint_params.singularity_threshold);
  if (user.joints != nullptr)
    std::copy(user.joints, user.joints + n, ws.qd_user.begin());
  else
    math::dls_from_gram(jac, kTwist, n, nullptr, gram, joint_params.damping * joint_params.damping, user.twist,
                        ws.qd_user.data(), math::DlsSum::FromZero);
  const double* qd_user = ws.qd_user.data();
  const robot::JointLimitsView& limits = robot.limits;
  for (std::size_t j = 0; j < n; ++j)
    if (q[j] - limits.lower[j] < joint_params.joint_limit_margin ||
        limits.upper[j] - q[j] < joint_params.joint_limit_margin)
      out.at_limit = true;
  const NearestLink nearest = nearest_link(robot.links, *world, obstacles.set, hint_link, hint_obstacle, placement);
  const double alpha = arbitrated_share(mode, nearest.link >= 0, nearest.distance, params, goal_share, false);
  for (std::size_t j = 0; j < n; ++j) qd[j] = alpha * qd_auto[j] + (1.0 - alpha) * qd_user[j];
  if (nearest.link >= 0) {
    const double clearance = nearest.distance;
    const Vec3 nv = nearest.normal;
    double* point_jac = ws.point_jacobian.data();
    robot::linear_point_jacobian(kinematics, *frames,
                                 robot.links.cap_joint[static_cast<std::size_t>(nearest.link)], nearest.point,
                                 point_jac);
    const Vec3 o = obstacles.velocity(static_cast<std::size_t>(nearest.obstacle));
    const Vec3 u = times(point_jac, qd_user, n);
    const double approach_user = -(nv.x * (u.x - o.x) + nv.y * (u.y - o.y) + nv.z * (u.z - o.z));
    if (clearance <= 0.0)
      out.time_to_collision = 0.0;
    else if (approach_user > 0.0)
      out.time_to_collision = clearance / approach_user;
    if (clearance < params.influence_distance) {
      // the nearest pair in closed form, then every pair within Q (assist.hpp)
      std::copy(qd, qd + n, ws.blend.begin());
      out.limited = correct_nearest(point_jac, nv, o, damper_allowance(clearance, params), n, qd);
      if (hold_every_pair(robot, *frames, *world, placement, obstacles, params, ws, qd)) out.limited = true;
    }
    out.obstacle_point = {nearest.point.x - clearance * nv.x, nearest.point.y - clearance * nv.y,
                          nearest.point.z - clearance * nv.z};
  } else {
    out.obstacle_point = nearest.point;
  }
  for (std::size_t k = 0; k < kTwist; ++k) {
    double total = 0.0;
    for (std::size_t j = 0; j < n; ++j) total += jac[k * n + j] * qd[j];
    out.blended[k] = total;
  }
  out.alpha = alpha;
  out.speed_scale = servo_scale(nearest.distance, params.scale_threshold);
  out.nearest = nearest;
  return out;
}

WholeBodyAssistance::WholeBodyAssistance(const robot::RobotView& robot, const MovingObstacles& obstacles,
                                         const AssistParams& params, const JointAssistParams& joint_params)
    : robot_(robot),
      obstacles_(obstacles),
      params_(params),
      joint_params_(joint_params),
      ws_(robot, obstacles.count()),
      zeros_(robot.kinematics.joint_count, 0.0),
      clamped_(robot.kinematics.joint_count),
      obstacle_offsets_(robot.links.capsule_count * obstacles.count(), 0.0),
      self_offsets_(robot.links.pair_count, 0.0),
      scene_{obstacles.set, obstacle_offsets_.data(), self_offsets_.data()} {}

WholeBodyAssistance::WholeBodyAssistance(const robot::RobotView& robot, const MovingObstacles& obstacles,
                                         const AssistParams& params, const JointAssistParams& joint_params,
                                         const planning::Goal& goal, const planning::WholeBodyParams& step_params)
    : WholeBodyAssistance(robot, obstacles, params, joint_params) {
  stepper_ = std::make_unique<planning::WholeBodyStepper>(robot_, scene_, goal, step_params);
}

JointAssistance WholeBodyAssistance::assist(const double* q, const OperatorCommand& user, Arbitration mode,
                                            double goal_share, double* qd) {
  return assist_joints(q, robot_, obstacles_, params_, joint_params_, mode, goal_share, zeros_.data(), user, -1, -1,
                       ws_, nullptr, qd);
}

bool WholeBodyAssistance::step(const double* q, std::size_t q_size, const double* previous,
                               std::size_t previous_size, double dt, double limit_tolerance,
                               const OperatorCommand& user, Arbitration mode, JointAssistance& out, double* qd) {
  if (!stepper_ || !stepper_->step(q, q_size, previous, previous_size, dt, limit_tolerance)) return false;
  const std::size_t n = joint_count();
  const robot::JointLimitsView& limits = robot_.limits;
  for (std::size_t j = 0; j < n; ++j) clamped_[j] = py_min(py_max(q[j], limits.lower[j]), limits.upper[j]);
  const planning::StepResult& row = stepper_->result();
  const double distance = row.position_error;
  const bool at_goal =
      distance <= joint_params_.goal_tolerance && row.rotation_error <= joint_params_.rotation_tolerance;
  const double* t = row.twist;
  const double linear = std::sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
  const double angular = std::sqrt(t[3] * t[3] + t[4] * t[4] + t[5] * t[5]);
  const bool stalled = !at_goal && linear < joint_params_.stall_speed && angular < joint_params_.stall_speed;
  const double goal_share = clamp01(1.0 - distance / joint_params_.goal_radius);
  // The step evaluated every link-obstacle pair exactly below the influence distance Q (its dampers' cutoff), the
  // others only by bounds >= Q; so a nearest pair it reports in (d_s, Q) is the closest of all. (At or below d_s the
  // step's start offsets hold pairs at d_s, up to rounding: then the whole search decides.)
  const double nearest = row.nearest_distance;
  const bool known = params_.safety_distance + kOffsetRounding < nearest && nearest < params_.influence_distance;
  const auto hint_link = known ? static_cast<std::int64_t>(row.nearest_capsule) : -1;
  const auto hint_obstacle = known ? static_cast<std::int64_t>(row.nearest_obstacle) : -1;
  // continue from the step's joint frames, Jacobian and world segments (the same link model and obstacles)
  const planning::WholeBodyWorkspace& step_ws = stepper_->workspace();
  const robot::PrimitivePlacement placement = stepper_->placement();
  const JointState state{&step_ws.frames, step_ws.jacobian.data(), &step_ws.world, &placement};
  const double* qd_auto = stepper_->joint_velocities();
  out = assist_joints(clamped_.data(), robot_, obstacles_, params_, joint_params_, mode, goal_share, qd_auto, user,
                      hint_link, hint_obstacle, ws_, &state, qd);
  out.at_goal = at_goal;
  out.stalled = stalled;
  std::copy(t, t + kTwist, out.autonomy);
  return true;
}

}  // namespace pfield::shared_control
