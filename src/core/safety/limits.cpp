// The output contract's rules (limits.hpp), compiled once: see limits.hpp for why this is the only copy.
#include "safety/limits.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>

namespace pfield::safety {

double part_scale(double x, double y, double z, double limit) {
  const double largest = std::max(std::abs(x), std::max(std::abs(y), std::abs(z)));
  // A part clearly within its limit, the common case, answers 1 without the scaled norm's divisions and hypot:
  // with its largest component in [1e-150, 1e150) the plain sum of squares neither overflows nor falls among the
  // subnormals and is within a few ulp of |v|^2, so a sum under (1 - 1e-9) limit^2 is a part whose scaled ratio
  // below would also be > 1 (the same 1.0 either way).
  if (largest >= 1e-150 && largest < 1e150 && limit > 0.0 &&
      x * x + y * y + z * z < (1.0 - 1e-9) * (limit * limit))
    return 1.0;
  if (largest == 0.0) return 1.0;
  const double ratio = (limit / largest) / std::hypot(x / largest, y / largest, z / largest);
  return ratio < 1.0 ? ratio : 1.0;
}

double twist_scale(const double* v, double max_linear, double max_angular) {
  for (int k = 0; k < 6; ++k)
    if (!std::isfinite(v[k])) return std::numeric_limits<double>::quiet_NaN();
  return std::min(part_scale(v[0], v[1], v[2], max_linear), part_scale(v[3], v[4], v[5], max_angular));
}

double joint_scale(const double* qd, const double* limits, std::size_t n) {
  double scale = 1.0;
  for (std::size_t j = 0; j < n; ++j) {
    if (!std::isfinite(qd[j])) return std::numeric_limits<double>::quiet_NaN();
    const double limit = limits[j];
    if (limit > 0.0 && limit < std::numeric_limits<double>::infinity() && std::abs(qd[j]) > limit)
      scale = std::min(scale, limit / std::abs(qd[j]));
  }
  return scale;
}

Outcome apply(double scale, double* values, std::size_t count) {
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

Outcome limit_twist(double* v, double max_linear, double max_angular) {
  return apply(twist_scale(v, max_linear, max_angular), v, 6);
}

Outcome limit_joint_command(double* qd, std::size_t n, double* twist, const double* limits, double max_linear,
                            double max_angular) {
  const double joints = joint_scale(qd, limits, n), cartesian = twist_scale(twist, max_linear, max_angular);
  const double scale = std::isnan(joints) || std::isnan(cartesian) ? std::numeric_limits<double>::quiet_NaN()
                                                                    : std::min(joints, cartesian);
  const Outcome outcome = apply(scale, qd, n);
  apply(scale, twist, 6);
  return outcome;
}

}  // namespace pfield::safety
