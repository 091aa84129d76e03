// Why a plan ended: the values of pfield.planning.PlanStatus (its Python enum, which prints the names), for the
// loops in the core. Only Reached is a success.
#pragma once

#include <cstdint>

namespace pfield::planning {

enum class PlanStatus : std::int64_t {
  Reached = 0,
  Stagnation = 1,
  IterationLimit = 2,
  Collision = 3,
  SelfCollision = 4,
  NotFinite = 5,
  StartInvalid = 6,
  GoalInvalid = 7,
  Cancelled = 8,
  IkFailed = 9,
  GlobalNoPath = 10,
  GlobalTimeLimit = 11,
};

// The stagnation rule of every planning loop (pfield/planning/_progress.py): keep the best position and rotation
// errors, and every `window` steps compare them with their values one window earlier; no improvement by
// `progress` (m, rad) in either stagnates. Best rather than current errors make a limit cycle stagnate too.
struct Progress {
  double best_position;
  double best_rotation;
  double window_position;
  double window_rotation;

  // Record step `step`'s goal errors; true when the window brought no progress.
  bool stuck(std::int64_t step, std::int64_t window, double progress, double position_error, double rotation_error) {
    best_position = position_error < best_position ? position_error : best_position;
    best_rotation = rotation_error < best_rotation ? rotation_error : best_rotation;
    if (step % window != 0) return false;
    if (window_position - best_position < progress && window_rotation - best_rotation < progress) return true;
    window_position = best_position;
    window_rotation = best_rotation;
    return false;
  }
};

}  // namespace pfield::planning
