// FindValidPose's search (Move Base Flex's service, pfield/costmap/find_valid_pose.py documents the contract):
// the candidates in answer order, ring by ring, stopping at the first ring that holds a FREE or INSCRIBED one.
//
// Candidates are (position p, yaw a). Positions are lattice offsets (i, j) from the base cell grouped in rings of
// equal i^2 + j^2, sorted inside a ring by the tie-break; yaws are sorted by |delta yaw|. Inside a ring the loop
// order (a outer, p inner) is the answer order, so the first FREE candidate met is the answer and the first
// UNKNOWN and OUTSIDE met overall are the fallbacks. Once an UNKNOWN fallback is known, later candidates are only
// asked "FREE or INSCRIBED?" (an OUTSIDE one can no longer win) and may be marked Rejected.
//
// Prefilter: when the whole footprint is inside the map at every yaw and the nearest lethal cell centre is within
// `prefilter_limit` cells of the candidate's cell centre, that cell meets the footprint's inscribed disc: LETHAL
// at every yaw, no cell scanned (the Python layer derives the limit; negative disables it).
#pragma once

#include <cstddef>
#include <cstdint>

#include "costmap/grid.hpp"
#include "costmap/pose_state.hpp"
#include "costmap/raster.hpp"

namespace pfield::costmap {

// Lattice offsets in answer order (views): position p is (i[p], j[p]); ring r is positions
// ring_start[r] .. ring_start[r + 1] (ring_start has ring_count + 1 entries, ascending, within [0, count]).
struct Candidates {
  const std::int64_t* i = nullptr;
  const std::int64_t* j = nullptr;
  std::size_t count = 0;
  const std::int64_t* ring_start = nullptr;
  std::size_t ring_count = 0;
};

struct SearchRequest {
  CostGrid grid;
  const double* lethal_distance = nullptr;  // (size_y, size_x): cells from each cell centre to the nearest lethal one
  std::int64_t base_m = 0;                  // the requested pose's cell
  std::int64_t base_n = 0;
  double prefilter_limit = -1.0;
};

// The answer: FREE or INSCRIBED at the smallest distance (FREE preferred), else the first UNKNOWN, else the first
// OUTSIDE, else LETHAL with no candidate. `cost` is the answer's full cost (every covered in-map cell).
struct SearchResult {
  PoseState state = PoseState::Lethal;
  std::int64_t cost = 0;
  bool found = false;
  std::size_t position = 0;  // index of the answer's lattice offset in Candidates
  std::size_t yaw = 0;       // index of the answer's yaw in the kernels
};

// Searches the candidates; `states` (count x yaw_count, row-major, pre-filled with NotEvaluated) receives the
// state of every candidate examined.
SearchResult find_valid_pose(const SearchRequest& request, const YawKernels& kernels, const Candidates& candidates,
                             std::uint8_t* states);

}  // namespace pfield::costmap
