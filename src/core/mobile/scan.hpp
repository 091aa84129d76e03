// Laser scans to weighted obstacle points for the 2D field (pfield/mobile/scan.py documents the weightings).
#pragma once

#include <cstddef>
#include <vector>

namespace pfield::mobile {

enum class ScanWeighting { Sector = 0, ArcLength = 1, Sum = 2 };

struct ScanGeometry {
  double angle_min = 0.0;        // rad, of the first beam
  double angle_increment = 0.0;  // rad between beams
  double range_min = 0.0;        // m; beams outside [range_min, range_max] (NaN, inf) are invalid
  double range_max = 0.0;
};

struct Pose2D {
  double x = 0.0;
  double y = 0.0;
  double yaw = 0.0;
};

struct ScanPoints {
  std::vector<double> points;   // (M, 2) row-major, in the sensor pose's parent frame
  std::vector<double> weights;  // (M,)
};

// Valid beams -> points and weights: every valid beam (ArcLength: weight r |angle_increment|; Sum: 1), or the
// nearest valid beam of each sector of `sector_angle` rad (Sector: weight 1). Beam directions come from the
// rotation recurrence (cos, sin)(t + d) = R(d)(cos, sin)(t), re-anchored on exact cos/sin every 32 beams
// (error ~1e-14), several times cheaper than one libm call per beam.
ScanPoints scan_points(const double* ranges, std::size_t count, const ScanGeometry& scan, const Pose2D& sensor,
                       ScanWeighting weighting, double sector_angle);

}  // namespace pfield::mobile
