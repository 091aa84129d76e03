// The output contract: every command pfield returns is finite and within its velocity limits (docs/assistance.md
// "The output contract"; pfield.safety is its Python face and calls these). The one home of these rules.
//
// 1. A command with a NaN or an infinity is replaced by zeros (Halted).
// 2. A twist whose linear part is longer than max_linear or whose angular part is longer than max_angular is
//    scaled by the one factor that brings both within (direction kept); joint velocities by s = min_j v_j / |qd_j|
//    (MoveIt Servo's scaling), and a whole-body command's joints and twist by one factor, the smaller (Scaled).
// 3. Inputs beyond the limits (a previous twist, previous joint velocities) are clipped before use (clip_*).
// Norms are taken as m |v/m| with m = max |v_i|, so 1e308 components neither overflow nor lose their direction.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>

namespace pfield::safety {

enum class Outcome : int { Within = 0, Scaled = 1, Halted = 2 };

// The largest s <= 1 with s |(x, y, z)| <= limit, for finite components.
inline double part_scale(double x, double y, double z, double limit) {
  const double largest = std::max(std::abs(x), std::max(std::abs(y), std::abs(z)));
  if (largest == 0.0) return 1.0;
  const double ratio = (limit / largest) / std::hypot(x / largest, y / largest, z / largest);
  return ratio < 1.0 ? ratio : 1.0;
}

// The factor in [0, 1] that brings the twist (linear, angular) within both limits; NaN when a component is not
// finite.
inline double twist_scale(const double* v, double max_linear, double max_angular) {
  for (int k = 0; k < 6; ++k)
    if (!std::isfinite(v[k])) return std::numeric_limits<double>::quiet_NaN();
  return std::min(part_scale(v[0], v[1], v[2], max_linear), part_scale(v[3], v[4], v[5], max_angular));
}

// min(1, min_j limit_j / |qd_j|) over joints with a positive finite limit; NaN when a qd_j is not finite.
inline double joint_scale(const double* qd, const double* limits, std::size_t n) {
  double scale = 1.0;
  for (std::size_t j = 0; j < n; ++j) {
    if (!std::isfinite(qd[j])) return std::numeric_limits<double>::quiet_NaN();
    const double limit = limits[j];
    if (limit > 0.0 && limit < std::numeric_limits<double>::infinity() && std::abs(qd[j]) > limit)
      scale = std::min(scale, limit / std::abs(qd[j]));
  }
  return scale;
}

// Rules 1 and 2 with a factor of twist_scale / joint_scale on `count` values in place.
inline Outcome apply(double scale, double* values, std::size_t count) {
  if (std::isnan(scale)) {
    std::fill(values, values + count, 0.0);
    return Outcome::Halted;
  }
  if (scale < 1.0) {
    for (std::size_t k = 0; k < count; ++k) values[k] *= scale;
    return Outcome::Scaled;
  }
  return Outcome::Within;
}

// Rules 1 and 2 on a twist (6) in place.
inline Outcome limit_twist(double* v, double max_linear, double max_angular) {
  return apply(twist_scale(v, max_linear, max_angular), v, 6);
}

// Rules 1 and 2 on a whole-body command in place: qd (n) and its twist J qd (6) by one factor, the smaller of
// the two rules (both zeroed when either is not finite).
inline Outcome limit_joint_command(double* qd, std::size_t n, double* twist, const double* limits, double max_linear,
                                   double max_angular) {
  const double joints = joint_scale(qd, limits, n), cartesian = twist_scale(twist, max_linear, max_angular);
  const double scale = std::isnan(joints) || std::isnan(cartesian) ? std::numeric_limits<double>::quiet_NaN()
                                                                    : std::min(joints, cartesian);
  const Outcome outcome = apply(scale, qd, n);
  apply(scale, twist, 6);
  return outcome;
}

}  // namespace pfield::safety
