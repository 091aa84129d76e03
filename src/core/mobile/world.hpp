// A 2D world of circles, polygon edges and points for the simulation: laser ray casting and clearance.
//
// A ray from o along the unit d hits a circle where |o + t d - c| = r (smallest t >= 0; from inside, the exit)
// and an edge where o + t d = a + u (b - a), u in [0, 1], t >= 0 (2D cross products).
#pragma once

#include <cstddef>

namespace pfield::mobile {

struct World2DView {
  const double* circles = nullptr;   // (K, 3) rows cx, cy, radius
  std::size_t circle_count = 0;
  const double* segments = nullptr;  // (E, 4) rows x1, y1, x2, y2
  std::size_t segment_count = 0;
  const double* points = nullptr;    // (M, 2)
  std::size_t point_count = 0;
};

// Range (m) of each beam from (ox, oy) at the world `angles`; inf where nothing is within range_max.
void raycast(const World2DView& world, double ox, double oy, const double* angles, std::size_t count,
             double range_max, double* ranges);

// Distance (m) from (px, py) to the nearest circle boundary (negative inside), edge or point.
double clearance(const World2DView& world, double px, double py);

}  // namespace pfield::mobile
