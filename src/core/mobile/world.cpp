#include "mobile/world.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pfield::mobile {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

double ray_circle(double ox, double oy, double dx, double dy, const double* circle) {
  const double fx = ox - circle[0], fy = oy - circle[1], r = circle[2];
  const double b = fx * dx + fy * dy;
  const double disc = b * b - (fx * fx + fy * fy - r * r);
  if (disc < 0.0) return kInf;
  const double root = std::sqrt(disc);
  double t = -b - root;
  if (t < 0.0) t = -b + root;  // the origin inside the circle: the exit point
  return t >= 0.0 ? t : kInf;
}

double ray_segment(double ox, double oy, double dx, double dy, const double* segment) {
  const double ex = segment[2] - segment[0], ey = segment[3] - segment[1];
  const double denom = dx * ey - dy * ex;
  if (std::abs(denom) < 1e-15) return kInf;
  const double wx = segment[0] - ox, wy = segment[1] - oy;
  const double t = (wx * ey - wy * ex) / denom;
  const double u = (wx * dy - wy * dx) / denom;
  return t >= 0.0 && u >= 0.0 && u <= 1.0 ? t : kInf;
}

}  // namespace

void raycast(const World2DView& world, double ox, double oy, const double* angles, std::size_t count,
             double range_max, double* ranges) {
  for (std::size_t i = 0; i < count; ++i) {
    const double dx = std::cos(angles[i]), dy = std::sin(angles[i]);
    double best = kInf;
    for (std::size_t k = 0; k < world.circle_count; ++k)
      best = std::min(best, ray_circle(ox, oy, dx, dy, world.circles + 3 * k));
    for (std::size_t k = 0; k < world.segment_count; ++k)
      best = std::min(best, ray_segment(ox, oy, dx, dy, world.segments + 4 * k));
    ranges[i] = best <= range_max ? best : kInf;
  }
}

double clearance(const World2DView& world, double px, double py) {
  double best = kInf;
  for (std::size_t k = 0; k < world.circle_count; ++k) {
    const double* c = world.circles + 3 * k;
    best = std::min(best, std::hypot(px - c[0], py - c[1]) - c[2]);
  }
  for (std::size_t k = 0; k < world.segment_count; ++k) {
    const double* s = world.segments + 4 * k;
    const double ex = s[2] - s[0], ey = s[3] - s[1];
    const double length2 = ex * ex + ey * ey;
    double u = length2 == 0.0 ? 0.0 : ((px - s[0]) * ex + (py - s[1]) * ey) / length2;
    u = std::min(std::max(u, 0.0), 1.0);
    best = std::min(best, std::hypot(px - s[0] - u * ex, py - s[1] - u * ey));
  }
  for (std::size_t k = 0; k < world.point_count; ++k) {
    const double* p = world.points + 2 * k;
    best = std::min(best, std::hypot(px - p[0], py - p[1]));
  }
  return best;
}

}  // namespace pfield::mobile
