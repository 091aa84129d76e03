#include "geometry/packed.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace pfield::geometry {

std::string check_packed(const PackedView& packed) {
  const auto nodes = static_cast<std::int64_t>(packed.node_count);
  const auto triangles = static_cast<std::int64_t>(packed.triangle_count);
  for (std::size_t i = 0; i < packed.obstacle_count; ++i)
    if (packed.kinds[i] < 0 || packed.kinds[i] >= kKindCount)
      return "kinds: obstacle " + std::to_string(i) + " has code " + std::to_string(packed.kinds[i]) +
             ", which is no shape (pfield._core.geometry.Kind: 0 to " + std::to_string(kKindCount - 1) + ")";
  std::vector<std::int64_t> depth(packed.node_count, 0);
  for (std::int64_t k = 0; k < nodes; ++k) {
    const std::int64_t* node = packed.node(k);
    if (node[2] == 1) {
      if (node[0] < 0 || node[1] < 0 || node[0] > triangles - node[1])
        return "bvh_nodes: leaf " + std::to_string(k) + " names triangles outside the " + std::to_string(triangles) +
               " packed";
      continue;
    }
    for (int side = 0; side < 2; ++side) {
      const std::int64_t child = node[side];
      if (child <= k || child >= nodes)
        return "bvh_nodes: node " + std::to_string(k) + " has child " + std::to_string(child) +
               " (children follow their parent and stay below " + std::to_string(nodes) + ")";
      if (depth[k] + 1 > depth[child]) depth[child] = depth[k] + 1;
    }
    if (depth[k] + 2 >= static_cast<std::int64_t>(kStackSize))
      return "bvh_nodes: a tree deeper than " + std::to_string(kStackSize - 2) + " levels";
  }
  for (std::size_t m = 0; m < packed.mesh_count; ++m) {
    const std::int64_t* row = packed.mesh(static_cast<std::int64_t>(m));
    if (row[0] < 0 || row[0] >= nodes)
      return "mesh_table: mesh " + std::to_string(m) + " has root " + std::to_string(row[0]) + " outside the " +
             std::to_string(nodes) + " nodes";
  }
  return {};
}

}  // namespace pfield::geometry
