// Every expression keeps the operand order of the numba kernels this replaced (issue 32), and Python's
// min/max tie rule (min(a, b) is a unless b < a), so the cover takes the same capsules and the depths and the
// centre come out with the same bits.
#include "robot/cover.hpp"

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <vector>

#include "math/vec3.hpp"

namespace pfield::robot {
namespace {

using math::dot;
using math::Vec3;

// m added to a capsule's bounding box and to the cell tests: rounding never leaves out a point the capsule contains
constexpr double kPad = 1e-9;
// sqrt(3) / 2: a cube's points lie within this many sides of its centre
constexpr double kHalfDiagonal = 0.8660254037844387;
constexpr std::int64_t kMaxCells = std::int64_t{1} << 27;

inline double min_of(double a, double b) { return b < a ? b : a; }
inline double max_of(double a, double b) { return b > a ? b : a; }

inline Vec3 row3(const double* rows, std::size_t i) { return {rows[3 * i], rows[3 * i + 1], rows[3 * i + 2]}; }

// One capsule as the containment test reads it: its start a, axis d = b - a, |d|^2 and radius.
struct Axis {
  Vec3 a;
  Vec3 d;
  double length2;
  double radius;
};

Axis axis_of(const CapsuleSet& capsules, std::size_t k) {
  const Vec3 a = row3(capsules.a, k), d = row3(capsules.b, k) - a;
  return {a, d, dot(d, d), capsules.radii[k]};
}

// t of the point of the segment nearest to a + q: clamp(q.d / |d|^2, 0, 1), 0 for a sphere.
inline double along(const Axis& axis, Vec3 q) {
  return axis.length2 == 0.0 ? 0.0 : min_of(max_of(dot(q, axis.d) / axis.length2, 0.0), 1.0);
}

// The containment test of cover.hpp, r2 = radius^2.
inline bool contains(const Axis& axis, double r2, Vec3 p) {
  const Vec3 q = p - axis.a;
  const Vec3 e = q - along(axis, q) * axis.d;
  return dot(e, e) <= r2;
}

// The points bucketed by cubes of side `cell` from the points' lower corner: those of cell
// c = ix + X (iy + Y iz) are ordered[starts[c] .. starts[c + 1]), in their input order.
struct Grid {
  double lower[3];
  std::int64_t dims[3];  // X, Y, Z
  double cell;
  std::vector<std::int64_t> starts;  // (cells + 1,)
  std::vector<Vec3> ordered;         // (points,)

  std::int64_t cells() const { return dims[0] * dims[1] * dims[2]; }
  std::int64_t row(std::int64_t iy, std::int64_t iz) const { return iy + dims[1] * iz; }  // a row of cells along x
};

Grid make_grid(const PointSet& points, double cell) {
  Grid grid;
  grid.cell = cell;
  const std::size_t n = points.count;
  for (int axis = 0; axis < 3; ++axis) {
    double low = points.xyz[axis], high = points.xyz[axis];
    for (std::size_t i = 1; i < n; ++i) {
      const double v = points.xyz[3 * i + axis];
      low = min_of(low, v);
      high = max_of(high, v);
    }
    grid.lower[axis] = low;
    const double span = (high - low) / cell;
    if (!(span < static_cast<double>(kMaxCells)))
      throw std::invalid_argument("greedy_cover: the grid has too many cells");
    grid.dims[axis] = static_cast<std::int64_t>(span) + 1;
  }
  if (grid.dims[0] * grid.dims[1] > kMaxCells || grid.cells() > kMaxCells)
    throw std::invalid_argument("greedy_cover: the grid has too many cells");
  std::vector<std::int64_t> cell_of(n);
  for (std::size_t i = 0; i < n; ++i) {
    std::int64_t index[3];
    for (int axis = 0; axis < 3; ++axis) {
      const std::int64_t k = static_cast<std::int64_t>((points.xyz[3 * i + axis] - grid.lower[axis]) / cell);
      index[axis] = k < grid.dims[axis] - 1 ? k : grid.dims[axis] - 1;
    }
    cell_of[i] = index[0] + grid.dims[0] * (index[1] + grid.dims[1] * index[2]);
  }
  grid.starts.assign(static_cast<std::size_t>(grid.cells()) + 1, 0);
  for (std::size_t i = 0; i < n; ++i) ++grid.starts[cell_of[i] + 1];
  for (std::size_t c = 1; c < grid.starts.size(); ++c) grid.starts[c] += grid.starts[c - 1];
  grid.ordered.resize(n);
  std::vector<std::int64_t> fill(grid.starts.begin(), grid.starts.end() - 1);
  for (std::size_t i = 0; i < n; ++i) grid.ordered[fill[cell_of[i]]++] = row3(points.xyz, i);
  return grid;
}

// An inclusive range of cells on each axis (empty when lo > hi on some axis).
struct CellBox {
  std::int64_t lo[3];
  std::int64_t hi[3];
};

// The cells of a capsule's bounding box grown by its radius and kPad. The floors are clamped in double before
// the conversion (to [0, dims] below and [-1, dims - 1] above): the same box for any capsule near the points,
// and no out-of-range conversion for one far from them.
CellBox cell_box(const Axis& axis, Vec3 b, const Grid& grid) {
  const double reach = axis.radius + kPad;
  const double a3[3] = {axis.a.x, axis.a.y, axis.a.z}, b3[3] = {b.x, b.y, b.z};
  CellBox box;
  for (int i = 0; i < 3; ++i) {
    const double top = static_cast<double>(grid.dims[i]);
    const double lo = std::floor((min_of(a3[i], b3[i]) - reach - grid.lower[i]) / grid.cell);
    const double hi = std::floor((max_of(a3[i], b3[i]) + reach - grid.lower[i]) / grid.cell);
    box.lo[i] = static_cast<std::int64_t>(min_of(max_of(lo, 0.0), top));
    box.hi[i] = static_cast<std::int64_t>(max_of(min_of(hi, top - 1.0), -1.0));
  }
  return box;
}

// Summed-volume table (X + 1, Y + 1, Z + 1) of the points per cell: any box's count in O(1).
struct BoxSums {
  std::int64_t sx, sy, sz;  // strides of x, y, z
  std::vector<std::int64_t> table;

  explicit BoxSums(const Grid& grid)
      : sx((grid.dims[1] + 1) * (grid.dims[2] + 1)),
        sy(grid.dims[2] + 1),
        sz(1),
        table(static_cast<std::size_t>((grid.dims[0] + 1) * sx), 0) {
    for (std::int64_t iz = 0; iz < grid.dims[2]; ++iz)
      for (std::int64_t iy = 0; iy < grid.dims[1]; ++iy)
        for (std::int64_t ix = 0; ix < grid.dims[0]; ++ix) {
          const std::int64_t c = ix + grid.dims[0] * grid.row(iy, iz);
          at(ix + 1, iy + 1, iz + 1) = grid.starts[c + 1] - grid.starts[c] + at(ix, iy + 1, iz + 1) +
                                       at(ix + 1, iy, iz + 1) + at(ix + 1, iy + 1, iz) - at(ix, iy, iz + 1) -
                                       at(ix, iy + 1, iz) - at(ix + 1, iy, iz) + at(ix, iy, iz);
        }
  }
  std::int64_t& at(std::int64_t x, std::int64_t y, std::int64_t z) { return table[x * sx + y * sy + z * sz]; }
  std::int64_t get(std::int64_t x, std::int64_t y, std::int64_t z) const { return table[x * sx + y * sy + z * sz]; }

  std::int64_t count(const CellBox& b) const {
    const std::int64_t lx = b.lo[0], ly = b.lo[1], lz = b.lo[2];
    const std::int64_t hx = b.hi[0] + 1, hy = b.hi[1] + 1, hz = b.hi[2] + 1;
    if (lx >= hx || ly >= hy || lz >= hz) return 0;
    return get(hx, hy, hz) - get(lx, hy, hz) - get(hx, ly, hz) - get(hx, hy, lz) + get(lx, ly, hz) + get(lx, hy, lz) +
           get(hx, ly, lz) - get(lx, ly, lz);
  }
};

// Where cell (ix, iy, iz) lies for the capsule: 1 inside, -1 outside, both by more than kPad (so that `contains`
// says the same of every point in it: they lie within half a diagonal of its centre), 0 across its surface.
int cell_side(const Axis& axis, const Grid& grid, std::int64_t ix, std::int64_t iy, std::int64_t iz) {
  const double cell = grid.cell;
  const Vec3 centre{grid.lower[0] + (static_cast<double>(ix) + 0.5) * cell,
                    grid.lower[1] + (static_cast<double>(iy) + 0.5) * cell,
                    grid.lower[2] + (static_cast<double>(iz) + 0.5) * cell};
  const Vec3 q = centre - axis.a;
  const Vec3 e = q - along(axis, q) * axis.d;
  const double distance = std::sqrt(dot(e, e));
  const double half = kHalfDiagonal * cell;
  if (distance + half <= axis.radius - kPad) return 1;
  if (distance - half > axis.radius + kPad) return -1;
  return 0;
}

// The uncovered points: a flag per cell-ordered point and how many are left per cell and per row of cells.
struct Uncovered {
  std::vector<unsigned char> flag;
  std::vector<std::int64_t> cell_left;
  std::vector<std::int64_t> row_left;

  explicit Uncovered(const Grid& grid) : flag(grid.ordered.size(), 1), cell_left(grid.starts.size() - 1) {
    for (std::size_t c = 0; c < cell_left.size(); ++c) cell_left[c] = grid.starts[c + 1] - grid.starts[c];
    row_left.assign(static_cast<std::size_t>(grid.dims[1] * grid.dims[2]), 0);
    const auto x_cells = static_cast<std::size_t>(grid.dims[0]);
    for (std::size_t c = 0; c < cell_left.size(); ++c) row_left[c / x_cells] += cell_left[c];
  }
};

// One look at a candidate, in three steps that share their work (nothing changes the uncovered points between
// them): bound() finds the cells of its box that still hold uncovered points and lie not outside it, and sums
// their points (an upper bound of its gain); count() counts the uncovered points it contains in those cells (a cell
// inside counts whole, only the cells across its surface test their points); claim() marks them covered.
//
// A candidate is looked at many times (the UR5's 18 links: 363 000 looks at 126 000 candidates, 298 taken); cells
// only ever lose points: the cells found at its first look are kept (with their side, up to kKeptCells over all
// candidates), and a later look sums them, dropping those emptied since, without a square root. The sums, and so
// the keys and the choices, are the same as those of a fresh scan of the box.
class Scan {
 public:
  explicit Scan(std::size_t candidates) : kept_(candidates), is_kept_(candidates, 0) {}

  std::int64_t bound(std::int64_t k, const Axis& axis, const CellBox& box, const Grid& grid, const Uncovered& left) {
    std::int64_t sum = 0;
    if (is_kept_[k]) {
      cells_ = &kept_[k];
      std::size_t live = 0;
      for (const Visit& visit : *cells_) {
        if (left.cell_left[visit.cell] == 0) continue;
        sum += left.cell_left[visit.cell];
        (*cells_)[live++] = visit;
      }
      kept_cells_ -= cells_->size() - live;
      cells_->resize(live);
      return sum;
    }
    scratch_.clear();
    for (std::int64_t iz = box.lo[2]; iz <= box.hi[2]; ++iz)
      for (std::int64_t iy = box.lo[1]; iy <= box.hi[1]; ++iy) {
        const std::int64_t row = grid.row(iy, iz);
        if (left.row_left[row] == 0) continue;
        for (std::int64_t ix = box.lo[0]; ix <= box.hi[0]; ++ix) {
          const std::int64_t c = ix + grid.dims[0] * row;
          if (left.cell_left[c] == 0) continue;
          const int side = cell_side(axis, grid, ix, iy, iz);
          if (side < 0) continue;
          sum += left.cell_left[c];
          scratch_.push_back({static_cast<std::int32_t>(c), static_cast<std::int32_t>(row), side > 0});
        }
      }
    cells_ = &scratch_;
    if (kept_cells_ + scratch_.size() <= kKeptCells) {
      kept_[k].assign(scratch_.begin(), scratch_.end());
      kept_cells_ += scratch_.size();
      is_kept_[k] = 1;
      cells_ = &kept_[k];
    }
    return sum;
  }

  // After bound() of the same candidate.
  std::int64_t count(const Axis& axis, const Grid& grid, const Uncovered& left) {
    const double r2 = axis.radius * axis.radius;
    matched_.clear();
    std::int64_t sum = 0;
    for (const Visit& visit : *cells_) {
      if (visit.inside) {
        sum += left.cell_left[visit.cell];
        continue;
      }
      for (std::int64_t m = grid.starts[visit.cell]; m < grid.starts[visit.cell + 1]; ++m)
        if (left.flag[m] && contains(axis, r2, grid.ordered[m])) matched_.push_back({m, visit.cell, visit.row});
    }
    return sum + static_cast<std::int64_t>(matched_.size());
  }

  // After count() of the same candidate: marks what it counted covered, returns how many.
  std::int64_t claim(const Grid& grid, Uncovered& left) const {
    std::int64_t sum = static_cast<std::int64_t>(matched_.size());
    for (const Visit& visit : *cells_) {
      if (!visit.inside) continue;
      const std::int64_t c = visit.cell;
      for (std::int64_t m = grid.starts[c]; m < grid.starts[c + 1]; ++m) left.flag[m] = 0;
      sum += left.cell_left[c];
      left.row_left[visit.row] -= left.cell_left[c];
      left.cell_left[c] = 0;
    }
    for (const Match& match : matched_) {
      left.flag[match.point] = 0;
      --left.cell_left[match.cell];
      --left.row_left[match.row];
    }
    return sum;
  }

 private:
  static constexpr std::size_t kKeptCells = std::size_t{1} << 22;  // 48 MB at most (12 bytes a cell)

  struct Visit {
    std::int32_t cell;  // < kMaxCells
    std::int32_t row;
    bool inside;  // the whole cell lies inside the capsule (else across its surface)
  };
  struct Match {  // a point of a cell across the surface, which the capsule contains
    std::int64_t point;
    std::int32_t cell;
    std::int32_t row;
  };

  std::vector<std::vector<Visit>> kept_;  // by candidate
  std::vector<unsigned char> is_kept_;
  std::size_t kept_cells_ = 0;
  std::vector<Visit> scratch_;            // the cells of a candidate not kept
  std::vector<Visit>* cells_ = nullptr;   // the cells of the candidate being looked at
  std::vector<Match> matched_;
};

// A candidate in the heap: its index and its key, an upper bound of its gain.
struct Entry {
  std::int64_t key;
  std::int64_t index;
};

// e comes before f: a larger key, or an equal key and a lower index (the greedy's tie rule).
inline bool before(const Entry& e, const Entry& f) { return e.key > f.key || (e.key == f.key && e.index < f.index); }

// A binary max-heap of the candidates in `before` order (the keys live in the slots: no indirection).
struct Heap {
  std::vector<Entry> slots;  // heap-ordered in [0, size)
  std::size_t size;

  explicit Heap(const std::vector<std::int64_t>& keys) : slots(keys.size()), size(keys.size()) {
    for (std::size_t i = 0; i < size; ++i) slots[i] = {keys[i], static_cast<std::int64_t>(i)};
    for (std::size_t slot = size / 2; slot-- > 0;) sift_down(slot);
  }
  const Entry& top() const { return slots[0]; }
  // The runner-up: the root's larger child (nullptr when the root is alone).
  const Entry* rival() const {
    if (size < 2) return nullptr;
    return size == 2 || before(slots[1], slots[2]) ? &slots[1] : &slots[2];
  }
  // The root's key becomes min(key, its key), and the root sinks to its place.
  void lower_top(std::int64_t key) {
    slots[0].key = key < slots[0].key ? key : slots[0].key;
    sift_down(0);
  }
  void pop() {
    --size;
    slots[0] = slots[size];
    sift_down(0);
  }
  void sift_down(std::size_t slot) {
    while (true) {
      std::size_t top = slot;
      const std::size_t l = 2 * slot + 1, r = 2 * slot + 2;
      if (l < size && before(slots[l], slots[top])) top = l;
      if (r < size && before(slots[r], slots[top])) top = r;
      if (top == slot) return;
      const Entry held = slots[slot];
      slots[slot] = slots[top];
      slots[top] = held;
      slot = top;
    }
  }
};

bool finite_rows(const double* values, std::size_t count) {
  bool finite = true;
  for (std::size_t i = 0; i < count; ++i) finite &= std::isfinite(values[i]);
  return finite;
}

}  // namespace

void coverage(const CapsuleSet& capsules, const PointSet& points, bool* covered) {
  for (std::size_t k = 0; k < capsules.count; ++k) {
    const Axis axis = axis_of(capsules, k);
    const double r2 = axis.radius * axis.radius;
    bool* row = covered + k * points.count;
    for (std::size_t n = 0; n < points.count; ++n) row[n] = contains(axis, r2, row3(points.xyz, n));
  }
}

std::vector<std::int64_t> greedy_cover(const CapsuleSet& capsules, const PointSet& points, double cell) {
  if (!finite_rows(capsules.a, 3 * capsules.count) || !finite_rows(capsules.b, 3 * capsules.count) ||
      !finite_rows(capsules.radii, capsules.count) || !finite_rows(points.xyz, 3 * points.count))
    throw std::invalid_argument("greedy_cover: capsules and points must be finite");
  if (!(cell > 0.0) || !std::isfinite(cell)) throw std::invalid_argument("greedy_cover: cell must be finite and > 0");
  std::vector<std::int64_t> chosen;
  if (points.count == 0) return chosen;
  const Grid grid = make_grid(points, cell);
  const BoxSums sums(grid);
  std::vector<Axis> axes(capsules.count);
  std::vector<CellBox> boxes(capsules.count);
  std::vector<std::int64_t> first(capsules.count);
  for (std::size_t k = 0; k < capsules.count; ++k) {
    axes[k] = axis_of(capsules, k);
    boxes[k] = cell_box(axes[k], row3(capsules.b, k), grid);
    first[k] = sums.count(boxes[k]);
  }
  Uncovered left(grid);
  Heap heap(first);
  Scan scan(capsules.count);
  std::int64_t remaining = static_cast<std::int64_t>(points.count);
  while (remaining > 0 && heap.size > 0) {
    const std::int64_t k = heap.top().index;
    const Entry* rival = heap.rival();
    std::int64_t value = scan.bound(k, axes[k], boxes[k], grid, left);
    if (rival == nullptr || before({value, k}, *rival)) {  // it may still win: count it
      value = scan.count(axes[k], grid, left);
      if (rival == nullptr || before({value, k}, *rival)) {  // the argmax: every key bounds its candidate's gain
        if (value == 0) break;  // no candidate contains the points left (only a caller's error)
        remaining -= scan.claim(grid, left);
        chosen.push_back(k);
        heap.pop();
        continue;
      }
    }
    heap.lower_top(value);
  }
  return chosen;
}

namespace {

// depth[n] = min(depth[n], |p_n - (a + t d)| - r) over the points, t as `along`. `Segment` says whether |d|^2 != 0
// (a template parameter: the loop has no branch on it, and GCC vectorises it).
template <bool Segment>
void deepen(const Axis& axis, const double* __restrict points, std::size_t count, double* __restrict depth) {
  for (std::size_t n = 0; n < count; ++n) {
    const Vec3 p = row3(points, n);
    const double t = Segment ? min_of(max_of(dot(p - axis.a, axis.d) / axis.length2, 0.0), 1.0) : 0.0;
    const Vec3 e = p - (axis.a + t * axis.d);  // this kernel's order (not `contains`'): the same bits as before
    depth[n] = min_of(depth[n], std::sqrt(dot(e, e)) - axis.radius);
  }
}

}  // namespace

void min_depth(const CapsuleSet& capsules, const PointSet& points, std::int64_t skip, double* depth) {
  for (std::size_t n = 0; n < points.count; ++n) depth[n] = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < capsules.count; ++k) {
    if (static_cast<std::int64_t>(k) == skip) continue;
    const Axis axis = axis_of(capsules, k);
    if (axis.length2 == 0.0)
      deepen<false>(axis, points.xyz, points.count, depth);
    else
      deepen<true>(axis, points.xyz, points.count, depth);
  }
}

namespace {

// Whether p satisfies every facet n.x + c <= tolerance, n.x summed x, y, z then c.
bool within(const Facets& facets, Vec3 p, double tolerance) {
  for (std::size_t f = 0; f < facets.count; ++f) {
    const double* e = facets.equations + 4 * f;
    if (e[0] * p.x + e[1] * p.y + e[2] * p.z + e[3] > tolerance) return false;
  }
  return true;
}

}  // namespace

void inside_hull(const Facets& hull, const Facets& inner, const PointSet& points, double tolerance, bool* inside) {
  for (std::size_t n = 0; n < points.count; ++n) {
    const Vec3 p = row3(points.xyz, n);
    inside[n] = within(inner, p, 0.0) || within(hull, p, tolerance);
  }
}

namespace {

// The first of `count` points (count, dimension) farthest from `centre` (as numpy's argmax of the norms: the
// distance is sqrt(distance2), its squares summed over the axes in order). The square root is monotonic: a point
// whose distance2 is no larger than the farthest one's cannot lie farther, and its root is not taken. `Fixed`:
// the dimension when known at compile time (0: `dimension`).
template <std::size_t Fixed>
std::size_t farthest_point(const double* points, std::size_t count, std::size_t dimension, const double* centre) {
  const std::size_t width = Fixed > 0 ? Fixed : dimension;
  std::size_t far = 0;
  double farthest = -1.0, farthest2 = -1.0;
  for (std::size_t n = 0; n < count; ++n) {
    double distance2 = 0.0;
    for (std::size_t axis = 0; axis < width; ++axis) {
      const double offset = points[n * width + axis] - centre[axis];
      distance2 += offset * offset;
    }
    if (!(distance2 > farthest2)) continue;
    const double distance = std::sqrt(distance2);
    if (distance > farthest) {
      far = n;
      farthest = distance;
      farthest2 = distance2;
    }
  }
  return far;
}

}  // namespace

void enclosing_circle(const double* points, std::size_t count, std::size_t dimension, int iterations,
                      double* centre) {
  for (std::size_t axis = 0; axis < dimension; ++axis) {
    double low = points[axis], high = points[axis];
    for (std::size_t n = 1; n < count; ++n) {
      low = min_of(low, points[n * dimension + axis]);
      high = max_of(high, points[n * dimension + axis]);
    }
    centre[axis] = 0.5 * (low + high);
  }
  for (int k = 1; k <= iterations; ++k) {
    const std::size_t far = dimension == 2   ? farthest_point<2>(points, count, dimension, centre)
                            : dimension == 3 ? farthest_point<3>(points, count, dimension, centre)
                                             : farthest_point<0>(points, count, dimension, centre);
    const double step = static_cast<double>(k + 1);
    for (std::size_t axis = 0; axis < dimension; ++axis)
      centre[axis] = centre[axis] + (points[far * dimension + axis] - centre[axis]) / step;
  }
}

}  // namespace pfield::robot
