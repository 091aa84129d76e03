// The robot's forward kinematics and point Jacobians (kinematics.hpp): the numba kernels they replaced (issue 32)
// statement for statement, so the sums run in the same order and give the same bits.
#include "robot/kinematics.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "math/dls.hpp"
#include "math/linalg.hpp"
#include "math/so3.hpp"

namespace pfield::robot {

void joint_transforms(const KinematicsView& kinematics, const double* q, Frames& frames) {
  const std::size_t n = kinematics.joint_count;
  for (std::size_t i = 0; i < n; ++i) {
    const std::int64_t k = kinematics.parents[i];
    const double* pr = kinematics.place_rot + 9 * i;
    const double* pp = kinematics.place_pos + 3 * i;
    // B = R_parent P_i and o = R_parent p_i + o_parent (B = P_i, o = p_i at the base)
    double b[9];
    double o0, o1, o2;
    if (k < 0) {
      std::memcpy(b, pr, sizeof b);
      o0 = pp[0], o1 = pp[1], o2 = pp[2];
    } else {
      const double* rp = frames.rotation(k);
      const double* op = frames.origins + 3 * k;
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
          b[3 * r + c] = rp[3 * r] * pr[c] + rp[3 * r + 1] * pr[3 + c] + rp[3 * r + 2] * pr[6 + c];
      const double px = pp[0], py = pp[1], pz = pp[2];
      o0 = rp[0] * px + rp[1] * py + rp[2] * pz + op[0];
      o1 = rp[3] * px + rp[4] * py + rp[5] * pz + op[1];
      o2 = rp[6] * px + rp[7] * py + rp[8] * pz + op[2];
    }
    const double x = kinematics.axes[3 * i], y = kinematics.axes[3 * i + 1], z = kinematics.axes[3 * i + 2];
    double* out = frames.rotations + 9 * i;
    if (kinematics.kind(i) == JointKind::Revolute) {
      // Rodrigues: L = c I + (1 - c) a a^T + s [a]x, entries written as the numba kernel wrote them
      const double c = std::cos(q[i]), s = std::sin(q[i]);
      const double t = 1.0 - c;
      const double l[9] = {c + x * x * t,     x * y * t - z * s, x * z * t + y * s,
                           y * x * t + z * s, c + y * y * t,     y * z * t - x * s,
                           z * x * t - y * s, z * y * t + x * s, c + z * z * t};
      for (int r = 0; r < 3; ++r)
        for (int col = 0; col < 3; ++col)
          out[3 * r + col] = b[3 * r] * l[col] + b[3 * r + 1] * l[3 + col] + b[3 * r + 2] * l[6 + col];
    } else {
      std::memcpy(out, b, sizeof b);
      const double d = q[i];
      o0 += (b[0] * x + b[1] * y + b[2] * z) * d;
      o1 += (b[3] * x + b[4] * y + b[5] * z) * d;
      o2 += (b[6] * x + b[7] * y + b[8] * z) * d;
    }
    double* origin = frames.origins + 3 * i;
    origin[0] = o0, origin[1] = o1, origin[2] = o2;
  }
}

FramePose frame_pose(const Frames& frames, std::int64_t joint, const double* local_rotation, Vec3 local_position) {
  FramePose pose;
  if (joint < 0) {
    std::memcpy(pose.rotation, local_rotation, sizeof pose.rotation);
    pose.position = local_position;
    return pose;
  }
  const double* rj = frames.rotation(joint);
  for (int a = 0; a < 3; ++a)
    for (int c = 0; c < 3; ++c)
      pose.rotation[3 * a + c] =
          rj[3 * a] * local_rotation[c] + rj[3 * a + 1] * local_rotation[3 + c] + rj[3 * a + 2] * local_rotation[6 + c];
  pose.position = transform_point(frames, joint, local_position);
  return pose;
}

namespace {

// The Jacobian rows of the world point carried by `joint` into out (rows x n: the 3 linear rows, then with
// Angular the 3 angular ones), zero for the joints that do not move it (all of them for the base, joint -1).
template <bool Angular>
void point_jacobian_rows(const KinematicsView& kinematics, const Frames& frames, std::int64_t joint, Vec3 point,
                         double* out) {
  const std::size_t n = kinematics.joint_count;
  std::fill(out, out + (Angular ? 6 : 3) * n, 0.0);
  if (joint < 0) return;
  for (std::size_t j = 0; j < n; ++j) {
    if (!kinematics.supports(joint, j)) continue;
    const JointColumn column = joint_column(kinematics, frames, j, point);
    out[j] = column.linear.x, out[n + j] = column.linear.y, out[2 * n + j] = column.linear.z;
    if (Angular && kinematics.kind(j) == JointKind::Revolute)
      out[3 * n + j] = column.axis.x, out[4 * n + j] = column.axis.y, out[5 * n + j] = column.axis.z;
  }
}

}  // namespace

void point_jacobian(const KinematicsView& kinematics, const Frames& frames, std::int64_t joint, Vec3 point,
                    double* out) {
  point_jacobian_rows<true>(kinematics, frames, joint, point, out);
}

void linear_point_jacobian(const KinematicsView& kinematics, const Frames& frames, std::int64_t joint, Vec3 point,
                           double* out) {
  point_jacobian_rows<false>(kinematics, frames, joint, point, out);
}

FramePose end_effector_pose(const KinematicsView& kinematics, const Frames& frames) {
  const double* p = kinematics.ee_pos;
  return frame_pose(frames, kinematics.ee_joint, kinematics.ee_rot, {p[0], p[1], p[2]});
}

FramePose end_effector_kinematics(const KinematicsView& kinematics, const double* q, Frames& frames,
                                  double* jacobian) {
  joint_transforms(kinematics, q, frames);
  const FramePose pose = end_effector_pose(kinematics, frames);
  if (jacobian != nullptr) point_jacobian(kinematics, frames, kinematics.ee_joint, pose.position, jacobian);
  return pose;
}

void end_effector_pose7(const KinematicsView& kinematics, const double* q, Frames& frames, double* out) {
  joint_transforms(kinematics, q, frames);
  const FramePose pose = end_effector_pose(kinematics, frames);
  const math::Quat quat = math::from_matrix(pose.rotation);
  out[0] = pose.position.x, out[1] = pose.position.y, out[2] = pose.position.z;
  out[3] = quat.x, out[4] = quat.y, out[5] = quat.z, out[6] = quat.w;
}

void batch_end_effector_positions(const KinematicsView& kinematics, const double* qs, std::size_t count,
                                  Frames& frames, double* out) {
  const std::size_t n = kinematics.joint_count;
  for (std::size_t k = 0; k < count; ++k) {
    joint_transforms(kinematics, qs + k * n, frames);
    const Vec3 p = end_effector_pose(kinematics, frames).position;
    out[3 * k] = p.x, out[3 * k + 1] = p.y, out[3 * k + 2] = p.z;
  }
}

LimitCheck check_limits(double* values, const double* lower, const double* upper, std::size_t n, double tolerance) {
  for (std::size_t i = 0; i < n; ++i) {
    const double v = values[i];
    if (!std::isfinite(v)) return {LimitCheck::Status::NotFinite, static_cast<std::int64_t>(i)};
    if (v < lower[i] - tolerance || v > upper[i] + tolerance)
      return {LimitCheck::Status::BeyondLimits, static_cast<std::int64_t>(i)};
    const double above = lower[i] > v ? lower[i] : v;  // Python's max(v, lower): v unless lower > v
    values[i] = upper[i] < above ? upper[i] : above;   // Python's min(above, upper)
  }
  return {};
}

double condition_number(const double* jacobian, std::size_t n) {
  constexpr std::size_t kRows = 6;
  double gram[kRows * kRows], values[kRows];
  math::dls_gram(jacobian, kRows, n, nullptr, gram);
  math::symmetric_eigenvalues(gram, kRows, values);
  const double largest = *std::max_element(values, values + kRows);
  const double smallest = *std::min_element(values, values + kRows);
  return smallest > 0.0 ? std::sqrt(largest / smallest) : std::numeric_limits<double>::infinity();
}

}  // namespace pfield::robot
