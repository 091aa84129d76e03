// The task-space planning loop: RK4 on the constrained twist over R^3 x SO(3), one call per plan.
//
// The state is the end-effector position p and unit quaternion q (world frame). The twist (v, w) of
// field::constrained_twist is a point velocity and an angular velocity in the world frame, so one step of size h
// maps (p, q) to (p + h v, exp(h w) (x) q). RK4 (Munthe-Kaas 1998 with the first-order dexp approximation, as in
// Crouch & Grossman 1993) evaluates the twist at four stage poses and applies the weighted mean; all four stages
// share the previous step's twist for the rate limit, so the mean obeys the velocity and acceleration limits too.
// The steps and their order are pfield/planning/_task_space_loop.py's: the same waypoints to the last bit.
#pragma once

#include <cstddef>
#include <cstdint>

#include "field/evaluate.hpp"
#include "planning/status.hpp"

namespace pfield::planning {

struct TaskSpaceSettings {
  double dt;                  // s
  double goal_tolerance;      // m
  double rotation_tolerance;  // rad
  std::int64_t max_iterations;
  std::int64_t window;        // stagnation window, steps
  double progress;            // least improvement that counts (m, rad)
};

struct LoopResult {
  std::int64_t count;     // waypoints written
  PlanStatus status;
  std::int64_t obstacle;  // the obstacle that decided (nearest, or the one hit), -1 for none
};

// Plan from start (x, y, z, qx, qy, qz, qw) toward the field's goal, filling poses (max_iterations + 1, 7), twists
// (.., 6) and clearances (..). Stops at the first waypoint within both tolerances (Reached), before a waypoint or
// segment in collision (Collision: the path stays free unless the start is inside), when the stagnation rule fires
// (Stagnation), when *cancel is set (Cancelled, read atomically every step) or after max_iterations steps.
LoopResult plan_task_space(const field::Field& field, const double* start, const TaskSpaceSettings& settings,
                           const std::uint8_t* cancel, double* poses, double* twists, double* clearances);

// `count` RK4 steps of dt from the same pose (7) with the same previous twist (6), the stage twists carried from
// step to step as plan_task_space carries them, and nothing else of a plan step (no clearance bookkeeping, segment
// check or advance): the benchmark's figure of one RK4 step, as the numba engine's bench timed it. Returns the sum
// of the steps' mean v_x (m/s), so that no step can be left out.
double rk4_steps(const field::Field& field, const double* pose, const double* previous, double dt, std::int64_t count);

}  // namespace pfield::planning
