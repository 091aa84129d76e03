// planning::ForbiddenRegions (rrt.hpp): a state is in region b exactly when sum_j w_bj |q_j - c_bj| < r_b, and
// StateChecker::forbid makes those states invalid in the point space as in the joint space (issue 34).
#include <array>
#include <vector>

#include "harness.hpp"
#include "planning/rrt.hpp"

namespace {

using namespace pfield;

TEST(a_forbidden_region_holds_the_states_within_its_weighted_radius) {
  planning::ForbiddenRegions regions;
  regions.dimension = 3;
  CHECK(!regions.contains(std::array<double, 3>{0.0, 0.0, 0.0}.data()));  // no region: nothing forbidden
  regions.centres = {1.0, 2.0, 3.0};
  regions.weights = {0.5, 0.0, 2.0};  // joint 1 does not count
  regions.radii = {1.0};
  CHECK(regions.contains(std::array<double, 3>{1.0, 2.0, 3.0}.data()));
  CHECK(regions.contains(std::array<double, 3>{1.9, 100.0, 3.0}.data()));    // 0.45 + 0
  CHECK(regions.contains(std::array<double, 3>{0.2, 2.0, 3.2999}.data()));   // 0.4 + 0.5998 < 1
  CHECK(!regions.contains(std::array<double, 3>{0.2, 2.0, 3.3001}.data()));  // 0.4 + 0.6002 > 1
  CHECK(!regions.contains(std::array<double, 3>{3.0, 2.0, 3.0}.data()));     // exactly on the boundary: outside
  regions.centres.insert(regions.centres.end(), {10.0, 10.0, 10.0});
  regions.weights.insert(regions.weights.end(), {1.0, 1.0, 1.0});
  regions.radii.push_back(0.1);
  CHECK(regions.contains(std::array<double, 3>{10.03, 10.03, 10.03}.data()));  // the second region
  CHECK(!regions.contains(std::array<double, 3>{10.05, 10.05, 10.05}.data()));
}

TEST(a_checker_refuses_forbidden_states_and_counts_them) {
  // one sphere of radius 0.1 at the origin, as rrt's own tests build it
  std::vector<std::int64_t> kinds{static_cast<std::int64_t>(geometry::Kind::Sphere)};
  std::array<double, geometry::kRowWidth> row{0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0.1, 0, 0, -1};
  geometry::PackedView view{};
  view.kinds = kinds.data();
  view.rows = row.data();
  view.obstacle_count = 1;
  planning::StateChecker checker(view, 0.0, 0.01);
  const std::array<double, 3> free{1.0, 0.0, 0.0}, other{1.0, 0.5, 0.0};
  CHECK(checker.state_valid(free.data()) && checker.state_valid(other.data()));
  const std::array<double, 3> weights{1.0, 1.0, 1.0};
  checker.forbid(free.data(), weights.data(), 0.2);
  CHECK(!checker.state_valid(free.data()));
  CHECK(checker.state_valid(other.data()));
  CHECK(!checker.edge_valid(other.data(), std::array<double, 3>{1.0, -0.5, 0.0}.data()));  // through the region
  CHECK(checker.states_checked() > 4);
}

}  // namespace
