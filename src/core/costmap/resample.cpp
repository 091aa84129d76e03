#include "costmap/resample.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace pfield::costmap {
namespace {

constexpr int kUnknown = -1;
constexpr int kOccupied = 100;

// Source cells [lo, hi] (clipped to [0, extent - 1]) overlapped by the window interval [start, start + scale);
// false when none. Computed in doubles, so a window far from the map needs no integer conversion out of range.
bool overlapped(double start, double scale, std::int64_t extent, std::int64_t& lo, std::int64_t& hi) {
  const double first = std::max(std::floor(start), 0.0);
  const double last = std::min(std::ceil(start + scale) - 1.0, static_cast<double>(extent - 1));
  if (!(first <= last)) return false;
  lo = static_cast<std::int64_t>(first);
  hi = static_cast<std::int64_t>(last);
  return true;
}

}  // namespace

void resample_occupancy(const OccupancyView& source, const Window& window, std::int8_t* out) {
  struct Span {
    bool any = false;
    std::int64_t lo = 0, hi = 0;
  };
  std::vector<Span> columns(window.size_x);  // the same source columns for every row
  for (std::size_t i = 0; i < window.size_x; ++i) {
    Span& c = columns[i];
    c.any = overlapped(window.origin_u + static_cast<double>(i) * window.scale, window.scale, source.width, c.lo, c.hi);
  }
  for (std::size_t j = 0; j < window.size_y; ++j) {
    std::int8_t* row = out + j * window.size_x;
    std::fill(row, row + window.size_x, static_cast<std::int8_t>(kUnknown));
    Span rows;
    rows.any = overlapped(window.origin_v + static_cast<double>(j) * window.scale, window.scale, source.height,
                          rows.lo, rows.hi);
    if (!rows.any) continue;
    for (std::size_t i = 0; i < window.size_x; ++i) {
      const Span& c = columns[i];
      if (!c.any) continue;
      // the worst cell: occupied when the highest value is, else unknown when the lowest is, else the highest
      int lowest = kOccupied, highest = kUnknown;
      for (std::int64_t n = rows.lo; n <= rows.hi; ++n) {
        const std::int8_t* cells = source.data + n * source.width;
        for (std::int64_t m = c.lo; m <= c.hi; ++m) {
          lowest = std::min(lowest, static_cast<int>(cells[m]));
          highest = std::max(highest, static_cast<int>(cells[m]));
        }
      }
      const int value = highest >= kOccupied ? kOccupied : (lowest < 0 ? kUnknown : highest);
      row[i] = static_cast<std::int8_t>(value);
    }
  }
}

}  // namespace pfield::costmap
