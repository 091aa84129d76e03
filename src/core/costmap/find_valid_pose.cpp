#include "costmap/find_valid_pose.hpp"

#include <algorithm>
#include <vector>

namespace pfield::costmap {
namespace {

// The first candidate met of one kind.
struct Found {
  bool found = false;
  std::size_t position = 0;
  std::size_t yaw = 0;
  void keep(std::size_t p, std::size_t a) {
    if (!found) *this = {true, p, a};
  }
};

// Yaw a's cells; `offsets` (optional) holds every kernel cell's offset in the cost array.
FootprintCells cells_at_yaw(const YawKernels& kernels, std::size_t a, const std::int64_t* offsets = nullptr) {
  const std::size_t begin = kernels.start[a];
  return {kernels.dm.data() + begin, kernels.dn.data() + begin, kernels.start[a + 1] - begin, kernels.box[a],
          offsets != nullptr ? offsets + begin : nullptr};
}

// Bounds over every yaw: a base cell whose shifted box is inside the map is inside at every yaw.
CellBox union_box(const YawKernels& kernels) {
  if (kernels.box.empty()) return {};
  CellBox all = kernels.box.front();
  for (const CellBox& b : kernels.box) {
    all.m_min = std::min(all.m_min, b.m_min);
    all.m_max = std::max(all.m_max, b.m_max);
    all.n_min = std::min(all.n_min, b.n_min);
    all.n_max = std::max(all.n_max, b.n_max);
  }
  return all;
}

SearchResult answer(const SearchRequest& request, const YawKernels& kernels, const Candidates& candidates,
                    const Found& found) {
  const std::int64_t m = request.base_m + candidates.i[found.position];
  const std::int64_t n = request.base_n + candidates.j[found.position];
  const Placement placement = evaluate_placement(request.grid, m, n, cells_at_yaw(kernels, found.yaw), Scan::Full);
  return {placement.state, placement.cost, true, found.position, found.yaw};
}

// The prefilter at base cell (m, n); `all` bounds the footprint's cells at every yaw. (m, n) itself is tested
// too: a footprint that does not hold its centre may leave its base cell off the map.
bool lethal_at_every_yaw(const SearchRequest& request, const CellBox& all, std::int64_t m, std::int64_t n) {
  const CostGrid& grid = request.grid;
  return grid.contains(m, n) && grid.contains(m + all.m_min, n + all.n_min) &&
         grid.contains(m + all.m_max, n + all.n_max) &&
         request.lethal_distance[n * grid.size_x + m] <= request.prefilter_limit;
}

}  // namespace

SearchResult find_valid_pose(const SearchRequest& request, const YawKernels& kernels, const Candidates& candidates,
                             std::uint8_t* states) {
  const std::size_t yaw_count = kernels.yaw_count();
  const CellBox all = union_box(kernels);
  // every kernel cell as an offset in the cost array (placements inside the map read cells without bounds checks)
  std::vector<std::int64_t> offsets(kernels.dm.size());
  for (std::size_t k = 0; k < offsets.size(); ++k) offsets[k] = kernels.dn[k] * request.grid.size_x + kernels.dm[k];
  std::vector<bool> prefiltered;  // per position of the ring: LETHAL at every yaw
  Found best, unknown, outside;   // best: the first INSCRIBED (a FREE candidate answers at once)
  for (std::size_t r = 0; r < candidates.ring_count && !best.found; ++r) {
    const auto ring_begin = static_cast<std::size_t>(candidates.ring_start[r]);
    const auto ring_end = static_cast<std::size_t>(candidates.ring_start[r + 1]);
    prefiltered.assign(ring_end - ring_begin, false);
    for (std::size_t p = ring_begin; p < ring_end; ++p) {
      prefiltered[p - ring_begin] =
          lethal_at_every_yaw(request, all, request.base_m + candidates.i[p], request.base_n + candidates.j[p]);
    }
    for (std::size_t a = 0; a < yaw_count; ++a) {
      const FootprintCells cells = cells_at_yaw(kernels, a, offsets.data());
      for (std::size_t p = ring_begin; p < ring_end; ++p) {
        std::uint8_t& mark = states[p * yaw_count + a];
        if (prefiltered[p - ring_begin]) {
          mark = static_cast<std::uint8_t>(PoseState::Lethal);
          continue;
        }
        const Scan scan = unknown.found ? Scan::FreeOrInscribed : Scan::UntilSettled;
        const std::int64_t m = request.base_m + candidates.i[p], n = request.base_n + candidates.j[p];
        const PoseState state = evaluate_placement(request.grid, m, n, cells, scan).state;
        mark = static_cast<std::uint8_t>(state);
        if (state == PoseState::Free) return answer(request, kernels, candidates, {true, p, a});
        if (state == PoseState::Inscribed) {
          best.keep(p, a);
        } else if (state == PoseState::Unknown) {
          unknown.keep(p, a);
        } else if (state == PoseState::Outside) {
          outside.keep(p, a);
        }
      }
    }
  }
  for (const Found& fallback : {best, unknown, outside}) {
    if (fallback.found) return answer(request, kernels, candidates, fallback);
  }
  return {};
}

}  // namespace pfield::costmap
