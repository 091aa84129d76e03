// Bindings of the signed distances (pfield.geometry): a thin list of defs over geometry/sdf.hpp. The packed
// obstacle set crosses as its eight arrays, in PackedObstacles' field order, read in place.
#include <nanobind/nanobind.h>
#include <nanobind/stl/tuple.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>

#include "geometry/bvh_build.hpp"
#include "geometry/packed.hpp"
#include "geometry/sdf.hpp"
#include "python/arrays.hpp"
#include "python/packed.hpp"

namespace pfield::python {
namespace {

using namespace nb::literals;
using geometry::PackedView;

// Points that are not all finite: pfield.geometry raises InvalidInput for them (the check runs here, in the loop's
// pass over the points, rather than as a separate NumPy pass before the call).
struct NonFinitePoints : std::invalid_argument {
  NonFinitePoints() : std::invalid_argument("points: must be finite (no NaN or inf)") {}
};

bool all_finite(const double* values, std::size_t count) {
  bool finite = true;
  for (std::size_t k = 0; k < count; ++k) finite &= std::isfinite(values[k]);
  return finite;
}

}  // namespace

void bind_geometry(nb::module_& m) {
  m.doc() = "Exact signed distances to packed obstacles (pfield.geometry's compiled core).";
  nb::exception<NonFinitePoints>(m, "NonFinitePoints", PyExc_ValueError);
  nb::enum_<geometry::Kind>(m, "Kind", nb::is_arithmetic(),
                            "Shape codes of a packed obstacle set's kinds (pfield.geometry.packed takes its codes "
                            "here).")
      .value("Sphere", geometry::Kind::Sphere)
      .value("Box", geometry::Kind::Box)
      .value("Cylinder", geometry::Kind::Cylinder)
      .value("Ellipsoid", geometry::Kind::Ellipsoid)
      .value("Capsule", geometry::Kind::Capsule)
      .value("Mesh", geometry::Kind::Mesh);

  m.def(
      "signed_distances",
      [](const Kinds& kinds, const Rows<16>& rows, const Triangles& triangles, const PseudoNormals& pseudo_normals,
         const Rows<3>& bvh_lower, const Rows<3>& bvh_upper, const Nodes& bvh_nodes, const MeshTable& mesh_table,
         const Rows<3>& points, double cutoff) {
        const PackedView packed =
            packed_view(kinds, rows, triangles, pseudo_normals, bvh_lower, bvh_upper, bvh_nodes, mesh_table);
        const std::size_t n = points.shape(0), count = packed.obstacle_count;
        auto [distances, d] = new_array({n, count});
        auto [normals, normal] = new_array({n, count, 3});
        {
          nb::gil_scoped_release release;
          if (!all_finite(points.data(), 3 * n)) throw NonFinitePoints();
          geometry::signed_distances(packed, points.data(), n, d, normal, cutoff);
        }
        return std::make_tuple(distances, normals);
      },
      "kinds"_a, "rows"_a, "triangles"_a, "pseudo_normals"_a, "bvh_lower"_a, "bvh_upper"_a, "bvh_nodes"_a,
      "mesh_table"_a, "points"_a, "cutoff"_a = std::numeric_limits<double>::infinity(),
      "Signed distances (N, M) and unit normals (N, M, 3) of N world points (N, 3) to the M packed obstacles;\n"
      "exact where d <= cutoff, beyond it possibly a lower bound > cutoff (obstacle_signed_distance_within).");

  // The distance-only batches: into `out` (the caller's, reused from call to call) without normals.
  m.def(
      "distances",
      [](const Kinds& kinds, const Rows<16>& rows, const Triangles& triangles, const PseudoNormals& pseudo_normals,
         const Rows<3>& bvh_lower, const Rows<3>& bvh_upper, const Nodes& bvh_nodes, const MeshTable& mesh_table,
         const Rows<3>& points, double cutoff, OutMatrix& out) {
        const PackedView packed =
            packed_view(kinds, rows, triangles, pseudo_normals, bvh_lower, bvh_upper, bvh_nodes, mesh_table);
        const std::size_t n = points.shape(0);
        if (out.shape(0) != n || out.shape(1) != packed.obstacle_count)
          throw std::invalid_argument("out: expected one row per point and one column per obstacle");
        nb::gil_scoped_release release;
        if (!all_finite(points.data(), 3 * n)) throw NonFinitePoints();
        geometry::signed_distances_only(packed, points.data(), n, out.data(), cutoff);
      },
      "kinds"_a, "rows"_a, "triangles"_a, "pseudo_normals"_a, "bvh_lower"_a, "bvh_upper"_a, "bvh_nodes"_a,
      "mesh_table"_a, "points"_a, "cutoff"_a, "out"_a.noconvert(),
      "signed_distances' distances (N, M) alone, into out (N, M), the same bits; no normals.");
  m.def(
      "nearest_distances",
      [](const Kinds& kinds, const Rows<16>& rows, const Triangles& triangles, const PseudoNormals& pseudo_normals,
         const Rows<3>& bvh_lower, const Rows<3>& bvh_upper, const Nodes& bvh_nodes, const MeshTable& mesh_table,
         const Rows<3>& points, OutVector& out) {
        const PackedView packed =
            packed_view(kinds, rows, triangles, pseudo_normals, bvh_lower, bvh_upper, bvh_nodes, mesh_table);
        const std::size_t n = points.shape(0);
        if (out.shape(0) != n) throw std::invalid_argument("out: expected one entry per point");
        nb::gil_scoped_release release;
        if (!all_finite(points.data(), 3 * n)) throw NonFinitePoints();
        const double* p = points.data();
        double* d = out.data();
        for (std::size_t k = 0; k < n; ++k)
          d[k] = geometry::min_distance(packed, {p[3 * k], p[3 * k + 1], p[3 * k + 2]});
      },
      "kinds"_a, "rows"_a, "triangles"_a, "pseudo_normals"_a, "bvh_lower"_a, "bvh_upper"_a, "bvh_nodes"_a,
      "mesh_table"_a, "points"_a, "out"_a.noconvert(),
      "Each point's smallest signed distance over the obstacles (min_signed_distance's, inf without obstacles), "
      "into out (N,).");

  m.def(
      "build_bvh",
      [](const Rows<3>& centroids, const Rows<3>& lows, const Rows<3>& highs, std::size_t leaf_size) {
        const std::size_t count = centroids.shape(0);
        if (lows.shape(0) != count || highs.shape(0) != count)
          throw std::invalid_argument("build_bvh: centroids, lows and highs differ in length");
        if (count == 0 || leaf_size == 0) throw std::invalid_argument("build_bvh: needs triangles and leaf_size >= 1");
        geometry::Bvh bvh;
        {
          nb::gil_scoped_release release;
          bvh = geometry::build_bvh(centroids.data(), lows.data(), highs.data(), count, leaf_size);
        }
        const std::size_t nodes = bvh.nodes.size() / 3;
        auto [order, o] = new_array_of<std::int64_t>({count});
        auto [lower, l] = new_array({nodes, 3});
        auto [upper, u] = new_array({nodes, 3});
        auto [tree, t] = new_array_of<std::int64_t>({nodes, 3});
        std::copy(bvh.order.begin(), bvh.order.end(), o);
        std::copy(bvh.lower.begin(), bvh.lower.end(), l);
        std::copy(bvh.upper.begin(), bvh.upper.end(), u);
        std::copy(bvh.nodes.begin(), bvh.nodes.end(), t);
        return std::make_tuple(order, lower, upper, tree);
      },
      "centroids"_a, "lows"_a, "highs"_a, "leaf_size"_a,
      "Median-split AABB tree over T triangles given by their centroids and box corners (T, 3) each:\n"
      "(order (T,), lower (K, 3), upper (K, 3), nodes (K, 3)), nodes in depth-first order, root 0.");
}

}  // namespace pfield::python
