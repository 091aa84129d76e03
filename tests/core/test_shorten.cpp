// The shortening of a searched path (src/core/planning/rrt.hpp: shorten, path_length) in the point space around one
// sphere: never longer, the ends kept, every segment clear of the sphere by the margin, the new segments by the
// stricter checker's; a zigzag in free space becomes its straight segment. Also run under AddressSanitizer and UBSan
// (make core-test); tests/planning/test_motion_quality.py holds it on joint paths.
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "geometry/packed.hpp"
#include "harness.hpp"
#include "planning/rrt.hpp"

namespace {

using namespace pfield;

// One sphere of radius r at c (no meshes).
struct Sphere {
  std::vector<std::int64_t> kinds{static_cast<std::int64_t>(geometry::Kind::Sphere)};
  std::array<double, geometry::kRowWidth> row;
  geometry::PackedView view{};

  Sphere(double cx, double cy, double cz, double r) : row{cx, cy, cz, 1, 0, 0, 0, 1, 0, 0, 0, 1, r, 0, 0, -1} {
    view.kinds = kinds.data();
    view.rows = row.data();
    view.obstacle_count = 1;
  }
};

// The least distance from the sphere (centre c, radius r) of the points every 1/200 along segment a -> b.
double segment_clearance(const double* a, const double* b, const double* c, double r) {
  double least = 1e300;
  for (int s = 0; s <= 200; ++s) {
    const double t = s / 200.0;
    double d2 = 0.0;
    for (int j = 0; j < 3; ++j) {
      const double p = a[j] + t * (b[j] - a[j]) - c[j];
      d2 += p * p;
    }
    least = std::min(least, std::sqrt(d2) - r);
  }
  return least;
}

}  // namespace

TEST(shortening_a_path_around_a_sphere_never_lengthens_it_and_keeps_the_margins) {
  const Sphere sphere(0.5, 0.0, 0.0, 0.2);
  const double centre[3] = {0.5, 0.0, 0.0};
  const double margin = 0.02, extra = 0.03, resolution = 0.002;
  planning::StateChecker checker(sphere.view, margin, resolution);
  planning::StateChecker strict(sphere.view, margin + extra, resolution);
  const double start[3] = {0.0, 0.0, 0.0}, goal[3] = {1.0, 0.0, 0.0};
  const double lower[3] = {-0.5, -0.5, -0.5}, upper[3] = {1.5, 0.5, 0.5};
  int shorter = 0;
  for (std::uint64_t seed = 0; seed < 8; ++seed) {
    planning::Trees trees(start, goal, 1, 3, 4000, seed);
    planning::SearchOutcome outcome;
    for (int chunk = 0; chunk < 50 && outcome.status == planning::SearchStatus::Searching; ++chunk)
      outcome = planning::rrt_connect(checker, trees, lower, upper, 0.1, 500, nullptr);
    CHECK(outcome.status == planning::SearchStatus::Found);
    const double before = planning::path_length(outcome.path.data(), outcome.rows, 3);
    const std::vector<double> path =
        planning::shorten(checker, strict, outcome.path.data(), outcome.rows, 100, trees.random);
    const std::size_t rows = path.size() / 3;
    CHECK(rows >= 2 && path.size() == 3 * rows);
    for (int j = 0; j < 3; ++j) CHECK(path[j] == start[j] && path[3 * (rows - 1) + j] == goal[j]);
    const double after = planning::path_length(path.data(), rows, 3);
    CHECK(after <= before);
    shorter += after < 0.95 * before;
    // around a sphere of radius 0.2 the shortest way keeping 0.02 is longer than the straight metre
    CHECK(after > 1.0);
    for (std::size_t k = 0; k + 1 < rows; ++k)  // every edge keeps the margin (checked finer than the search did)
      CHECK(segment_clearance(&path[3 * k], &path[3 * (k + 1)], centre, 0.2) >= margin - 1e-3);
  }
  CHECK(shorter >= 4);
}

TEST(a_zigzag_in_free_space_shortens_to_its_straight_segment) {
  const Sphere far(10.0, 10.0, 10.0, 0.1);
  planning::StateChecker checker(far.view, 0.01, 0.005);
  const std::vector<double> zigzag{0.0, 0.0, 0.0, 0.2, 0.3, 0.0, 0.4, -0.3, 0.1, 0.6, 0.3, -0.1, 1.0, 0.0, 0.0};
  std::uint64_t random = planning::seeded_state(3);
  const std::vector<double> path = planning::shorten(checker, checker, zigzag.data(), 5, 20, random);
  CHECK(path == (std::vector<double>{0.0, 0.0, 0.0, 1.0, 0.0, 0.0}));
  CHECK(planning::path_length(path.data(), 2, 3) == 1.0);
  // one row stays one row; no rows, none
  CHECK(planning::shorten(checker, checker, zigzag.data(), 1, 20, random) == (std::vector<double>{0.0, 0.0, 0.0}));
  CHECK(planning::shorten(checker, checker, zigzag.data(), 0, 20, random).empty());
  CHECK(planning::path_length(zigzag.data(), 1, 3) == 0.0);
}
