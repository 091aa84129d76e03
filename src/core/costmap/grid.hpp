// A costmap's cells as the core reads them: nav2's cost values and a view of a (size_y, size_x) grid of costs.
//
// Cell coordinates (costmap_2d worldToMap): a world point (wx, wy) has u = (wx - origin_x) / resolution,
// v = (wy - origin_y) / resolution and lies in cell (floor(u), floor(v)); cell (m, n) is the half-open square
// [m, m + 1) x [n, n + 1); costs are stored row-major, costs[n * size_x + m] (row n = y, row 0 at the bottom).
#pragma once

#include <cstdint>

namespace pfield::costmap {

// nav2 cost_values.hpp
constexpr std::uint8_t kFreeSpace = 0;
constexpr std::uint8_t kInscribedInflatedObstacle = 253;
constexpr std::uint8_t kLethalObstacle = 254;
constexpr std::uint8_t kNoInformation = 255;

struct CostGrid {
  const std::uint8_t* costs = nullptr;  // (size_y, size_x) row-major
  std::int64_t size_x = 0;
  std::int64_t size_y = 0;

  bool contains(std::int64_t m, std::int64_t n) const { return m >= 0 && m < size_x && n >= 0 && n < size_y; }
  std::uint8_t at(std::int64_t m, std::int64_t n) const { return costs[n * size_x + m]; }
};

// Bounds of a set of cells (inclusive).
struct CellBox {
  std::int64_t m_min = 0;
  std::int64_t m_max = -1;
  std::int64_t n_min = 0;
  std::int64_t n_max = -1;
};

}  // namespace pfield::costmap
