// Unit quaternions (x, y, z, w; ROS order) and SO(3) exp/log: the one home of this maths in the core.
//
// Rotation vectors are axis * angle (rad), the so(3) exponential coordinates (Sola, Deray & Atchuthan 2018, "A
// micro Lie theory", eqs. 101-102). Below kSmallAngle exp and log use their Taylor series, whose next terms are
// under half an ulp there, avoiding the closed forms' 0/0 at the identity. Python reaches them through
// pfield.spatial (quaternion_exp, quaternion_log, ...), bound in python/spatial.cpp.
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
    // The series 0.5 - t^2/48 and 1 - t^2/8 round to 0.5 and 1 exactly below kSmallAngle (t^2/48 < 2^-55 and
    // t^2/8 < 2^-54 are under half an ulp of 0.5 and of 1): the constants are the same bits without the two
    // divisions on the chain of every increment (the task-space loop takes five per step).
    s = 0.5;
    w = 1.0;
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

// v rotated by the unit quaternion q: v + 2w (u x v) + 2 u x (u x v).
inline Vec3 rotate(const Quat& q, const Vec3& v) {
  const double tx = 2.0 * (q.y * v.z - q.z * v.y), ty = 2.0 * (q.z * v.x - q.x * v.z),
               tz = 2.0 * (q.x * v.y - q.y * v.x);
  return {v.x + q.w * tx + (q.y * tz - q.z * ty), v.y + q.w * ty + (q.z * tx - q.x * tz),
          v.z + q.w * tz + (q.x * ty - q.y * tx)};
}

// The geodesic angle between two unit quaternions, 2 acos(|<a, b>|) in [0, pi].
inline double angle(const Quat& a, const Quat& b) {
  double d = std::abs(a.x * b.x + a.y * b.y + a.z * b.z + a.w * b.w);
  if (d > 1.0) d = 1.0;
  return 2.0 * std::acos(d);
}

// The rotation matrix (row-major, local -> parent) of a unit quaternion.
inline void to_matrix(const Quat& q, double* r) {
  const double x = q.x, y = q.y, z = q.z, w = q.w;
  r[0] = 1.0 - 2.0 * (y * y + z * z), r[1] = 2.0 * (x * y - z * w), r[2] = 2.0 * (x * z + y * w);
  r[3] = 2.0 * (x * y + z * w), r[4] = 1.0 - 2.0 * (x * x + z * z), r[5] = 2.0 * (y * z - x * w);
  r[6] = 2.0 * (x * z - y * w), r[7] = 2.0 * (y * z + x * w), r[8] = 1.0 - 2.0 * (x * x + y * y);
}

// The unit quaternion (w >= 0) of a rotation matrix (row-major), by Shepperd's method (Shepperd 1978): the
// largest of the trace and the diagonal decides which component is found from a square root, the stable one.
inline Quat from_matrix(const double* r) {
  Quat q;
  const double trace = r[0] + r[4] + r[8];
  if (trace > 0.0) {
    const double s = 2.0 * std::sqrt(1.0 + trace);
    q = {(r[7] - r[5]) / s, (r[2] - r[6]) / s, (r[3] - r[1]) / s, 0.25 * s};
  } else if (r[0] > r[4] && r[0] > r[8]) {
    const double s = 2.0 * std::sqrt(1.0 + r[0] - r[4] - r[8]);
    q = {0.25 * s, (r[1] + r[3]) / s, (r[2] + r[6]) / s, (r[7] - r[5]) / s};
  } else if (r[4] > r[8]) {
    const double s = 2.0 * std::sqrt(1.0 + r[4] - r[0] - r[8]);
    q = {(r[1] + r[3]) / s, 0.25 * s, (r[5] + r[7]) / s, (r[2] - r[6]) / s};
  } else {
    const double s = 2.0 * std::sqrt(1.0 + r[8] - r[0] - r[4]);
    q = {(r[2] + r[6]) / s, (r[5] + r[7]) / s, 0.25 * s, (r[3] - r[1]) / s};
  }
  if (q.w < 0.0) q = {-q.x, -q.y, -q.z, -q.w};
  return q;
}

}  // namespace pfield::math
