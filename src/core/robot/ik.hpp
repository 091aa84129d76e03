// Inverse kinematics of the end effector: damped least squares with joint limits, position and orientation.
//
// Each iteration solves for the joint step (math/dls.hpp; Buss 2004, eq. 11)
//
//     dq = J^T (J J^T + lambda^2 I)^-1 e,     e = [p* - p(q);  log(R* R(q)^T)]   (world frame, m and rad)
//
// then clips q + dq to the joint limits; joints that sit on a limit and would be pushed past it are frozen (their
// Jacobian column removed) and the step recomputed, up to three times, so the remaining joints make the progress
// (a projected DLS). The step is scaled so that no joint moves more than max_step per iteration. It stops when
// |p* - p| <= position_tolerance and the rotation angle <= rotation_tolerance. The same operations in the same
// order as the numba kernels of pfield.robot.ik that it replaced (issue 32), so the same iterates to the bit.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "math/so3.hpp"
#include "math/vec3.hpp"
#include "robot/kinematics.hpp"
#include "robot/robot.hpp"

namespace pfield::robot {

struct IKSettings {
  std::int64_t max_iterations = 200;  // >= 1
  double position_tolerance = 1e-4;   // m
  double rotation_tolerance = 1e-3;   // rad
  double damping = 1e-4;              // lambda^2 (m^2)
  double max_step = 0.3;              // the largest joint move per iteration (rad or m)
};

// The end effector's goal in the world frame (a unit quaternion, x y z w).
struct IKTarget {
  Vec3 position;
  math::Quat orientation;
};

// One solve: q is the last iterate (within the limits) even when success is false.
struct IKOutcome {
  bool success = false;
  std::int64_t iterations = 0;
  double position_error = 0.0;  // m
  double rotation_error = 0.0;  // rad
};

// What a checked solve refused, before iterating (the prepared solver's inputs come unvalidated from Python).
enum class IKInput { Valid, BadSeed, BadPosition, BadOrientation };

// A path's IK: the first waypoint that failed (-1: none) and its errors (0 when none failed).
struct IKPathOutcome {
  std::int64_t failed = -1;
  double position_error = 0.0;
  double rotation_error = 0.0;
};

// The tolerance on |q|^2 - 1 of a target quaternion in solve_checked: 2 * 1e-9 (pfield.spatial's unit test).
constexpr double kUnitQuaternionTolerance = 1e-9;

// The DLS solver over one robot's kinematics and limits (read in place; they must outlive it); it owns its
// workspace, so one solver serves one thread at a time.
class IKSolver {
 public:
  IKSolver(const KinematicsView& kinematics, const double* lower, const double* upper, const IKSettings& settings);
  IKSolver(const IKSolver&) = delete;  // its views point into its own buffer
  IKSolver& operator=(const IKSolver&) = delete;

  std::size_t joint_count() const { return kinematics_.joint_count; }
  const IKSettings& settings() const { return settings_; }

  // The iterations on q (n,), already within the limits, in place.
  IKOutcome iterate(double* q, const IKTarget& target);

  // From seed (n,) clamped onto the limits, into q (n,; may be seed itself).
  IKOutcome solve(const double* seed, const IKTarget& target, double* q);

  // solve() after checking what Python did not: a target position that is not finite, a quaternion whose squared
  // norm is not 1 within 2 kUnitQuaternionTolerance, a seed not finite or beyond the limits by more than
  // limit_tolerance (the seed is clamped within it). On a refusal q is left unchanged.
  IKInput solve_checked(const double* seed, const double* target /*7: position, x y z w*/, double limit_tolerance,
                        double* q, IKOutcome& outcome);

  // The IK of every waypoint (positions (count, 3), unit quaternions (count, 4)), each seeded from the previous
  // solution and the first from seed; the solutions into qs (count, n), up to and including the first failure.
  IKPathOutcome solve_path(const double* seed, const double* positions, const double* orientations,
                           std::size_t count, double* qs);

 private:
  // e = [p* - p; rotation error] and the two error norms
  struct Error {
    double position;
    double rotation;
  };
  Error error(const FramePose& pose, const IKTarget& target);
  void clamp(const double* values, double* q) const;

  KinematicsView kinematics_;
  const double* lower_;
  const double* upper_;
  IKSettings settings_;
  // one allocation: rotations (9n), origins (3n), the Jacobian (6n), the step (n), a scratch vector (n)
  std::vector<double> buffer_;
  double* rotations_;
  double* origins_;
  double* jacobian_;
  double* step_;
  double* scratch_;
  std::vector<std::uint8_t> frozen_;
  double e_[6] = {};
};

}  // namespace pfield::robot
