// A packed obstacle set, read in place: the layout pfield.geometry.pack_obstacles builds (src/pfield/geometry/
// packed.py documents it; this view and that docstring describe the same arrays).
//
//   kinds (M,)              shape code per obstacle (Kind below)
//   rows (M, 16)            [0:3] world position of the shape centre, [3:12] the row-major rotation (local -> world),
//                           [12:15] sizes in the local frame, [15] the mesh index (-1 for primitives). Sizes: sphere
//                           (r, 0, 0); box half extents (hx, hy, hz); cylinder (r, h/2, 0); ellipsoid semi-axes
//                           (a, b, c); capsule (r, h/2, 0); mesh its scale (already applied to the triangles)
//   triangles (T, 3, 3)     vertices in the obstacle's local, scaled frame, every mesh in its BVH leaf order
//   pseudo_normals (T, 7, 3) unit normals of [face, edge ab, bc, ca, vertex a, b, c] (Baerentzen & Aanaes 2005)
//   bvh_lower, bvh_upper (K, 3)  node boxes
//   bvh_nodes (K, 3)        [left child | first triangle, right child | triangle count, is_leaf]; global indices
//   mesh_table (n, 5)       [root node, node count, first triangle, triangle count, watertight]
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "math/vec3.hpp"

namespace pfield::geometry {

// The shape codes of `kinds`: their one definition (bound as pfield._core.geometry.Kind, from which
// pfield.geometry.packed takes its codes). Every switch over a Kind lists each kind and has no default, and the
// build makes a missing case an error (-Werror=switch): a new kind cannot be taken for another in silence. Codes
// outside the enum never reach a switch: check_packed refuses them.
enum class Kind : std::int64_t { Sphere = 0, Box = 1, Cylinder = 2, Ellipsoid = 3, Capsule = 4, Mesh = 5 };
constexpr std::int64_t kKindCount = 6;  // one past the last Kind

constexpr std::size_t kRowWidth = 16;
constexpr std::size_t kPseudoNormals = 7;
constexpr std::size_t kMeshTableWidth = 5;
// Depth bound of the mesh query's traversal stack: a median-split tree over T triangles
// has depth ceil(log2 T), so 96 levels are far beyond any mesh; check_packed refuses deeper trees.
constexpr std::size_t kStackSize = 96;

using Vec3 = math::Vec3;  // the core's one 3-vector

// The outcome of every signed-distance query: d (m, negative inside) and the unit normal n = grad d (world frame
// for obstacles, the mesh's local frame for mesh_signed_distance).
struct SignedDistance {
  double distance = 0.0;
  Vec3 normal;
};

struct PackedView {
  const std::int64_t* kinds = nullptr;
  const double* rows = nullptr;
  std::size_t obstacle_count = 0;
  const double* triangles = nullptr;
  const double* pseudo_normals = nullptr;
  std::size_t triangle_count = 0;
  const double* bvh_lower = nullptr;
  const double* bvh_upper = nullptr;
  const std::int64_t* bvh_nodes = nullptr;
  std::size_t node_count = 0;
  const std::int64_t* mesh_table = nullptr;
  std::size_t mesh_count = 0;

  const double* row(std::size_t i) const { return rows + i * kRowWidth; }
  const std::int64_t* node(std::int64_t k) const { return bvh_nodes + 3 * k; }
  const std::int64_t* mesh(std::int64_t m) const { return mesh_table + kMeshTableWidth * m; }
};

// Empty when every kind is a Kind and every index the queries follow stays inside its array (mesh roots and node
// counts, children, leaf triangle ranges) and every tree is shallower than kStackSize; otherwise what is wrong, for
// the binding's ValueError. Children must come after their parent (depth-first order, as pack_obstacles stores
// them), which also rules out cycles. Mesh indices in rows are checked per query (NaN out).
std::string check_packed(const PackedView& packed);

}  // namespace pfield::geometry
