// The link-fitting cover (src/core/robot/cover): the greedy cover on a lattice (every point covered, each capsule
// for new points, capsules far off the grid clamped to no cells), a cover that cannot finish, the depth with a
// capsule skipped, a cube's inside test through an inner polytope, and the enclosing circle of symmetric points;
// under the sanitizers, the grid's and the heap's index arithmetic. Lattice values are dyadic, so the checks
// compare with ==.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <set>
#include <stdexcept>
#include <vector>

#include "harness.hpp"
#include "robot/cover.hpp"

namespace {

using namespace pfield::robot;

// Capsules from rows of (a, b, r).
struct Capsules {
  std::vector<double> a, b, r;
  void add(double ax, double ay, double az, double bx, double by, double bz, double radius) {
    a.insert(a.end(), {ax, ay, az});
    b.insert(b.end(), {bx, by, bz});
    r.push_back(radius);
  }
  CapsuleSet view() const { return {a.data(), b.data(), r.data(), r.size()}; }
};

// A fixed pseudo-random sequence (a 64-bit LCG, Knuth's MMIX constants): the same lattice on every build.
struct Sequence {
  std::uint64_t state = 7;
  int below(int n) {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<int>((state >> 33) % static_cast<std::uint64_t>(n));
  }
};

bool covers_all(const Capsules& capsules, const std::vector<double>& points, const std::vector<std::int64_t>& picked) {
  const std::size_t n = points.size() / 3, k = capsules.r.size();
  const std::unique_ptr<bool[]> matrix(new bool[k * n]);
  coverage(capsules.view(), {points.data(), n}, matrix.get());
  std::vector<bool> seen(n, false);
  for (std::int64_t pick : picked) {
    bool fresh = false;
    for (std::size_t p = 0; p < n; ++p)
      if (matrix[pick * n + p] && !seen[p]) fresh = seen[p] = true;
    if (!fresh) return false;  // taken without new points
  }
  for (std::size_t p = 0; p < n; ++p)
    if (!seen[p]) return false;
  return true;
}

}  // namespace

TEST(greedy_cover_covers_a_lattice_each_capsule_for_new_points) {
  Sequence random;
  Capsules capsules;
  std::vector<double> points;
  for (int i = 0; i < 300; ++i) points.insert(points.end(), {random.below(16) * 0.125, random.below(16) * 0.125,
                                                              random.below(16) * 0.125});
  for (int i = 0; i < 200; ++i) {
    const double ax = random.below(16) * 0.125, ay = random.below(16) * 0.125, az = random.below(16) * 0.125;
    if (random.below(2) == 0)
      capsules.add(ax, ay, az, ax, ay, az, random.below(4) * 0.125);
    else
      capsules.add(ax, ay, az, random.below(16) * 0.125, random.below(16) * 0.125, random.below(16) * 0.125,
                   random.below(4) * 0.125);
  }
  capsules.add(-50.0, 3.0, 1e6, -50.0, 3.0, 1e6, 0.5);  // far outside the grid: no cells, never taken
  capsules.add(1e300, -1e300, 0.0, 1e300, 1e300, 0.0, 1.0);
  for (std::size_t p = 0; p < points.size(); p += 3)  // every point in some candidate
    capsules.add(points[p], points[p + 1], points[p + 2], points[p], points[p + 1], points[p + 2], 0.0625);
  for (double cell : {0.0625, 0.125, 0.3, 2.0}) {
    const std::vector<std::int64_t> picked = greedy_cover(capsules.view(), {points.data(), points.size() / 3}, cell);
    CHECK(!picked.empty());
    CHECK(std::set<std::int64_t>(picked.begin(), picked.end()).size() == picked.size());
    CHECK(covers_all(capsules, points, picked));
    for (std::int64_t pick : picked) CHECK(pick != 200 && pick != 201);
  }
}

TEST(greedy_cover_stops_when_no_capsule_holds_the_points_left) {
  Capsules capsules;
  capsules.add(0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.25);
  const std::vector<double> points{0.5, 0.0, 0.0, 0.0, 0.125, 0.0, 3.0, 3.0, 3.0};
  const std::vector<std::int64_t> picked = greedy_cover(capsules.view(), {points.data(), 3}, 0.5);
  CHECK(picked.size() == 1 && picked[0] == 0);
  CHECK(greedy_cover(capsules.view(), {points.data(), 0}, 0.5).empty());
}

TEST(greedy_cover_refuses_what_it_cannot_grid) {
  Capsules capsules;
  capsules.add(0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.25);
  const std::vector<double> points{0.0, 0.0, 0.0, 1.0, 1.0, 1.0};
  const auto refused = [&](const CapsuleSet& set, double cell) {
    try {
      greedy_cover(set, {points.data(), 2}, cell);
    } catch (const std::invalid_argument&) {
      return true;
    }
    return false;
  };
  CHECK(refused(capsules.view(), 0.0));
  CHECK(refused(capsules.view(), std::numeric_limits<double>::quiet_NaN()));
  CHECK(refused(capsules.view(), 1e-9));  // 10^9 cells along each axis
  Capsules nan = capsules;
  nan.r[0] = std::numeric_limits<double>::quiet_NaN();
  CHECK(refused(nan.view(), 0.5));
}

TEST(min_depth_skips_one_capsule) {
  Capsules capsules;
  capsules.add(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5);  // a sphere
  capsules.add(2.0, 0.0, 0.0, 2.0, 0.0, 4.0, 0.25);  // a capsule along z
  const std::vector<double> points{1.0, 0.0, 0.0, 2.0, 0.0, 6.0, 2.5, 0.0, 2.0};
  std::vector<double> depth(3);
  min_depth(capsules.view(), {points.data(), 3}, -1, depth.data());
  CHECK(depth[0] == 0.5 && depth[1] == 1.75 && depth[2] == 0.25);
  min_depth(capsules.view(), {points.data(), 3}, 1, depth.data());
  CHECK(depth[0] == 0.5 && depth[1] == std::sqrt(40.0) - 0.5);
  min_depth(capsules.view(), {points.data(), 3}, 0, depth.data());
  CHECK(depth[0] == 0.75);
  min_depth({nullptr, nullptr, nullptr, 0}, {points.data(), 3}, -1, depth.data());
  CHECK(depth[2] == std::numeric_limits<double>::infinity());
}

TEST(inside_hull_of_a_cube_through_an_inner_octahedron) {
  const std::vector<double> cube{1, 0, 0, -1, -1, 0, 0, -1, 0, 1, 0, -1, 0, -1, 0, -1, 0, 0, 1, -1, 0, 0, -1, -1};
  std::vector<double> octahedron;  // |x| + |y| + |z| <= 1, inside the cube [-1, 1]^3
  const double s = 1.0 / std::sqrt(3.0);
  for (double x : {-s, s})
    for (double y : {-s, s})
      for (double z : {-s, s}) octahedron.insert(octahedron.end(), {x, y, z, -s});
  const std::vector<double> points{0.0, 0.0, 0.0, 0.9, 0.9, 0.9, 1.0, 0.0, 0.0, 1.5, 0.0, 0.0, 0.0, -1.75, 0.0};
  bool inside[5];
  inside_hull({cube.data(), 6}, {octahedron.data(), 8}, {points.data(), 5}, 0.0, inside);
  CHECK(inside[0] && inside[1] && inside[2] && !inside[3] && !inside[4]);
  inside_hull({cube.data(), 6}, {octahedron.data(), 8}, {points.data(), 5}, 0.5, inside);
  CHECK(inside[3] && !inside[4]);
}

TEST(enclosing_circle_of_symmetric_points_is_their_centre) {
  const std::vector<double> square{1.0, 1.0, -1.0, 1.0, -1.0, -1.0, 1.0, -1.0, 0.5, 0.0};
  double centre[2];
  enclosing_circle(square.data(), 5, 2, 400, centre);
  CHECK_NEAR(centre[0], 0.0, 0.1);
  CHECK_NEAR(centre[1], 0.0, 0.1);
  enclosing_circle(square.data(), 5, 2, 0, centre);  // the bounding box's centre
  CHECK(centre[0] == 0.0 && centre[1] == 0.0);
  const std::vector<double> line{0.0, 4.0, 1.0};
  double middle;
  enclosing_circle(line.data(), 3, 1, 1, &middle);  // from 2, the first farthest point is 0: 2 + (0 - 2) / 2
  CHECK(middle == 1.0);
}
