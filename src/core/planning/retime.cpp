#include "planning/retime.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pfield::planning {

void differences(const JointPath& path, const double* h, double* v, double* a) {
  const std::size_t count = path.count, n = path.joints;
  const double* q = path.q;
  for (std::size_t j = 0; j < n; ++j) {
    v[j] = 0.0;
    v[(count - 1) * n + j] = 0.0;
    a[j] = 2.0 * (q[n + j] - q[j]) / (h[0] * h[0]);
    a[(count - 1) * n + j] = 2.0 * (q[(count - 2) * n + j] - q[(count - 1) * n + j]) / (h[count - 2] * h[count - 2]);
  }
  for (std::size_t k = 1; k + 1 < count; ++k) {
    const double h0 = h[k - 1], h1 = h[k];
    for (std::size_t j = 0; j < n; ++j) {
      const double d0 = (q[k * n + j] - q[(k - 1) * n + j]) / h0, d1 = (q[(k + 1) * n + j] - q[k * n + j]) / h1;
      v[k * n + j] = (h1 * d0 + h0 * d1) / (h0 + h1);
      a[k * n + j] = 2.0 * (d1 - d0) / (h0 + h1);
    }
  }
}

namespace {

// ratio[k] = max over joints of |v|/v_max and sqrt(|a|/a_max) at sample k; returns the largest.
double ratios(const double* v, const double* a, std::size_t count, std::size_t n, const double* v_max,
              const double* a_max, double* ratio) {
  double worst = 0.0;
  for (std::size_t k = 0; k < count; ++k) {
    double r = 0.0;
    for (std::size_t j = 0; j < n; ++j)
      r = std::max({r, std::abs(v[k * n + j]) / v_max[j], std::sqrt(std::abs(a[k * n + j]) / a_max[j])});
    ratio[k] = r;
    worst = std::max(worst, r);
  }
  return worst;
}

}  // namespace

Timing stretch_intervals(const JointPath& path, const double* h0, const double* v_max, const double* a_max,
                         int rounds) {
  const std::size_t count = path.count, n = path.joints;
  Timing out{std::vector<double>(h0, h0 + (count - 1)), std::vector<double>(count * n, 0.0),
             std::vector<double>(count * n, 0.0)};
  std::vector<double> ratio(count);
  for (int round = 0; round < rounds; ++round) {
    differences(path, out.h.data(), out.velocities.data(), out.accelerations.data());
    if (ratios(out.velocities.data(), out.accelerations.data(), count, n, v_max, a_max, ratio.data()) <= 1.0 + 1e-9)
      break;
    for (std::size_t k = 0; k + 1 < count; ++k) {
      const double factor = std::max(ratio[k], ratio[k + 1]);
      if (factor > 1.0 + 1e-9) out.h[k] *= factor;
    }
  }
  differences(path, out.h.data(), out.velocities.data(), out.accelerations.data());
  return out;
}

std::vector<std::int64_t> knot_indices(const double* arc, std::size_t count, double spacing) {
  std::vector<std::int64_t> keep{0};
  double last = 0.0;
  for (std::size_t k = 1; k < count; ++k) {
    if (arc[k] - last >= spacing) {
      keep.push_back(static_cast<std::int64_t>(k));
      last = arc[k];
    }
  }
  if (arc[count - 1] > arc[keep.back()]) keep.push_back(static_cast<std::int64_t>(count - 1));
  return keep;
}

void strictly_increasing(double* times, std::size_t count) {
  for (std::size_t k = 1; k < count; ++k)
    if (times[k] <= times[k - 1]) times[k] = std::nextafter(times[k - 1], std::numeric_limits<double>::infinity());
}

}  // namespace pfield::planning
