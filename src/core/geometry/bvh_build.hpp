// The bounding-box hierarchy over a mesh's triangles that mesh_bvh.hpp queries (pfield.geometry._mesh_build).
//
// Median split: a node's triangles are ordered (stably) by their centroids along the axis where the centroids
// spread most (the lowest axis on ties) and split into halves, the first floor(n/2) to the left, until at most
// leaf_size remain. Nodes are numbered in depth-first order, left before right, so children follow their parent;
// each node's box is the exact union of its triangles' boxes. The tree's depth is ceil(log2(T / leaf_size)).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace pfield::geometry {

struct Bvh {
  std::vector<std::int64_t> order;  // (T,) the triangle at each leaf position: leaves index triangles[order]
  std::vector<double> lower;        // (K, 3)
  std::vector<double> upper;        // (K, 3)
  std::vector<std::int64_t> nodes;  // (K, 3): [left | first, right | count, is_leaf]; root 0, local indices
};

// centroids, lows, highs: (count, 3) row-major, per triangle; count >= 1 and leaf_size >= 1.
Bvh build_bvh(const double* centroids, const double* lows, const double* highs, std::size_t count,
              std::size_t leaf_size);

}  // namespace pfield::geometry
