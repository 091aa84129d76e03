// The global search (src/core/planning/rrt.hpp, segment_free.hpp): the segment samples' coarse-to-fine order, the
// random stream, and RRT-Connect with shortcutting in the point space around one sphere. Also run under
// AddressSanitizer and UBSan (make core-test); tests/planning/test_core_rrt.py holds the search to numba's draw for
// draw.
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "geometry/packed.hpp"
#include "harness.hpp"
#include "planning/rrt.hpp"
#include "planning/segment_free.hpp"

namespace {

using namespace pfield;
using planning::samples_valid;

// numba's edge_valid order: strides from the largest power of two <= last down to 1, skipping indices already done.
std::vector<std::int64_t> reference_order(std::int64_t last) {
  std::int64_t stride = 1;
  while (stride * 2 <= last) stride *= 2;
  std::vector<bool> done(static_cast<std::size_t>(last) + 1, false);
  std::vector<std::int64_t> order;
  for (; stride >= 1; stride /= 2)
    for (std::int64_t i = stride; i <= last; i += stride)
      if (!done[static_cast<std::size_t>(i)]) done[static_cast<std::size_t>(i)] = true, order.push_back(i);
  return order;
}

// One sphere of radius r at c (no meshes).
struct OneSphere {
  std::vector<std::int64_t> kinds{static_cast<std::int64_t>(geometry::Kind::Sphere)};
  std::array<double, geometry::kRowWidth> row;
  geometry::PackedView view{};

  OneSphere(double cx, double cy, double cz, double r) : row{cx, cy, cz, 1, 0, 0, 0, 1, 0, 0, 0, 1, r, 0, 0, -1} {
    view.kinds = kinds.data();
    view.rows = row.data();
    view.obstacle_count = 1;
  }
};

}  // namespace

TEST(segment_samples_are_visited_coarse_to_fine_as_numba_does) {
  for (std::int64_t steps = 1; steps <= 70; ++steps) {
    for (std::int64_t last = steps - 1; last <= steps; ++last) {
      std::vector<std::int64_t> seen;
      CHECK(samples_valid(steps, last, [&](double t) {
        seen.push_back(std::llround(t * static_cast<double>(steps)));
        return true;
      }));
      CHECK(seen == reference_order(last));
    }
  }
  // stops at the first invalid sample
  int calls = 0;
  CHECK(!samples_valid(16, 16, [&](double t) { return ++calls, t != 0.25; }));
  CHECK(calls == 3);  // 16/16, 8/16, 4/16
}

TEST(the_random_stream_is_in_the_unit_interval_and_seeded_apart) {
  std::uint64_t a = planning::seeded_state(0), b = planning::seeded_state(1);
  CHECK(a != 0 && b != 0 && a != b);
  double sum = 0.0;
  for (int k = 0; k < 100000; ++k) {
    const double u = planning::uniform(a);
    CHECK(u >= 0.0 && u < 1.0);
    sum += u;
  }
  CHECK_NEAR(sum / 100000.0, 0.5, 0.01);
}

TEST(a_point_search_goes_around_a_sphere_and_shortcuts_keep_the_margin) {
  const OneSphere sphere(0.5, 0.0, 0.0, 0.2);
  const double margin = 0.02, resolution = 0.005;
  planning::StateChecker checker(sphere.view, margin, resolution);
  const double start[3] = {0.0, 0.0, 0.0}, goal[3] = {1.0, 0.0, 0.0};
  const double lower[3] = {-0.5, -0.5, -0.5}, upper[3] = {1.5, 0.5, 0.5};
  CHECK(checker.state_valid(start) && checker.state_valid(goal));
  CHECK(!checker.edge_valid(start, goal));
  planning::Trees trees(start, goal, 1, 3, 2000, 7);
  planning::SearchOutcome outcome;
  for (int chunk = 0; chunk < 50 && outcome.status == planning::SearchStatus::Searching; ++chunk)
    outcome = planning::rrt_connect(checker, trees, lower, upper, 0.1, 500, nullptr);
  CHECK(outcome.status == planning::SearchStatus::Found);
  CHECK(outcome.rows >= 3 && outcome.path.size() == 3 * outcome.rows);
  const std::vector<double> path = planning::shortcut(checker, outcome.path.data(), outcome.rows, 50, trees.random);
  const std::size_t rows = path.size() / 3;
  CHECK(rows >= 3 && rows <= outcome.rows);
  for (int j = 0; j < 3; ++j) CHECK(path[j] == start[j] && path[3 * (rows - 1) + j] == goal[j]);
  for (std::size_t k = 0; k + 1 < rows; ++k) {  // every edge keeps the margin (checked finer than the search did)
    for (int s = 0; s <= 100; ++s) {
      const double t = s / 100.0;
      double d2 = 0.0;
      for (int j = 0; j < 3; ++j) {
        const double p = path[3 * k + j] + t * (path[3 * (k + 1) + j] - path[3 * k + j]);
        const double c = j == 0 ? 0.5 : 0.0;
        d2 += (p - c) * (p - c);
      }
      CHECK(std::sqrt(d2) - 0.2 >= margin - 1e-3);
    }
  }
  // a full tree ends the search
  planning::Trees small(start, goal, 1, 3, 3, 7);
  planning::SearchOutcome full;
  for (int chunk = 0; chunk < 50 && full.status == planning::SearchStatus::Searching; ++chunk)
    full = planning::rrt_connect(checker, small, lower, upper, 0.01, 500, nullptr);
  CHECK(full.status == planning::SearchStatus::Exhausted && full.rows == 0);
  // the cancel flag ends a chunk before any check
  const std::uint8_t cancel = 1;
  const std::int64_t before = checker.states_checked();
  planning::Trees fresh(start, goal, 1, 3, 100, 1);
  CHECK(planning::rrt_connect(checker, fresh, lower, upper, 0.1, 1000, &cancel).status ==
        planning::SearchStatus::Searching);
  CHECK(checker.states_checked() == before);
}

TEST(a_bound_on_the_checks_ends_a_chunk_where_the_budget_would_not) {
  // the race of seeds (global_search._Race) lowers a lane's bound while it runs: no iteration starts at or past it
  const OneSphere sphere(0.5, 0.0, 0.0, 0.2);
  planning::StateChecker checker(sphere.view, 0.02, 0.005);
  const double start[3] = {0.0, 0.0, 0.0}, goal[3] = {1.0, 0.0, 0.0};
  const double lower[3] = {-0.5, -0.5, -0.5}, upper[3] = {1.5, 0.5, 0.5};
  planning::Trees trees(start, goal, 1, 3, 2000, 3);
  const std::int64_t bound = 40;
  const planning::SearchOutcome bounded = planning::rrt_connect(checker, trees, lower, upper, 0.1, 100000, nullptr,
                                                                &bound);
  CHECK(bounded.status == planning::SearchStatus::Searching);
  CHECK(checker.states_checked() >= bound);
  // past the bound only the iteration that started before it: an extension (at most step / resolution = 20
  // samples) and the other tree's connection (at most the box's diagonal / step = 25 extensions), far below the budget
  CHECK(checker.states_checked() < bound + 20 + 25 * 20);
  // a bound already reached checks nothing
  const std::int64_t reached = checker.states_checked();
  CHECK(planning::rrt_connect(checker, trees, lower, upper, 0.1, 100000, nullptr, &reached).status ==
        planning::SearchStatus::Searching);
  CHECK(checker.states_checked() == reached);
  // the same stream with no bound checks the budget's worth (or finds the path)
  planning::StateChecker free_checker(sphere.view, 0.02, 0.005);
  planning::Trees same(start, goal, 1, 3, 2000, 3);
  const planning::SearchOutcome unbounded = planning::rrt_connect(free_checker, same, lower, upper, 0.1, 100000,
                                                                  nullptr);
  CHECK(unbounded.status == planning::SearchStatus::Found || free_checker.states_checked() >= 100000);
  CHECK(free_checker.states_checked() > checker.states_checked());
}
