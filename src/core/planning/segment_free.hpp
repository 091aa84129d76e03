// The segment-free test of the planners: is every sampled state on the straight segment a -> b valid? One
// sampling order for both users:
//
//   * the global search's edges (planning/rrt.cpp, edge_valid): samples a + (i / steps)(b - a), i = 1 .. steps
//     (the end b included, the start assumed valid), steps = ceil(max_j |b_j - a_j| / resolution);
//   * the task-space loop's step (planning/task_space.cpp, segment_is_free): i = 1 .. 15 of steps = 16, the end
//     (the next waypoint) checked by the loop itself; there a Lipschitz certificate comes first (the signed
//     distance is 1-Lipschitz, so |b - a| < d(a) + d(b) with both positive proves the segment free without any
//     sample), which the joint space has no counterpart of (a capsule's clearance has no cheap Lipschitz constant
//     in q).
//
// The samples are visited coarse to fine — every largest power of two <= last, then the odd multiples of each
// smaller power down to 1 — so a blocked segment is usually refused after a few checks; the verdict is that of
// any order (all samples valid), so only the number of checks depends on it. This order is that of the numba
// engine's edge check it replaced (issue 32), whose `done` flags marked exactly the multiples of twice the stride
// (visited one level up): the states are checked in the same sequence, so a search counts the same checks as there.
#pragma once

#include <cstdint>

namespace pfield::planning {

// True when valid(t) holds for every t = i / steps, i = 1 .. last (last <= steps), visited coarse to fine;
// stops at the first sample that is not valid.
template <typename Valid>
bool samples_valid(std::int64_t steps, std::int64_t last, Valid&& valid) {
  std::int64_t top = 1;
  while (top * 2 <= last) top *= 2;
  for (std::int64_t stride = top; stride >= 1; stride /= 2) {
    // below the top level the even multiples of stride were visited one level up
    const std::int64_t first = stride, increment = stride == top ? stride : 2 * stride;
    for (std::int64_t i = first; i <= last; i += increment)
      if (!valid(static_cast<double>(i) / static_cast<double>(steps))) return false;
  }
  return true;
}

}  // namespace pfield::planning
