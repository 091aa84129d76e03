// The costmap's core (src/core/costmap): exact rasterisation (grid lines, vertices on cell corners, a concave
// notch), the footprint at several yaws, the state and cost of placements in every scan mode, FindValidPose on
// hand-made grids (answer, cost, and the trace of every candidate) and the local window's resampling.
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

#include "costmap/find_valid_pose.hpp"
#include "costmap/pose_state.hpp"
#include "costmap/raster.hpp"
#include "costmap/resample.hpp"
#include "harness.hpp"

namespace {

using namespace pfield::costmap;
using CellList = std::vector<std::pair<std::int64_t, std::int64_t>>;

CellList cells_of(const std::vector<double>& us, const std::vector<double>& vs) {
  const Cells cells = rasterize_polygon(us.data(), vs.data(), us.size());
  CellList out;
  for (std::size_t k = 0; k < cells.m.size(); ++k) out.emplace_back(cells.m[k], cells.n[k]);
  return out;
}

// Lattice offsets (i, j) in answer order up to i^2 + j^2 = 8: ring by ring, by polar angle inside a ring.
const std::int64_t kOffsets[25][2] = {
    {0, 0},                                                                  // ring 0
    {1, 0},  {0, 1},  {-1, 0},  {0, -1},                                     // ring 1
    {1, 1},  {-1, 1}, {-1, -1}, {1, -1},                                     // ring 2
    {2, 0},  {0, 2},  {-2, 0},  {0, -2},                                     // ring 4
    {2, 1},  {1, 2},  {-1, 2},  {-2, 1}, {-2, -1}, {-1, -2}, {1, -2}, {2, -1},  // ring 5
    {2, 2},  {-2, 2}, {-2, -2}, {2, -2},                                     // ring 8
};
const std::vector<std::int64_t> kRings = {0, 1, 5, 9, 13, 21, 25};

std::vector<std::int64_t> column(int c) {
  std::vector<std::int64_t> out;
  for (const auto& offset : kOffsets) out.push_back(offset[c]);
  return out;
}
const std::vector<std::int64_t> kI = column(0), kJ = column(1);

Candidates rings_up_to(std::size_t ring_count) {
  return {kI.data(), kJ.data(), static_cast<std::size_t>(kRings[ring_count]), kRings.data(), ring_count};
}

// A 0.2 m square robot on a 0.1 m grid, its centre at a cell centre: 3 x 3 cells around the base cell.
YawKernels square_kernels() {
  const double px[4] = {0.1, -0.1, -0.1, 0.1}, py[4] = {0.1, 0.1, -0.1, -0.1}, yaw = 0.0;
  return rasterize_yaws({px, py, 4, 0.5, 0.5, 10.0}, &yaw, 1);
}

std::uint8_t mark(PoseState state) { return static_cast<std::uint8_t>(state); }

}  // namespace

TEST(rasterised_square_covers_its_cells_in_row_major_order) {
  const CellList cells = cells_of({0.5, 2.5, 2.5, 0.5}, {0.5, 0.5, 1.5, 1.5});
  CHECK((cells == CellList{{0, 0}, {1, 0}, {2, 0}, {0, 1}, {1, 1}, {2, 1}}));
}

TEST(closed_polygon_on_grid_lines_covers_the_half_open_cells_it_touches) {
  // [1, 3] x [1, 2]: x = 3 lies in cell [3, 4), y = 2 in row [2, 3); x = 1 is not in [0, 1)
  const CellList cells = cells_of({1.0, 3.0, 3.0, 1.0}, {1.0, 1.0, 2.0, 2.0});
  CHECK((cells == CellList{{1, 1}, {2, 1}, {3, 1}, {1, 2}, {2, 2}, {3, 2}}));
}

TEST(diamond_vertex_on_a_cell_edge_covers_that_cell) {
  const CellList cells = cells_of({1.0, 0.0, -1.0, 0.0}, {0.5, 1.5, 0.5, -0.5});
  CHECK((cells == CellList{{-1, -1}, {0, -1}, {-1, 0}, {0, 0}, {1, 0}, {-1, 1}, {0, 1}}));
}

TEST(concave_notch_is_not_covered) {
  std::vector<double> us = {0, 6, 6, 4, 4, 2, 2, 0}, vs = {0, 0, 6, 6, 2, 2, 6, 6};
  for (double& u : us) u += 0.5;
  for (double& v : vs) v += 0.5;
  const CellList cells = cells_of(us, vs);
  CHECK(cells.size() == 49 - 4);
  for (std::int64_t n = 3; n <= 6; ++n) {
    for (const auto& cell : cells) CHECK(!(cell.first == 3 && cell.second == n));
  }
}

TEST(rasterisation_refuses_vertices_it_cannot_place) {
  bool threw = false;
  try {
    cells_of({0.0, std::numeric_limits<double>::quiet_NaN(), 1.0}, {0.0, 0.0, 1.0});
  } catch (const std::invalid_argument&) {
    threw = true;
  }
  CHECK(threw);
  threw = false;
  try {
    cells_of({0.0, 1e6, 1e6}, {0.0, 0.0, 1e6});  // 10^12 cells
  } catch (const std::invalid_argument&) {
    threw = true;
  }
  CHECK(threw);
}

TEST(footprint_at_each_yaw_is_rasterised_around_the_base_cell) {
  // a 0.6 x 0.2 m rectangle on a 0.1 m grid, centred in its cell: 7 x 3 cells along x, then 3 x 7 along y
  const double px[4] = {0.3, -0.3, -0.3, 0.3}, py[4] = {0.1, 0.1, -0.1, -0.1};
  const double yaws[2] = {0.0, 1.5707963267948966};
  const YawKernels kernels = rasterize_yaws({px, py, 4, 0.5, 0.5, 10.0}, yaws, 2);
  CHECK(kernels.yaw_count() == 2);
  CHECK((kernels.start == std::vector<std::size_t>{0, 21, 42}));
  const CellBox along_x = kernels.box[0], along_y = kernels.box[1];
  CHECK(along_x.m_min == -3 && along_x.m_max == 3 && along_x.n_min == -1 && along_x.n_max == 1);
  CHECK(along_y.m_min == -1 && along_y.m_max == 1 && along_y.n_min == -3 && along_y.n_max == 3);
  CHECK(kernels.dm[0] == -3 && kernels.dn[0] == -1 && kernels.dm[20] == 3 && kernels.dn[20] == 1);
  CHECK(kernels.reach() == 3);
}

TEST(placement_states_and_costs_in_every_scan_mode) {
  const std::vector<std::uint8_t> costs = {
      0, 0,  0,   0,   0,  // row 0
      0, 10, 253, 0,   0,  // row 1
      0, 20, 255, 254, 0,  // row 2
      0, 0,  0,   0,   7,  // row 3
  };
  const CostGrid grid{costs.data(), 5, 4};
  const std::int64_t dm[4] = {0, 1, 0, 1}, dn[4] = {0, 0, 1, 1};
  const FootprintCells block{dm, dn, 4, bounds_of(dm, dn, 4)};
  auto at = [&](std::int64_t m, std::int64_t n, Scan scan) { return evaluate_placement(grid, m, n, block, scan); };
  const std::vector<std::pair<Placement, Placement>> full = {
      {at(0, 0, Scan::Full), {PoseState::Free, 10}},        {at(1, 0, Scan::Full), {PoseState::Inscribed, 263}},
      {at(1, 1, Scan::Full), {PoseState::Unknown, 538}},    {at(3, 2, Scan::Full), {PoseState::Lethal, 261}},
      {at(4, 3, Scan::Full), {PoseState::Outside, 7}},      {at(-1, -1, Scan::Full), {PoseState::Outside, 0}},
      {at(3, 2, Scan::UntilSettled), {PoseState::Lethal, 254}},  // stops at its first cell, lethal
      {at(4, 3, Scan::UntilSettled), {PoseState::Outside, 7}},
      {at(1, 1, Scan::FreeOrInscribed), {PoseState::Rejected, 538}},
      {at(1, 0, Scan::FreeOrInscribed), {PoseState::Inscribed, 263}},
      {at(4, 3, Scan::FreeOrInscribed), {PoseState::Rejected, 7}},
  };
  for (const auto& [got, expected] : full) CHECK(got.state == expected.state && got.cost == expected.cost);
}

TEST(find_valid_pose_moves_off_a_lethal_cell_to_the_first_free_candidate) {
  // 12 x 12 free grid, lethal (5, 5), cost 100 at (7, 5); the square robot requested on (5, 5)
  std::vector<std::uint8_t> costs(144, 0);
  costs[5 * 12 + 5] = kLethalObstacle;
  costs[5 * 12 + 7] = 100;
  std::vector<double> lethal_distance(144);
  for (int n = 0; n < 12; ++n) {
    for (int m = 0; m < 12; ++m) lethal_distance[n * 12 + m] = std::hypot(m - 5, n - 5);
  }
  const YawKernels kernels = square_kernels();
  const Candidates candidates = rings_up_to(4);  // i^2 + j^2 <= 5: 21 positions
  // prefilter on (inscribed radius 1 cell: limit 1.5 cells) and off: the same answer and trace
  for (double limit : {1.5 - 1e-6, -1.0}) {
    std::vector<std::uint8_t> states(21, mark(PoseState::NotEvaluated));
    const SearchRequest request{{costs.data(), 12, 12}, lethal_distance.data(), 5, 5, limit};
    const SearchResult result = find_valid_pose(request, kernels, candidates, states.data());
    CHECK(result.found && result.state == PoseState::Free && result.cost == 100);
    CHECK(result.position == 9 && result.yaw == 0);  // (2, 0): the first of the ring at 2 cells
    for (std::size_t p = 0; p < 9; ++p) CHECK(states[p] == mark(PoseState::Lethal));
    CHECK(states[9] == mark(PoseState::Free));
    for (std::size_t p = 10; p < 21; ++p) CHECK(states[p] == mark(PoseState::NotEvaluated));
  }
}

TEST(find_valid_pose_prefers_unknown_over_a_closer_outside_and_rejects_after_it) {
  // 10 x 10 lethal grid with unknown columns 6..9; the request at the top edge, cell (5, 9)
  std::vector<std::uint8_t> costs(100, kLethalObstacle);
  for (int n = 0; n < 10; ++n) {
    for (int m = 6; m < 10; ++m) costs[n * 10 + m] = kNoInformation;
  }
  const std::vector<double> lethal_distance(100, 0.0);
  std::vector<std::uint8_t> states(25, mark(PoseState::NotEvaluated));
  const SearchResult result = find_valid_pose({{costs.data(), 10, 10}, lethal_distance.data(), 5, 9, -1.0},
                                              square_kernels(), rings_up_to(6), states.data());
  CHECK(result.found && result.state == PoseState::Unknown && result.cost == 9 * 255);
  CHECK(result.position == 20 && result.yaw == 0);  // (2, -1): three unknown columns, inside the map
  const auto O = mark(PoseState::Outside), L = mark(PoseState::Lethal), R = mark(PoseState::Rejected);
  const std::vector<std::uint8_t> expected = {O,                                      // ring 0
                                              O, O, O, L,                             // ring 1
                                              O, O, L, L,                             // ring 2
                                              O, O, O, L,                             // ring 4
                                              O, O, O, O, L, L, L, mark(PoseState::Unknown),  // ring 5
                                              R, R, R, R};  // ring 8: only "FREE or INSCRIBED?"
  CHECK(states == expected);
}

TEST(find_valid_pose_answers_inscribed_and_stops_at_its_ring) {
  std::vector<std::uint8_t> costs(81, kInscribedInflatedObstacle);
  costs[4 * 9 + 4] = kLethalObstacle;
  const std::vector<double> lethal_distance(81, 0.0);
  std::vector<std::uint8_t> states(21, mark(PoseState::NotEvaluated));
  const SearchResult result = find_valid_pose({{costs.data(), 9, 9}, lethal_distance.data(), 4, 4, -1.0},
                                              square_kernels(), rings_up_to(4), states.data());
  CHECK(result.found && result.state == PoseState::Inscribed && result.cost == 9 * 253 && result.position == 9);
  for (std::size_t p = 9; p < 13; ++p) CHECK(states[p] == mark(PoseState::Inscribed));
  for (std::size_t p = 13; p < 21; ++p) CHECK(states[p] == mark(PoseState::NotEvaluated));
}

TEST(find_valid_pose_without_a_fitting_candidate_is_lethal) {
  const std::vector<std::uint8_t> costs(100, kLethalObstacle);
  const std::vector<double> lethal_distance(100, 0.0);
  std::vector<std::uint8_t> states(5, mark(PoseState::NotEvaluated));
  const SearchResult result = find_valid_pose({{costs.data(), 10, 10}, lethal_distance.data(), 5, 5, 1.5},
                                              square_kernels(), rings_up_to(2), states.data());
  CHECK(!result.found && result.state == PoseState::Lethal && result.cost == 0);
  CHECK((states == std::vector<std::uint8_t>(5, mark(PoseState::Lethal))));
}

TEST(resampled_window_takes_the_worst_cell_and_is_unknown_beyond_the_map) {
  const std::vector<std::int8_t> data = {
      0,  10, -1, 0,    // row 0
      5,  0,  0,  100,  // row 1
      0,  -1, 0,  0,    // row 2
      20, 0,  30, 0,    // row 3
  };
  const OccupancyView source{data.data(), 4, 4};
  std::vector<std::int8_t> coarse(4);
  resample_occupancy(source, {0.0, 0.0, 2.0, 2, 2}, coarse.data());
  CHECK((coarse == std::vector<std::int8_t>{10, 100, -1, 30}));  // occupied > unknown > the highest free value
  std::vector<std::int8_t> shifted(6);
  resample_occupancy(source, {-1.0, 3.0, 1.0, 3, 2}, shifted.data());
  CHECK((shifted == std::vector<std::int8_t>{-1, 20, 0, -1, -1, -1}));
  std::vector<std::int8_t> far(4, 0);
  resample_occupancy(source, {1e300, -1e300, 0.5, 2, 2}, far.data());
  CHECK((far == std::vector<std::int8_t>(4, -1)));
}
