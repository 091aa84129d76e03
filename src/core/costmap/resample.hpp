// A window of an occupancy grid resampled onto another grid (the node's rolling local costmap).
//
// Occupancy values as nav_msgs/OccupancyGrid: -1 unknown, 0..100 occupancy probability. Each window cell takes
// the worst source cell it overlaps: occupied (>= 100) > unknown (-1) > the highest free value; window cells that
// overlap no source cell are unknown.
#pragma once

#include <cstddef>
#include <cstdint>

namespace pfield::costmap {

struct OccupancyView {
  const std::int8_t* data = nullptr;  // (height, width) row-major, row 0 at the bottom
  std::int64_t width = 0;
  std::int64_t height = 0;
};

// The window in the source's cell coordinates: window cell (i, j) spans source cells
// [origin_u + i scale, origin_u + (i + 1) scale) x [origin_v + j scale, origin_v + (j + 1) scale).
struct Window {
  double origin_u = 0.0;
  double origin_v = 0.0;
  double scale = 1.0;  // window resolution / source resolution, > 0
  std::size_t size_x = 0;
  std::size_t size_y = 0;
};

// Fills `out` (size_y, size_x) row-major. Any finite origin is accepted (a window far from the map is unknown).
void resample_occupancy(const OccupancyView& source, const Window& window, std::int8_t* out);

}  // namespace pfield::costmap
