// Forward kinematics and point Jacobians of a tree robot with 1-DoF joints, over the KinematicsView of
// robot/robot.hpp. The same operations in the same order as the numba kernels they replaced (issue 32), so the same
// bits, signed zeros included (tests/robot/test_core_kinematics.py holds digests of those kernels' results, beside
// pinocchio and finite-difference oracles).
//
// Forward kinematics composes T_i = T_parent(i) X_i exp(a_i q_i) (Featherstone, "Rigid Body Dynamics Algorithms"
// 2008, section 4.1), the rotation about the axis by Rodrigues' formula. The world-aligned Jacobian of a point p
// carried by joint k has, for each supporting revolute joint j, the column [z_j x (p - o_j); z_j] and for a
// prismatic one [z_j; 0], with z_j = R_j a_j the world axis and o_j the world origin of joint j (Siciliano et al.,
// "Robotics: Modelling, Planning and Control" 2009, section 3.1).
//
// The inline functions below do arithmetic: call them only from files compiled with -ffp-contract=off (every file
// under src/core/{field,planning,robot,math,shared_control}), not from the binding files, or the bits may differ.
#pragma once

#include <cstddef>
#include <cstdint>

#include "math/vec3.hpp"
#include "robot/robot.hpp"

namespace pfield::robot {

// A rigid frame in the world: rotation row-major (local -> world) and origin.
struct FramePose {
  double rotation[9];
  Vec3 position;
};

// World axis z_j of joint j and its linear Jacobian column at a world point.
struct JointColumn {
  Vec3 axis;    // z_j = R_j a_j
  Vec3 linear;  // revolute: z_j x (p - o_j); prismatic: z_j
};

// World rotation and origin of every joint frame at configuration q (n,), into frames (n * 9 and n * 3 doubles).
void joint_transforms(const KinematicsView& kinematics, const double* q, Frames& frames);

// World position of a point fixed to `joint` (-1: the base) at `local` in that joint's frame.
inline Vec3 transform_point(const Frames& frames, std::int64_t joint, Vec3 local) {
  if (joint < 0) return local;
  const double* r = frames.rotation(joint);
  const double* o = frames.origins + 3 * joint;
  return {r[0] * local.x + r[1] * local.y + r[2] * local.z + o[0],
          r[3] * local.x + r[4] * local.y + r[5] * local.z + o[1],
          r[6] * local.x + r[7] * local.y + r[8] * local.z + o[2]};
}

// World pose of a frame fixed to `joint` (-1: the base) at the local placement (rotation row-major 3x3, position).
FramePose frame_pose(const Frames& frames, std::int64_t joint, const double* local_rotation, Vec3 local_position);

// Joint j's world axis and linear column at the world point p.
inline JointColumn joint_column(const KinematicsView& kinematics, const Frames& frames, std::size_t j, Vec3 p) {
  const double* r = frames.rotation(static_cast<std::int64_t>(j));
  const double ax = kinematics.axes[3 * j], ay = kinematics.axes[3 * j + 1], az = kinematics.axes[3 * j + 2];
  const Vec3 z{r[0] * ax + r[1] * ay + r[2] * az, r[3] * ax + r[4] * ay + r[5] * az,
               r[6] * ax + r[7] * ay + r[8] * az};
  if (kinematics.kind(j) != JointKind::Revolute) return {z, z};
  const double* o = frames.origins + 3 * j;
  const double dx = p.x - o[0], dy = p.y - o[1], dz = p.z - o[2];
  return {z, {z.y * dz - z.z * dy, z.z * dx - z.x * dz, z.x * dy - z.y * dx}};
}

// The world-aligned 6 x n Jacobian (linear rows first, row-major) of the world point `point` rigidly attached to
// `joint`, overwriting out: columns of joints that do not support `joint` are zero, and so are a prismatic
// joint's angular rows; all zero for the base (joint -1).
void point_jacobian(const KinematicsView& kinematics, const Frames& frames, std::int64_t joint, Vec3 point,
                    double* out);

// The linear rows only (3 x n, row-major) of point_jacobian, overwriting out.
void linear_point_jacobian(const KinematicsView& kinematics, const Frames& frames, std::int64_t joint, Vec3 point,
                           double* out);

// The end effector's world pose from the joint frames (kinematics.ee_joint, ee_rot, ee_pos).
FramePose end_effector_pose(const KinematicsView& kinematics, const Frames& frames);

// Forward kinematics of every joint at q into frames, then the end effector's world pose and, when jacobian is
// not null, its 6 x n Jacobian into it (row-major).
FramePose end_effector_kinematics(const KinematicsView& kinematics, const double* q, Frames& frames,
                                  double* jacobian);

// The end effector's world pose at q as 7 numbers, a Pose's: position, then the unit quaternion x y z w (w >= 0,
// math::from_matrix) into out; frames is workspace.
void end_effector_pose7(const KinematicsView& kinematics, const double* q, Frames& frames, double* out);

// End-effector world positions (count, 3) of `count` configurations qs (count, n) into out; frames is workspace.
void batch_end_effector_positions(const KinematicsView& kinematics, const double* qs, std::size_t count,
                                  Frames& frames, double* out);

// The condition number kappa = sigma_max / sigma_min of a 6 x n end-effector Jacobian (n >= 6, row-major): the
// square root of the ratio of the extreme eigenvalues of J J^T (math::dls_gram, math::symmetric_eigenvalues; a 6 x 6
// eigenproblem instead of the SVD). Infinity when J J^T is singular (its smallest eigenvalue <= 0). MoveIt Servo's
// measure of the distance to a singularity.
double condition_number(const double* jacobian, std::size_t n);

// check_limits's verdict: every value fine (and clamped), or the first bad one.
struct LimitCheck {
  enum class Status { Ok, BeyondLimits, NotFinite };
  Status status = Status::Ok;
  std::int64_t index = -1;  // the first bad value (-1 when Ok)
};

// Clamps values (n,) onto [lower, upper] in place, stopping at the first value that is not finite or lies beyond
// its limits by more than `tolerance` (values before it are clamped, it and those after untouched).
LimitCheck check_limits(double* values, const double* lower, const double* upper, std::size_t n, double tolerance);

}  // namespace pfield::robot
