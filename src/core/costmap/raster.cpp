#include "costmap/raster.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <stdexcept>

namespace pfield::costmap {
namespace {

// The polygon's bounding box of cells and a flag per cell of it (row-major, row r = n - n0).
struct Mask {
  std::int64_t m0 = 0;
  std::int64_t n0 = 0;
  std::int64_t width = 0;
  std::int64_t height = 0;
  std::vector<std::uint8_t> covered;

  bool in_box(std::int64_t m, std::int64_t n) const {
    return n - n0 >= 0 && n - n0 < height && m - m0 >= 0 && m - m0 < width;
  }
  std::uint8_t& at(std::int64_t m, std::int64_t n) { return covered[(n - n0) * width + (m - m0)]; }
};

std::int64_t floor_cell(double x) { return static_cast<std::int64_t>(std::floor(x)); }
std::int64_t ceil_cell(double x) { return static_cast<std::int64_t>(std::ceil(x)); }

// True when the closed segment A->B meets the half-open cell [m, m + 1) x [n, n + 1). The segment is
// clipped against the four sides: x >= m (closed), x < m + 1 (open), y >= n (closed), y < n + 1 (open);
// t in [lo, hi] survives, with lo or hi excluded when it came from an open side.
bool segment_meets_cell(double ax, double ay, double bx, double by, std::int64_t m, std::int64_t n) {
  double lo = 0.0, hi = 1.0;
  bool lo_strict = false, hi_strict = false;
  const double dx = bx - ax, dy = by - ay;
  const double sides[4] = {static_cast<double>(m), static_cast<double>(m + 1), static_cast<double>(n),
                           static_cast<double>(n + 1)};
  for (int side = 0; side < 4; ++side) {
    const double a = side < 2 ? ax : ay;
    const double d = side < 2 ? dx : dy;
    const double c = sides[side];
    const bool closed_lower = side == 0 || side == 2;  // a + t d >= c; else a + t d < c
    if (d == 0.0) {
      if ((closed_lower && a < c) || (!closed_lower && a >= c)) return false;
      continue;
    }
    const double t = (c - a) / d;
    const bool strict = !closed_lower;
    if (closed_lower == (d > 0.0)) {  // the side bounds t from below
      if (t > lo) {
        lo = t;
        lo_strict = strict;
      } else if (t == lo) {
        lo_strict = lo_strict || strict;
      }
    } else if (t < hi) {
      hi = t;
      hi_strict = strict;
    } else if (t == hi) {
      hi_strict = hi_strict || strict;
    }
  }
  return lo < hi || (lo == hi && !lo_strict && !hi_strict);
}

// Marks every cell the closed segment A->B meets, testing only the cells near the segment, row by row.
void mark_edge(Mask& mask, double ax, double ay, double bx, double by) {
  const std::int64_t n_lo = floor_cell(std::min(ay, by)), n_hi = floor_cell(std::max(ay, by));
  for (std::int64_t n = n_lo; n <= n_hi; ++n) {
    double xa = ax, xb = bx;  // the segment's x-range inside the closed strip n <= y <= n + 1
    if (ay != by) {
      const double t0 = (static_cast<double>(n) - ay) / (by - ay);
      const double t1 = (static_cast<double>(n + 1) - ay) / (by - ay);
      const double ta = std::min(std::max(std::min(t0, t1), 0.0), 1.0);
      const double tb = std::min(std::max(std::max(t0, t1), 0.0), 1.0);
      xa = ax + ta * (bx - ax);
      xb = ax + tb * (bx - ax);
    }
    const std::int64_t m_lo = floor_cell(std::min(xa, xb)) - 1, m_hi = floor_cell(std::max(xa, xb)) + 1;
    for (std::int64_t m = m_lo; m <= m_hi; ++m) {
      if (mask.in_box(m, n) && !mask.at(m, n) && segment_meets_cell(ax, ay, bx, by, m, n)) mask.at(m, n) = 1;
    }
  }
}

// Marks the cells whose lower-left corner lies inside the polygon: even-odd rule on each row line y = n.
void fill_interior(Mask& mask, const double* us, const double* vs, std::size_t count) {
  std::vector<double> crossings;
  crossings.reserve(count);
  for (std::int64_t n = mask.n0; n < mask.n0 + mask.height; ++n) {
    const double y = static_cast<double>(n);
    crossings.clear();
    for (std::size_t e = 0; e < count; ++e) {
      const std::size_t next = e + 1 == count ? 0 : e + 1;
      const double ax = us[e], ay = vs[e], bx = us[next], by = vs[next];
      if ((ay <= y && y < by) || (by <= y && y < ay)) crossings.push_back(ax + (y - ay) * (bx - ax) / (by - ay));
    }
    std::sort(crossings.begin(), crossings.end());
    for (std::size_t i = 0; i + 1 < crossings.size(); i += 2) {
      const std::int64_t lo = std::max(ceil_cell(crossings[i]), mask.m0);
      const std::int64_t hi = std::min(floor_cell(crossings[i + 1]), mask.m0 + mask.width - 1);
      for (std::int64_t m = lo; m <= hi; ++m) mask.at(m, n) = 1;
    }
  }
}

Mask bounding_mask(const double* us, const double* vs, std::size_t count) {
  double u_min = us[0], u_max = us[0], v_min = vs[0], v_max = vs[0];
  for (std::size_t k = 0; k < count; ++k) {
    if (!(std::abs(us[k]) <= kMaxCellCoordinate && std::abs(vs[k]) <= kMaxCellCoordinate))
      throw std::invalid_argument("polygon: vertices must be finite and within 2^52 cells of the grid's origin");
    u_min = std::min(u_min, us[k]);
    u_max = std::max(u_max, us[k]);
    v_min = std::min(v_min, vs[k]);
    v_max = std::max(v_max, vs[k]);
  }
  Mask mask;
  mask.m0 = floor_cell(u_min);
  mask.n0 = floor_cell(v_min);
  mask.width = floor_cell(u_max) - mask.m0 + 1;
  mask.height = floor_cell(v_max) - mask.n0 + 1;
  if (mask.width > kMaxRasterCells / mask.height)
    throw std::invalid_argument("polygon: spans more than 2^30 cells");
  mask.covered.assign(static_cast<std::size_t>(mask.width * mask.height), 0);
  return mask;
}

}  // namespace

Cells rasterize_polygon(const double* us, const double* vs, std::size_t count) {
  Cells cells;
  if (count == 0) return cells;
  Mask mask = bounding_mask(us, vs, count);
  for (std::size_t e = 0; e < count; ++e) {
    const std::size_t next = e + 1 == count ? 0 : e + 1;
    mark_edge(mask, us[e], vs[e], us[next], vs[next]);
  }
  fill_interior(mask, us, vs, count);
  for (std::int64_t r = 0; r < mask.height; ++r) {
    for (std::int64_t c = 0; c < mask.width; ++c) {
      if (mask.covered[r * mask.width + c]) {
        cells.m.push_back(mask.m0 + c);
        cells.n.push_back(mask.n0 + r);
      }
    }
  }
  return cells;
}

std::int64_t YawKernels::reach() const {
  std::int64_t reach = 0;
  for (const CellBox& b : box) {
    for (std::int64_t bound : {b.m_min, b.m_max, b.n_min, b.n_max}) reach = std::max(reach, std::abs(bound));
  }
  return reach;
}

YawKernels rasterize_yaws(const FootprintPlacement& footprint, const double* yaws, std::size_t yaw_count) {
  YawKernels kernels;
  kernels.start.assign(1, 0);
  kernels.box.reserve(yaw_count);
  std::vector<double> us(footprint.count), vs(footprint.count);
  for (std::size_t a = 0; a < yaw_count; ++a) {
    const double c = std::cos(yaws[a]), s = std::sin(yaws[a]);
    for (std::size_t k = 0; k < footprint.count; ++k) {
      const double x = footprint.px[k], y = footprint.py[k];
      us[k] = footprint.frac_u + (c * x - s * y) * footprint.inv_resolution;
      vs[k] = footprint.frac_v + (s * x + c * y) * footprint.inv_resolution;
    }
    Cells cells = rasterize_polygon(us.data(), vs.data(), footprint.count);
    CellBox box;
    if (!cells.m.empty()) {
      const auto [m_min, m_max] = std::minmax_element(cells.m.begin(), cells.m.end());
      box = {*m_min, *m_max, cells.n.front(), cells.n.back()};  // rows ascend
    }
    kernels.box.push_back(box);
    kernels.dm.insert(kernels.dm.end(), cells.m.begin(), cells.m.end());
    kernels.dn.insert(kernels.dn.end(), cells.n.begin(), cells.n.end());
    kernels.start.push_back(kernels.dm.size());
  }
  return kernels;
}

}  // namespace pfield::costmap
