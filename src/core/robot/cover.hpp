// Covering points by capsules, for fitting a link's primitives (pfield.robot._fit.fit_primitives): Chvátal's
// greedy set cover over a grid of the points, the dense coverage matrix, the depth in a union of capsules, the
// inside test of a convex hull and the Bădoiu–Clarkson enclosing ball. These replaced pfield.robot._cover's numba
// kernels (issue 32; the module now calls this core) with the same operations in the same order (no fused
// multiply-adds: CMakeLists.txt compiles src/core/robot with -ffp-contract=off), so every fit kept its primitives to
// the bit (tests/robot/test_core_cover.py holds digests of those kernels' outputs, beside NumPy oracles).
//
// Containment. A capsule (segment a-b, radius r) contains a point p when |q - t d|^2 <= r^2 with q = p - a,
// d = b - a and t = clamp(q.d / |d|^2, 0, 1) (t = 0 when |d|^2 = 0: a sphere). The cover and the coverage matrix
// evaluate that one expression, so a point on a surface is decided the same way by both.
//
// The cover (Chvátal, "A greedy heuristic for the set-covering problem", Math. Oper. Res. 4(3), 1979): repeatedly
// take the capsule containing the most points not yet covered, ties to the lowest index. A capsule's gain only
// shrinks as points get covered, so a gain counted earlier bounds the present one, and lazy evaluation (Minoux,
// "Accelerated greedy algorithms for maximizing submodular set functions", 1978) takes exactly the same capsules:
// the candidates sit in a binary max-heap ordered by (key, -index), every key an upper bound of its candidate's
// gain; the top candidate is counted, and taken when its count still comes before the runner-up's key, else its
// count becomes its key and it sinks. The first keys are the point counts of each capsule's bounding box (O(1)
// from a summed-volume table). A count visits only the grid cells of the capsule's bounding box that still hold
// uncovered points; a cell lying wholly inside the capsule counts whole, one wholly outside is skipped, and only
// the cells across its surface test their points. No (capsules x points) matrix is built: the UR5's
// 20 000-vertex force-torque sensor has ~30 000 candidates for ~25 000 points.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace pfield::robot {

// count capsules, rows read in place: segment a_k-b_k with radius radii[k] (a_k == b_k: a sphere).
struct CapsuleSet {
  const double* a = nullptr;      // (count, 3)
  const double* b = nullptr;      // (count, 3)
  const double* radii = nullptr;  // (count,)
  std::size_t count = 0;
};

// count points in 3D, rows read in place.
struct PointSet {
  const double* xyz = nullptr;  // (count, 3)
  std::size_t count = 0;
};

// Half-spaces n.x + c <= 0 of a convex polytope, rows (n_x, n_y, n_z, c) with outward unit normals
// (scipy.spatial.ConvexHull.equations).
struct Facets {
  const double* equations = nullptr;  // (count, 4)
  std::size_t count = 0;
};

// covered[k * points.count + n]: capsule k contains point n (the containment test above).
void coverage(const CapsuleSet& capsules, const PointSet& points, bool* covered);

// The capsules the greedy cover takes to contain every point, in taking order; `cell` (m, > 0) is the side of
// the grid's cubes (pfield.robot._cover.cell_side). Stops early (leaving points uncovered) only when no capsule
// contains the points left. Throws std::invalid_argument for non-finite capsules, points or cell, a cell <= 0, or
// a grid of more than 2^27 cells.
std::vector<std::int64_t> greedy_cover(const CapsuleSet& capsules, const PointSet& points, double cell);

// depth[n] = min over capsules k != skip of |p_n - segment a_k-b_k| - r_k (<= 0: inside their union; +inf when
// no capsule is left). skip = -1 skips none.
void min_depth(const CapsuleSet& capsules, const PointSet& points, std::int64_t skip, double* depth);

// inside[n]: point n satisfies every facet n.x + c <= tolerance of `hull`. `inner` holds the facets of a polytope
// inside the hull with fewer facets (the hull of some of its vertices): a point inside it (tolerance 0) is inside
// the hull without testing the hull's facets (the UR5's force-torque sensor: 8184 facets, 500 inner).
void inside_hull(const Facets& hull, const Facets& inner, const PointSet& points, double tolerance, bool* inside);

// Approximate centre (dimension,) of the smallest ball enclosing `count` points (count, dimension), count >= 1:
// Bădoiu and Clarkson ("Smaller core-sets for balls", SODA 2003), c <- c + (p_far - c) / (k + 1) for
// k = 1 .. iterations, from the centre of the bounding box; p_far is the first point farthest from c.
void enclosing_circle(const double* points, std::size_t count, std::size_t dimension, int iterations,
                      double* centre);

}  // namespace pfield::robot
