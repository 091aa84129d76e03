// The self pairs' tables (robot/pair_tables.hpp, issue 34) on a case whose distances are exact: a ball on the base
// and a ball on a revolute joint about z, both 0.5 m from the axis, radius 0.1. At angle θ their centres are
// 2 · 0.5 · |sin(θ/2)| apart, so the fitted distance is D(θ) = |sin(θ/2)| - 0.2, changing by at most 0.5 m/rad.
// Run under the sanitizers (the lazy cells, the wrap of a joint that turns more than once).
#include <cmath>
#include <cstdint>
#include <vector>

#include "harness.hpp"
#include "robot/pair_tables.hpp"
#include "robot/robot.hpp"

namespace {

using namespace pfield::robot;

struct TwoBalls {
  // the kinematics: one revolute joint about z at the origin
  std::vector<std::int64_t> parents{-1}, kinds{0}, support{1};
  std::vector<double> place_rot{1, 0, 0, 0, 1, 0, 0, 0, 1}, place_pos{0, 0, 0}, axes{0, 0, 1};
  // link 0 on the base, link 1 on the joint; each one ball (a segment of zero length) at (0.5, 0, 0)
  std::vector<std::int64_t> cap_joint{-1, 0}, pairs{0, 1}, link_start{0, 1, 2}, prim_joint{-1, 0};
  std::vector<double> cap_a{0.5, 0, 0, 0.5, 0, 0}, cap_b{0.5, 0, 0, 0.5, 0, 0}, cap_r{0.1, 0.1}, self_r{0.1, 0.1};
  std::vector<double> prim_a{0.5, 0, 0, 0.5, 0, 0}, prim_b{0.5, 0, 0, 0.5, 0, 0}, prim_r{0.1, 0.1};
  std::vector<double> lower{-3.0}, upper{3.0};

  RobotView view() {
    RobotView v;
    v.kinematics = {1, parents.data(), place_rot.data(), place_pos.data(), axes.data(), kinds.data(),
                    support.data(), -1, nullptr, nullptr};
    v.links = {2, cap_joint.data(), cap_a.data(), cap_b.data(), cap_r.data(), self_r.data(), 1, pairs.data(),
               2, link_start.data(), prim_joint.data(), prim_a.data(), prim_b.data(), prim_r.data()};
    v.limits = {lower.data(), upper.data(), nullptr, nullptr};
    return v;
  }
};

double exact(double angle) { return std::abs(std::sin(angle / 2.0)) - 0.2; }

}  // namespace

TEST(a_pair_table_decides_as_the_exact_distance_does) {
  TwoBalls robot;
  const double weight = 0.5;
  const PairTables tables(robot.view(), &weight);
  CHECK(tables.axes(0).size() == 1);
  const TableAxis& axis = tables.axes(0)[0];
  CHECK(axis.joint == 0 && !axis.turns && axis.origin == -3.0);
  CHECK_NEAR(axis.cells * axis.width, 6.0, 1e-12);
  CHECK(tables.filled(0) == 0);
  int decided = 0;  // at need 0
  for (int i = 0; i <= 600; ++i) {
    const double angle = -3.0 + 0.01 * i;
    for (const double need : {0.0, 0.05, exact(angle), exact(angle) - 0.02, exact(angle) + 0.02}) {
      const PairVerdict said = tables.verdict(0, &angle, need);
      if (said == PairVerdict::Clear) CHECK(exact(angle) >= need);
      if (said == PairVerdict::Below) CHECK(exact(angle) < need);
      if (need == 0.0) decided += said != PairVerdict::Unknown ? 1 : 0;
    }
  }
  // of 601: those within a cell's slack of the contact (|θ| near 0.40) are the primitives' to decide
  CHECK(decided > 550);
  CHECK(tables.filled(0) == axis.cells);  // every cell was visited and filled
  // far apart the table answers at once; in contact too
  const double across = 3.0, together = 0.0;
  CHECK(tables.verdict(0, &across, 0.0) == PairVerdict::Clear);
  CHECK(tables.verdict(0, &together, 0.0) == PairVerdict::Below);
}

TEST(a_joint_that_turns_more_than_once_is_tabulated_over_one_turn) {
  TwoBalls robot;
  robot.lower = {-7.0};
  robot.upper = {7.0};
  const double weight = 0.5;
  const PairTables tables(robot.view(), &weight);
  const TableAxis& axis = tables.axes(0)[0];
  CHECK(axis.turns);
  CHECK_NEAR(axis.cells * axis.width, 2.0 * M_PI, 1e-12);
  for (int i = 0; i < 100; ++i) {
    const double angle = -3.0 + 0.06 * i, turned = angle + 2.0 * M_PI;
    CHECK(tables.verdict(0, &angle, 0.05) == tables.verdict(0, &turned, 0.05));
    const PairVerdict said = tables.verdict(0, &turned, 0.05);
    if (said == PairVerdict::Clear) CHECK(exact(angle) >= 0.05);
    if (said == PairVerdict::Below) CHECK(exact(angle) < 0.05);
  }
}

TEST(pair_tables_know_the_robot_they_were_made_from) {
  TwoBalls robot, other;
  const double weight = 0.5;
  const PairTables tables(robot.view(), &weight);
  CHECK(tables.made_from(robot.view()));
  CHECK(tables.made_from(other.view()));  // the same arrays, elsewhere
  other.prim_r[1] = 0.2;
  CHECK(!tables.made_from(other.view()));
  // a pair moved by no joint, or by one without limits, has no table
  const double none = 0.0;
  CHECK(PairTables(robot.view(), &none).axes(0).empty());
  robot.upper = {INFINITY};
  CHECK(PairTables(robot.view(), &weight).axes(0).empty());
  const double q = 1.0;
  CHECK(PairTables(robot.view(), &weight).verdict(0, &q, 0.0) == PairVerdict::Unknown);
}
