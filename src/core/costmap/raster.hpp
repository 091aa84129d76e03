// Exact rasterisation of a closed polygon onto the cell grid (grid.hpp's cell coordinates).
//
// Rule: a cell is covered by the closed polygon P when P meets the half-open cell. That holds exactly when some
// edge of P (a closed segment) meets the cell, or when the cell's lower-left corner (m, n), which belongs to the
// cell, lies inside P: if no edge meets the cell, the cell is entirely inside or entirely outside P. Segment/cell
// tests use Liang-Barsky clipping (Liang & Barsky 1984) with strict bounds on the cell's open sides, so
// axis-aligned edges on cell boundaries and vertices on grid lines are classified exactly; crossing parameters
// of oblique edges are rounded doubles (this file is compiled without fused multiply-adds, CMakeLists.txt, so the
// same polygon gives the same cells on every build).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "costmap/grid.hpp"

namespace pfield::costmap {

// Largest bounding box (cells) a polygon may span: a 1 GiB mask (a 50 m footprint at 2 mm cells).
constexpr std::int64_t kMaxRasterCells = std::int64_t{1} << 30;
// Largest |coordinate| (cells) of a vertex: integers up to 2^52 are exact doubles.
constexpr double kMaxCellCoordinate = 4503599627370496.0;

// Covered cells in row-major order (n ascending, then m ascending).
struct Cells {
  std::vector<std::int64_t> m;
  std::vector<std::int64_t> n;
};

// Cells covered by the closed polygon with vertices (us[i], vs[i]) in cell coordinates, count >= 1 (a simple
// polygon: pfield.costmap.footprint validates). Throws std::invalid_argument for a vertex that is not finite
// or beyond kMaxCellCoordinate, or a polygon spanning more than kMaxRasterCells.
Cells rasterize_polygon(const double* us, const double* vs, std::size_t count);

// A footprint rasterised at each yaw of a search, as cell offsets from the base cell of the requested pose
// (compressed rows: yaw a's cells are dm/dn[start[a] .. start[a + 1]), in rasterize_polygon's order).
struct YawKernels {
  std::vector<std::size_t> start;  // (A + 1)
  std::vector<std::int64_t> dm;
  std::vector<std::int64_t> dn;
  std::vector<CellBox> box;        // (A): bounds of each yaw's offsets

  std::size_t yaw_count() const { return box.size(); }
  // Largest |offset| over every yaw (0 without yaws).
  std::int64_t reach() const;
};

// Placement of a footprint for rasterize_yaws: the vertices (m, robot frame), and the requested position's
// sub-cell offset (frac_u, frac_v) in [0, 1)^2 from its base cell, shared by every lattice position of a search.
struct FootprintPlacement {
  const double* px = nullptr;
  const double* py = nullptr;
  std::size_t count = 0;
  double frac_u = 0.0;
  double frac_v = 0.0;
  double inv_resolution = 1.0;  // cells per metre
};

// The footprint turned by each of the `yaw_count` yaws (rad) and rasterised: vertex k at yaw a lies at
// u = frac_u + (cos(a) px - sin(a) py) / resolution, v = frac_v + (sin(a) px + cos(a) py) / resolution.
YawKernels rasterize_yaws(const FootprintPlacement& footprint, const double* yaws, std::size_t yaw_count);

}  // namespace pfield::costmap
