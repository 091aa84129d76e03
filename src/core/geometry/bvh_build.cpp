#include "geometry/bvh_build.hpp"

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <vector>

namespace pfield::geometry {
namespace {

struct Pending {
  std::size_t first, size;
  std::int64_t parent;
  int slot;  // 0: the parent's left child, 1: its right
};

}  // namespace

Bvh build_bvh(const double* centroids, const double* lows, const double* highs, std::size_t count,
              std::size_t leaf_size) {
  Bvh bvh;
  bvh.order.resize(count);
  std::iota(bvh.order.begin(), bvh.order.end(), std::int64_t{0});
  std::vector<Pending> pending{{0, count, -1, 0}};
  std::vector<std::int64_t> sorted;
  while (!pending.empty()) {
    const Pending task = pending.back();
    pending.pop_back();
    const auto index = static_cast<std::int64_t>(bvh.nodes.size() / 3);
    if (task.parent >= 0) bvh.nodes[3 * task.parent + task.slot] = index;
    const std::int64_t* members = bvh.order.data() + task.first;
    // numpy's min and max: the first of equal values stays (signed zeros included)
    for (int axis = 0; axis < 3; ++axis) {
      double lo = lows[3 * members[0] + axis], hi = highs[3 * members[0] + axis];
      for (std::size_t k = 1; k < task.size; ++k) {
        const double l = lows[3 * members[k] + axis], h = highs[3 * members[k] + axis];
        if (l < lo) lo = l;
        if (h > hi) hi = h;
      }
      bvh.lower.push_back(lo);
      bvh.upper.push_back(hi);
    }
    if (task.size <= leaf_size) {
      bvh.nodes.insert(bvh.nodes.end(),
                       {static_cast<std::int64_t>(task.first), static_cast<std::int64_t>(task.size), 1});
      continue;
    }
    bvh.nodes.insert(bvh.nodes.end(), {-1, -1, 0});
    int axis = 0;
    double widest = 0.0;
    for (int a = 0; a < 3; ++a) {
      double lo = centroids[3 * members[0] + a], hi = lo;
      for (std::size_t k = 1; k < task.size; ++k) {
        const double c = centroids[3 * members[k] + a];
        if (c < lo) lo = c;
        if (c > hi) hi = c;
      }
      if (a == 0 || hi - lo > widest) axis = a, widest = hi - lo;  // argmax: the first of equal spreads
    }
    sorted.assign(members, members + task.size);
    std::stable_sort(sorted.begin(), sorted.end(), [&](std::int64_t a, std::int64_t b) {
      return centroids[3 * a + axis] < centroids[3 * b + axis];
    });
    std::copy(sorted.begin(), sorted.end(), bvh.order.begin() + static_cast<std::ptrdiff_t>(task.first));
    const std::size_t half = task.size / 2;
    pending.push_back({task.first + half, task.size - half, index, 1});
    pending.push_back({task.first, half, index, 0});  // popped first: the left subtree is numbered first
  }
  return bvh;
}

}  // namespace pfield::geometry
