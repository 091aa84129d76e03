// The force and limit laws of the 3D potential field: their one home (docs/field.md says why each has its form);
// pfield.field.forces is their Python face (bound in python/field.cpp). Vectors in the world frame, SI units. The
// operation order is that of the Python kernels they replaced (issue 32), so results kept their last bit.
//
// * attraction, quadratic within G and conical beyond (Choset et al. 2005, sec. 4.1, eqs. 4.2-4.3);
// * Khatib repulsion m = eta (1/d - 1/Q)/d^2 for 0 < d < Q (Khatib 1986, eq. 19), saturated as m/sqrt(1 + (m/F)^2);
// * velocity dampers (Faverjon & Tournassoud 1987; Haviland & Corke 2021, NEO, eq. 20), in two forms: damper_speed
//   for a rate-limited twist, stepped_damper_speed for the whole-body QP's one-step rows;
// * soft saturation v <- v_max tanh(|v|/v_max) v/|v| and the rate limit |v - v_prev| <= a_max dt.
#pragma once

#include <algorithm>
#include <cmath>

#include "math/vec3.hpp"

namespace pfield::field {

using math::Vec3;

constexpr double kTiny = 1e-12;

// Attractive force for the goal error e = g - p: k e within G = threshold, k G e/|e| beyond (continuous at |e| = G).
inline Vec3 attraction(const Vec3& e, double gain, double threshold) {
  const double distance = std::sqrt(e.x * e.x + e.y * e.y + e.z * e.z);
  const double scale = distance <= threshold ? gain : gain * threshold / distance;
  return {scale * e.x, scale * e.y, scale * e.z};
}

// The saturated Khatib magnitude (N) at signed distance d: 0 beyond Q, F_cap inside.
inline double khatib_magnitude(double distance, double gain, double influence, double cap) {
  if (distance >= influence) return 0.0;
  if (distance <= 0.0) return cap;
  const double raw = gain * (1.0 / distance - 1.0 / influence) / (distance * distance);
  const double ratio = raw / cap;
  return raw / std::sqrt(1.0 + ratio * ratio);
}

// v <- limit tanh(|v|/limit) v/|v|: the same direction, a norm always below limit.
inline Vec3 soft_saturate(const Vec3& v, double limit) {
  const double norm = std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
  if (norm < kTiny) return v;
  const double scale = limit * std::tanh(norm / limit) / norm;
  return {scale * v.x, scale * v.y, scale * v.z};
}

// The point of the ball |v - v_prev| <= max_change nearest to v.
inline Vec3 rate_limit(const Vec3& v, const Vec3& previous, double max_change) {
  const double dx = v.x - previous.x, dy = v.y - previous.y, dz = v.z - previous.z;
  const double norm = std::sqrt(dx * dx + dy * dy + dz * dz);
  if (norm <= max_change) return v;
  const double scale = max_change / norm;
  return {previous.x + scale * dx, previous.y + scale * dy, previous.z + scale * dz};
}

// Largest allowed approach speed (m/s) toward an obstacle at d < Q (task space): xi (d - d_s)/(Q - d_s), capped by
// sqrt(a_max (d - d_s)) so that a rate-limited twist can still stop before d_s; never below -max_speed.
// Selects, not branches (the min/max of Python's rule: the first argument unless the second is smaller/larger), so
// that the batches' lanes take this same function in SIMD instructions (batch.cpp): the square root of a negative
// margin is computed there and not selected.
inline double damper_speed(double distance, double influence, double safety, double gain, double max_speed,
                           double max_acceleration) {
  const double margin = distance - safety;
  const double speed = gain * margin / (influence - safety);
  const double braking = std::sqrt(max_acceleration * margin);
  const double capped = margin > 0.0 && braking < speed ? braking : speed;  // min(speed, braking) where margin > 0
  const double floor = -max_speed;
  return capped < floor ? floor : capped;  // max(capped, -max_speed)
}

// Largest allowed approach speed (m/s or rad/s) at distance d < Q for a step of dt (the whole-body QP's damper
// rows): s = min(v (d - d_s)/(Q - d_s), (d - d_s)/(2 dt)) with v = max_speed; below d_s the required retreat
// max((d - d_s)/(2 dt), -v). Why not damper_speed: the QP's rows constrain joint velocities applied for one step
// whose rate limit is dropped when it would break a damper (safety first), so no braking distance is needed; what
// must hold is the discrete step: a link moving at s for dt covers at most half its margin, so d_s is approached
// geometrically and never crossed by a step. Python's min/max tie rule (the first argument unless the second is
// smaller/larger).
inline double stepped_damper_speed(double distance, double influence, double safety, double max_speed, double dt) {
  const double margin = distance - safety;
  const double step = 0.5 * margin / dt;
  if (margin <= 0.0) return -max_speed > step ? -max_speed : step;  // max(step, -max_speed)
  const double linear = max_speed * margin / (influence - safety);
  return step < linear ? step : linear;  // min(linear, step)
}

struct Limited {
  Vec3 v;
  bool changed = false;
};

// Enforce the damper n.v >= -allowed and turn the removed approach speed into tangential motion about the
// obstacle's circulation axis c (docs/field.md, "velocity dampers"); at zero excess the result is v.
inline Limited deflect(const Vec3& v, const Vec3& n, const Vec3& c, double allowed, double circulation) {
  const double normal_speed = v.x * n.x + v.y * n.y + v.z * n.z;
  const double excess = -normal_speed - allowed;
  if (excess <= 0.0) return {v, false};
  double px = v.x - normal_speed * n.x, py = v.y - normal_speed * n.y, pz = v.z - normal_speed * n.z;
  const double tx = n.y * c.z - n.z * c.y, ty = n.z * c.x - n.x * c.z, tz = n.x * c.y - n.y * c.x;
  const double speed_sq = v.x * v.x + v.y * v.y + v.z * v.z;
  const double t_sq = tx * tx + ty * ty + tz * tz;
  const double against = px * tx + py * ty + pz * tz;
  if (against < 0.0 && t_sq > kTiny) {
    const double share = 2.0 * excess * excess >= 0.5 * speed_sq ? 1.0 : 2.0 * excess / std::sqrt(speed_sq);
    const double drop = share * against / t_sq;
    px = px - drop * tx;
    py = py - drop * ty;
    pz = pz - drop * tz;
  }
  const double weight = circulation * excess;
  const double wx = px + weight * tx, wy = py + weight * ty, wz = pz + weight * tz;
  const double w_norm = std::sqrt(wx * wx + wy * wy + wz * wz);
  const double tangential = std::sqrt(std::max(speed_sq - allowed * allowed, 0.0));
  double ox = -allowed * n.x, oy = -allowed * n.y, oz = -allowed * n.z;
  if (w_norm > kTiny) {
    const double scale = tangential / w_norm;
    ox = ox + scale * wx;
    oy = oy + scale * wy;
    oz = oz + scale * wz;
  }
  return {{ox, oy, oz}, true};
}

// The nearest twist with approach speed -n.v <= allowed (projection onto the damper's half-space). Selects, not a
// branch, so that the batches' lanes take it in SIMD instructions (GCC does not if-convert the branch's return).
inline Limited project_damper(const Vec3& v, const Vec3& n, double allowed) {
  const double excess = -(v.x * n.x + v.y * n.y + v.z * n.z) - allowed;
  const bool changed = excess > 0.0;
  return {{changed ? v.x + excess * n.x : v.x, changed ? v.y + excess * n.y : v.y, changed ? v.z + excess * n.z : v.z},
          changed};
}

// Rate limit |v - v_prev| <= max_change that spends the budget on braking along the unit n first, then projects
// onto the ball |v| <= limit (v_prev must lie in it: the output contract clips it there).
inline Vec3 braking_rate_limit(const Vec3& v, const Vec3& previous, double max_change, const Vec3& n, double limit) {
  double dx = v.x - previous.x, dy = v.y - previous.y, dz = v.z - previous.z;
  const double norm = std::sqrt(dx * dx + dy * dy + dz * dz);
  if (norm <= max_change) return v;
  const double along = dx * n.x + dy * n.y + dz * n.z;
  if (along <= 0.0) {
    const double scale = max_change / norm;
    dx = scale * dx;
    dy = scale * dy;
    dz = scale * dz;
  } else {
    const double ax = along * n.x, ay = along * n.y, az = along * n.z;
    const double tx = dx - ax, ty = dy - ay, tz = dz - az;
    double scale, rest;
    if (along >= max_change) {
      scale = max_change / along;
      rest = 0.0;
    } else {
      const double t_norm = std::sqrt(tx * tx + ty * ty + tz * tz);
      scale = 1.0;
      rest = t_norm > kTiny ? std::sqrt(std::max(max_change * max_change - along * along, 0.0)) / t_norm : 0.0;
    }
    dx = scale * ax + rest * tx;
    dy = scale * ay + rest * ty;
    dz = scale * az + rest * tz;
  }
  double vx = previous.x + dx, vy = previous.y + dy, vz = previous.z + dz;
  const double speed = std::sqrt(vx * vx + vy * vy + vz * vz);
  if (speed > limit) {
    vx = vx * limit / speed;
    vy = vy * limit / speed;
    vz = vz * limit / speed;
  }
  return {vx, vy, vz};
}

// The laws one call at a time for pfield.field.forces (python/field.cpp binds these). Compiled out of line in
// forces.cpp, with the core's flags (no fused multiply-adds): inlined into a binding file they would take its
// -ffp-contract=fast and could part from the core's own loops in a last bit.
namespace out_of_line {
Vec3 attraction(const Vec3& e, double gain, double threshold);
double khatib_magnitude(double distance, double gain, double influence, double cap);
Vec3 soft_saturate(const Vec3& v, double limit);
double damper_speed(double distance, double influence, double safety, double gain, double max_speed,
                    double max_acceleration);
double stepped_damper_speed(double distance, double influence, double safety, double max_speed, double dt);
Limited deflect(const Vec3& v, const Vec3& n, const Vec3& c, double allowed, double circulation);
Limited project_damper(const Vec3& v, const Vec3& n, double allowed);
}  // namespace out_of_line

}  // namespace pfield::field
