// Tracking of a joint-space path by the whole-body field's dampers: the global fallback's last stage.
//
// The global search returns a polyline of joint configurations w_0 ... w_K. The arm follows it with a moving
// attractor: a target q*(t) runs along the polyline, segment by segment, with a trapezoidal speed profile that
// stops at every vertex (so q*(t) stays on the polyline, and its joint speeds and accelerations stay within 80 % of
// the limits), and it waits while the arm lags more than `lead` (rad or m, max norm) behind. Each step solves the
// whole-body field's QP with the joint-space task
//
//     minimise  1/2 |qd - qd_ref|^2 (+ the field's damping),   qd_ref = sigma' (w_{k+1} - w_k) + k_p (q* - q),
//
// each joint's correction k_p (q* - q) capped at sqrt(2 a e) (a: the acceleration the profile leaves, e = |q* - q|):
// the speed from which the joint can still stop at the target, so the pull never overshoots into a limit cycle
// under the acceleration limits. The rows are the field's own (planning/whole_body.hpp constrained_velocity:
// link-obstacle, self and joint-limit dampers, then the speed scaling and rate limit), so the tracked motion keeps
// the field's clearance guarantees even where the polyline cuts close.
//
// The same operations in the same order as the numba kernel it replaced (issue 32): the same waypoints to the
// last bit (tests/planning/test_core_rrt.py holds digests of that kernel's tracked paths); the stall rule below is
// newer and only ends a tracking earlier.
#pragma once

#include <cstddef>
#include <cstdint>

#include "planning/whole_body.hpp"
#include "robot/robot.hpp"

namespace pfield::planning {

// Share of the joint speed and acceleration limits that the moving target uses; the rest is the lag correction's.
constexpr double kProfileShare = 0.8;

struct TrackSettings {
  std::int64_t max_iterations;  // steps (the outputs hold max_iterations + 1 waypoints)
  double gain;                  // k_p (1/s) of the lag correction
  double lead;                  // (rad or m) the target waits while the arm lags more than this (max norm)
};

// The damper-constrained joint velocity closest to `reference` (n,) at q into ws.x (previous: the last velocity for
// the rate limit, or null); pose, twist, goal errors and clearances into ws.result, as the field's step writes them.
void tracking_step(const double* q, const double* previous, const double* reference, const robot::RobotView& robot,
                   const WholeBodyScene& scene, const Goal& goal, const WholeBodyParams& params,
                   WholeBodyWorkspace& ws);

// Follows waypoints (count, n; the first is q0) from q0 until the field's goal tolerances hold at the end (Reached),
// a damper could not keep a pair apart (Collision / SelfCollision: stopped before the contact), the target reached
// the last vertex but the arm did not settle within the tolerances in max_iterations / 4 further steps
// (Stagnation), for params.stagnation_steps steps neither the target moved along the path nor the arm by
// params.stagnation_progress (max norm) (Stagnation: a damper or a joint limit holds the arm still short of the
// target; an arm that detours around an obstacle to catch up keeps moving and goes on; without this rule such a
// tracking ran to the iteration limit, e.g. 10 000 steps and 0.29 s on a UR5 MotionBenchMaker problem whose
// fallback then solved it with the next search), the iteration limit, or *cancel != 0 (Cancelled, read atomically
// every step). The waypoints are plan_whole_body's (path: max_iterations + 1 rows each); `last` of the result names
// a failure's culprit.
WholeBodyPlanResult track_path(const double* q0, const double* waypoints, std::size_t count,
                               const robot::RobotView& robot, const WholeBodyScene& scene, const Goal& goal,
                               const WholeBodyParams& params, const TrackSettings& settings,
                               const std::uint8_t* cancel, const WholeBodyPath& path);

// Which of the configurations qs (count, n) have a link capsule overlapping an obstacle or another capsule (the
// scene's offsets should be zero): where the conservative capsules cannot certify the motion. Into out (count,).
void overlapping_waypoints(const double* qs, std::size_t count, const robot::RobotView& robot,
                           const WholeBodyScene& scene, bool* out);

}  // namespace pfield::planning
