// Bindings of the link-fitting cover (pfield.robot._cover, used by pfield.robot._fit): a thin list of defs over
// robot/cover.hpp. Capsules cross as their ends a, b (K, 3) and radii (K,), read in place.
#include <nanobind/nanobind.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "python/arrays.hpp"
#include "robot/cover.hpp"

namespace pfield::python {
namespace {

using namespace nb::literals;

robot::CapsuleSet capsule_set(const Rows<3>& a, const Rows<3>& b, const Vector& radii) {
  const std::size_t count = a.shape(0);
  if (b.shape(0) != count || radii.shape(0) != count)
    throw std::invalid_argument("capsules: a (K, 3), b (K, 3) and radii (K,) differ in length");
  return {a.data(), b.data(), radii.data(), count};
}

robot::PointSet point_set(const Rows<3>& points) { return {points.data(), points.shape(0)}; }

}  // namespace

void bind_cover(nb::module_& m) {
  m.doc() = "Covering points by capsules for fitting a link's primitives (pfield.robot._cover's compiled core).";

  m.def(
      "coverage",
      [](const Rows<3>& a, const Rows<3>& b, const Vector& radii, const Rows<3>& points) {
        const robot::CapsuleSet capsules = capsule_set(a, b, radii);
        return filled_array<bool>({capsules.count, points.shape(0)},
                                  [&](bool* out) { robot::coverage(capsules, point_set(points), out); });
      },
      "a"_a, "b"_a, "radii"_a, "points"_a, "(K, N) booleans: capsule k (segment a_k-b_k, radius r_k) contains point n.");

  m.def(
      "greedy_cover",
      [](const Rows<3>& a, const Rows<3>& b, const Vector& radii, const Rows<3>& points, double cell) {
        const robot::CapsuleSet capsules = capsule_set(a, b, radii);
        std::vector<std::int64_t> chosen;
        {
          nb::gil_scoped_release release;
          chosen = robot::greedy_cover(capsules, point_set(points), cell);
        }
        auto [picked, out] = new_array_of<std::int64_t>({chosen.size()});
        std::copy(chosen.begin(), chosen.end(), out);
        return picked;
      },
      "a"_a, "b"_a, "radii"_a, "points"_a, "cell"_a,
      "Indices of the capsules Chvatal's greedy set cover takes to contain every point, in taking order (ties to\n"
      "the lowest index); cell: the side (m) of the grid's cubes. Every point must lie in some capsule.");

  m.def(
      "min_depth",
      [](const Rows<3>& a, const Rows<3>& b, const Vector& radii, const Rows<3>& points, std::int64_t skip) {
        const robot::CapsuleSet capsules = capsule_set(a, b, radii);
        return filled_array({points.shape(0)},
                            [&](double* out) { robot::min_depth(capsules, point_set(points), skip, out); });
      },
      "a"_a, "b"_a, "radii"_a, "points"_a, "skip"_a,
      "(N,): min over capsules k != skip of dist(point, segment a_k-b_k) - r_k (<= 0: inside their union; +inf\n"
      "when no capsule is left; skip = -1 skips none).");

  m.def(
      "inside_hull",
      [](const Rows<4>& equations, const Rows<4>& inner, const Rows<3>& points, double tolerance) {
        return filled_array<bool>({points.shape(0)}, [&](bool* out) {
          robot::inside_hull({equations.data(), equations.shape(0)}, {inner.data(), inner.shape(0)}, point_set(points),
                             tolerance, out);
        });
      },
      "equations"_a, "inner"_a, "points"_a, "tolerance"_a,
      "(N,) booleans: the point satisfies every facet n.x + c <= tolerance of a convex hull (equations (F, 4),\n"
      "outward unit normals); inner: the facets of a polytope inside the hull, whose points need no other test.");

  m.def(
      "enclosing_circle",
      [](const Matrix& points, int iterations) {
        const std::size_t count = points.shape(0), dimension = points.shape(1);
        if (count == 0) throw std::invalid_argument("enclosing_circle: needs at least one point");
        return filled_array({dimension}, [&](double* out) {
          robot::enclosing_circle(points.data(), count, dimension, iterations, out);
        });
      },
      "points"_a, "iterations"_a,
      "Approximate centre (D,) of the smallest ball enclosing points (N, D): Badoiu-Clarkson's iterations from the\n"
      "bounding box's centre.");
}

}  // namespace pfield::python
