#include "mobile/scan.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pfield::mobile {
namespace {

constexpr std::size_t kAnchor = 32;  // beams between exact cos/sin evaluations of the rotation recurrence
constexpr double kPi = 3.14159265358979323846;

bool valid(double r, const ScanGeometry& scan) { return scan.range_min <= r && r <= scan.range_max; }

// Which beams become points: every valid one, or the nearest valid one per sector.
std::vector<unsigned char> select_beams(const double* ranges, std::size_t count, const ScanGeometry& scan,
                                        ScanWeighting weighting, double sector_angle) {
  std::vector<unsigned char> keep(count, 0);
  if (weighting != ScanWeighting::Sector) {
    for (std::size_t i = 0; i < count; ++i) keep[i] = valid(ranges[i], scan);
    return keep;
  }
  const auto sectors = static_cast<std::size_t>(std::max(1.0, std::ceil(2.0 * kPi / sector_angle)));
  std::vector<double> best(sectors, std::numeric_limits<double>::infinity());
  std::vector<std::ptrdiff_t> best_index(sectors, -1);
  const double inverse = 1.0 / sector_angle;
  for (std::size_t i = 0; i < count; ++i) {
    const double r = ranges[i];
    if (!valid(r, scan)) continue;
    double offset = scan.angle_min + static_cast<double>(i) * scan.angle_increment + kPi;
    offset -= 2.0 * kPi * std::floor(offset * (0.5 / kPi));  // wrapped into [0, 2 pi) without a float modulo
    const std::size_t sector = std::min(static_cast<std::size_t>(offset * inverse), sectors - 1);
    // unconditional stores (conditional moves): whether a beam is its sector's nearest so far is a coin toss
    // to the branch predictor
    const bool nearer = r < best[sector];
    best_index[sector] = nearer ? static_cast<std::ptrdiff_t>(i) : best_index[sector];
    best[sector] = nearer ? r : best[sector];
  }
  for (std::ptrdiff_t index : best_index)
    if (index >= 0) keep[static_cast<std::size_t>(index)] = 1;
  return keep;
}

}  // namespace

ScanPoints scan_points(const double* ranges, std::size_t count, const ScanGeometry& scan, const Pose2D& sensor,
                       ScanWeighting weighting, double sector_angle) {
  const std::vector<unsigned char> keep = select_beams(ranges, count, scan, weighting, sector_angle);
  const std::size_t kept = static_cast<std::size_t>(std::count(keep.begin(), keep.end(), 1));
  ScanPoints out;
  out.points.resize(2 * kept);
  out.weights.assign(kept, 1.0);
  const double c_yaw = std::cos(sensor.yaw), s_yaw = std::sin(sensor.yaw);
  const double c_step = std::cos(scan.angle_increment), s_step = std::sin(scan.angle_increment);
  double c = 0.0, s = 0.0;
  std::size_t k = 0;
  for (std::size_t i = 0; i < count; ++i) {
    if (i % kAnchor == 0) {
      const double theta = scan.angle_min + static_cast<double>(i) * scan.angle_increment;
      c = std::cos(theta);
      s = std::sin(theta);
    }
    if (keep[i]) {
      const double lx = ranges[i] * c, ly = ranges[i] * s;
      out.points[2 * k] = sensor.x + c_yaw * lx - s_yaw * ly;
      out.points[2 * k + 1] = sensor.y + s_yaw * lx + c_yaw * ly;
      if (weighting == ScanWeighting::ArcLength) out.weights[k] = ranges[i] * std::abs(scan.angle_increment);
      ++k;
    }
    const double next_c = c * c_step - s * s_step;
    s = s * c_step + c * s_step;
    c = next_c;
  }
  return out;
}

}  // namespace pfield::mobile
