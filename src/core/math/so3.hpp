// Unit quaternions (x, y, z, w; ROS order) and SO(3) exp/log: the one home of this maths in the core.
//
// Rotation vectors are axis * angle (rad), the so(3) exponential coordinates (Sola, Deray & Atchuthan 2018, "A
// micro Lie theory", eqs. 101-102). Below kSmallAngle exp and log use their Taylor series, whose next terms are
// under half an ulp there, avoiding the closed forms' 0/0 at the identity. pfield/_spatial_kernels.py holds the
// same formulas for the kernels not yet moved to the core; the results agree to the last bit.
#pragma once

#include <cmath>

#include "math/vec3.hpp"

namespace pfield::math {

struct Quat {
  double x = 0.0;
  double y = 0.0;
  double z = 0.0;
  double w = 1.0;
};

constexpr double kSmallAngle = 1e-8;

// a (x) b: apply b first, then a.
inline Quat hamilton(const Quat& a, const Quat& b) {
  return {a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y, a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
          a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w, a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z};
}

// exp: so(3) -> S^3, (sin(t/2) a/t, cos(t/2)) with t = |a|.
inline Quat so3_exp(const Vec3& a) {
  const double theta = std::sqrt(a.x * a.x + a.y * a.y + a.z * a.z);
  double s, w;
  if (theta < kSmallAngle) {
    s = 0.5 - theta * theta / 48.0;
    w = 1.0 - theta * theta / 8.0;
  } else {
    s = std::sin(0.5 * theta) / theta;
    w = std::cos(0.5 * theta);
  }
  return {s * a.x, s * a.y, s * a.z, w};
}

// log: S^3 -> so(3) on the short arc (q and -q alike), angle in [0, pi].
inline Vec3 so3_log(Quat q) {
  if (q.w < 0.0) q = {-q.x, -q.y, -q.z, -q.w};
  const double vnorm = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z);
  const double scale = vnorm < kSmallAngle ? 2.0 / q.w : 2.0 * std::atan2(vnorm, q.w) / vnorm;
  return {scale * q.x, scale * q.y, scale * q.z};
}

// The world-frame rotation error log(goal (x) q^-1) of unit quaternions (Sola et al. 2018, eq. 26, left minus):
// integrating omega = k error on the left shrinks it along its own axis, from any start up to 180 degrees.
inline Vec3 rotation_error(const Quat& q, const Quat& goal) {
  return so3_log(hamilton(goal, Quat{-q.x, -q.y, -q.z, q.w}));
}

// exp(h omega) (x) q, renormalised: the world-frame (left) update of a unit quaternion by omega (rad/s).
inline Quat left_increment(const Quat& q, const Vec3& omega, double h) {
  const Quat r = hamilton(so3_exp({h * omega.x, h * omega.y, h * omega.z}), q);
  const double norm = std::sqrt(r.x * r.x + r.y * r.y + r.z * r.z + r.w * r.w);
  return {r.x / norm, r.y / norm, r.z / norm, r.w / norm};
}

}  // namespace pfield::math
