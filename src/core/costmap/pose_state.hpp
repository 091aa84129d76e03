// The state and cost of a footprint placed on a costmap (Move Base Flex FindValidPose's states).
//
// State precedence: OUTSIDE (a covered cell lies outside the map) > LETHAL > UNKNOWN > INSCRIBED > FREE; the cost
// is the sum of the covered in-map cells' costs.
#pragma once

#include <cstddef>
#include <cstdint>

#include "costmap/grid.hpp"

namespace pfield::costmap {

// FindValidPose.srv's state constants (0-4); a search's trace also marks candidates Rejected (neither FREE nor
// INSCRIBED, not examined further because a better fallback was known) or NotEvaluated.
enum class PoseState : std::uint8_t {
  Free = 0,
  Inscribed = 1,
  Lethal = 2,
  Unknown = 3,
  Outside = 4,
  Rejected = 5,
  NotEvaluated = 255,
};

// How far to scan a placement's cells.
enum class Scan {
  Full,             // every cell: the exact state and the whole cost
  UntilSettled,     // stop once the state is settled (the cost is then partial)
  FreeOrInscribed,  // only "FREE or INSCRIBED?": Rejected at the first outside, lethal or unknown cell
};

// Cells of a footprint relative to a base cell (a view) and their bounds; optionally each cell's offset in the
// cost array, dn * size_x + dm, which placements inside the map read instead of (dm, dn).
struct FootprintCells {
  const std::int64_t* dm = nullptr;
  const std::int64_t* dn = nullptr;
  std::size_t count = 0;
  CellBox box;
  const std::int64_t* offsets = nullptr;
};

struct Placement {
  PoseState state = PoseState::Free;
  std::int64_t cost = 0;
};

// The footprint's cells shifted to the base cell (m, n), scanned as `scan` says.
Placement evaluate_placement(const CostGrid& grid, std::int64_t m, std::int64_t n, const FootprintCells& cells,
                             Scan scan);

// Bounds of `count` cells (an empty box for none).
CellBox bounds_of(const std::int64_t* dm, const std::int64_t* dn, std::size_t count);

}  // namespace pfield::costmap
