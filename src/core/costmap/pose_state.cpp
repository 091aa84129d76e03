#include "costmap/pose_state.hpp"

#include <algorithm>

namespace pfield::costmap {
namespace {

// What the cells scanned so far hold.
struct Tally {
  bool outside = false;
  bool lethal = false;
  bool unknown = false;
  bool inscribed = false;
  std::int64_t total = 0;

  PoseState state() const {
    if (outside) return PoseState::Outside;
    if (lethal) return PoseState::Lethal;
    if (unknown) return PoseState::Unknown;
    if (inscribed) return PoseState::Inscribed;
    return PoseState::Free;
  }
};

enum class Next { Continue, Stop, Reject };

// Adds one in-map cell; whether the scan goes on. Inside the map nothing outranks LETHAL, so UntilSettled stops
// there; with cells off the map it goes on looking for an outside one.
Next add_cell(Tally& tally, std::uint8_t value, Scan scan, bool inside) {
  tally.total += value;
  if (value >= kLethalObstacle && scan == Scan::FreeOrInscribed) return Next::Reject;
  if (value == kLethalObstacle) {
    tally.lethal = true;
    if (inside && scan == Scan::UntilSettled) return Next::Stop;
  } else if (value == kNoInformation) {
    tally.unknown = true;
  } else if (value == kInscribedInflatedObstacle) {
    tally.inscribed = true;
  }
  return Next::Continue;
}

}  // namespace

Placement evaluate_placement(const CostGrid& grid, std::int64_t m, std::int64_t n, const FootprintCells& cells,
                             Scan scan) {
  const CellBox& b = cells.box;
  Tally tally;
  if (grid.contains(m + b.m_min, n + b.n_min) && grid.contains(m + b.m_max, n + b.n_max)) {
    const std::int64_t base = n * grid.size_x + m;  // every cell is in the map: no bounds to check
    for (std::size_t k = 0; k < cells.count; ++k) {
      const std::int64_t index = cells.offsets != nullptr ? base + cells.offsets[k]
                                                          : (n + cells.dn[k]) * grid.size_x + m + cells.dm[k];
      const Next next = add_cell(tally, grid.costs[index], scan, true);
      if (next == Next::Reject) return {PoseState::Rejected, tally.total};
      if (next == Next::Stop) break;
    }
    return {tally.state(), tally.total};
  }
  for (std::size_t k = 0; k < cells.count; ++k) {
    const std::int64_t cm = m + cells.dm[k], cn = n + cells.dn[k];
    if (!grid.contains(cm, cn)) {
      if (scan == Scan::FreeOrInscribed) return {PoseState::Rejected, tally.total};
      tally.outside = true;
      if (scan == Scan::UntilSettled) break;
      continue;
    }
    if (add_cell(tally, grid.at(cm, cn), scan, false) == Next::Reject) return {PoseState::Rejected, tally.total};
  }
  return {tally.state(), tally.total};
}

CellBox bounds_of(const std::int64_t* dm, const std::int64_t* dn, std::size_t count) {
  if (count == 0) return {};
  CellBox box{dm[0], dm[0], dn[0], dn[0]};
  for (std::size_t k = 1; k < count; ++k) {
    box.m_min = std::min(box.m_min, dm[k]);
    box.m_max = std::max(box.m_max, dm[k]);
    box.n_min = std::min(box.n_min, dn[k]);
    box.n_max = std::max(box.n_max, dn[k]);
  }
  return box;
}

}  // namespace pfield::costmap
