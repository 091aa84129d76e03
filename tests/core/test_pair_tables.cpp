// The self pairs' tables (robot/pair_tables.hpp, issue 34) on a case whose distances are exact: a ball on the base
// and a ball on a revolute joint about z, both 0.5 m from the axis, radius 0.1. At angle θ their centres are
// 2 · 0.5 · |sin(θ/2)| apart, so the fitted distance is D(θ) = |sin(θ/2)| - 0.2, changing by at most 0.5 m/rad.
// Run under the sanitizers (the lazy cells, the wrap of a joint that turns more than once).
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <thread>
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
  TwoBalls limits;
  limits.upper = {2.0};
  CHECK(!tables.made_from(limits.view()));
  // a pair moved by no joint, or by a prismatic one without limits, has no table
  const double none = 0.0;
  CHECK(PairTables(robot.view(), &none).axes(0).empty());
  TwoBalls endless;
  endless.kinds = {1};
  endless.upper = {INFINITY};
  CHECK(PairTables(endless.view(), &weight).axes(0).empty());
  const double q = 1.0;
  CHECK(PairTables(endless.view(), &weight).verdict(0, &q, 0.0) == PairVerdict::Unknown);
  // a continuous joint (no limits) turns: one turn of it, from -π
  robot.lower = {-INFINITY};
  robot.upper = {INFINITY};
  const PairTables continuous(robot.view(), &weight);
  CHECK(continuous.axes(0).size() == 1 && continuous.axes(0)[0].turns && continuous.axes(0)[0].origin == -M_PI);
  const double across = 3.0 + 4.0 * M_PI;
  CHECK(continuous.verdict(0, &across, 0.0) == PairVerdict::Clear);
}

TEST(a_pair_table_leaves_configurations_it_cannot_bound_to_the_primitives) {
  TwoBalls robot;
  const double weight = 0.5;
  const PairTables tables(robot.view(), &weight);
  for (const double q : {3.5, -3.01, std::numeric_limits<double>::quiet_NaN(),
                         std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()})
    CHECK(tables.verdict(0, &q, 0.0) == PairVerdict::Unknown);
  const double edge = 3.0;  // the upper limit itself is in the last cell
  CHECK(tables.verdict(0, &edge, 0.0) == PairVerdict::Clear);
  // a turning joint wraps any finite angle, but not infinities
  robot.lower = {-7.0};
  robot.upper = {7.0};
  const PairTables turning(robot.view(), &weight);
  const double far = 1000.0 * M_PI + 3.0, endless = std::numeric_limits<double>::infinity();
  CHECK(turning.verdict(0, &far, 0.0) == PairVerdict::Clear);
  CHECK(turning.verdict(0, &endless, 0.0) == PairVerdict::Unknown);
}

TEST(a_prismatic_joint_and_two_joints_make_tables_too) {
  // the joint slides along x: the balls are |q| apart along x, D(q) = |q| - 0.2 at 1 m/m
  TwoBalls slide;
  slide.kinds = {1};
  slide.axes = {1, 0, 0};
  slide.lower = {-0.5};
  slide.upper = {0.5};
  const double one = 1.0;
  const PairTables sliding(slide.view(), &one);
  CHECK(sliding.axes(0).size() == 1 && !sliding.axes(0)[0].turns);
  for (int i = 0; i <= 100; ++i) {
    const double q = -0.5 + 0.01 * i, d = std::abs(q) - 0.2;
    const PairVerdict said = sliding.verdict(0, &q, 0.0);
    if (said == PairVerdict::Clear) CHECK(d >= 0.0);
    if (said == PairVerdict::Below) CHECK(d < 0.0);
  }
  // two revolute joints about z in a chain, link 1 on the second: the ball turns by q0 + q1, D = |sin((q0+q1)/2)| - 0.2
  TwoBalls chain;
  chain.parents = {-1, 0};
  chain.kinds = {0, 0};
  chain.support = {1, 0, 1, 1};
  chain.place_rot = {1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  chain.place_pos = {0, 0, 0, 0, 0, 0};
  chain.axes = {0, 0, 1, 0, 0, 1};
  chain.cap_joint = {-1, 1};
  chain.prim_joint = {-1, 1};
  chain.lower = {-1.5, -1.5};
  chain.upper = {1.5, 1.5};
  RobotView view = chain.view();
  view.kinematics.joint_count = 2;
  const double weights[2] = {0.5, 0.5};
  const PairTables both(view, weights);
  CHECK(both.axes(0).size() == 2);
  int decided = 0;
  for (int i = 0; i <= 30; ++i)
    for (int j = 0; j <= 30; ++j) {
      const double q[2] = {-1.5 + 0.1 * i, -1.5 + 0.1 * j};
      const double d = std::abs(std::sin((q[0] + q[1]) / 2.0)) - 0.2;
      const PairVerdict said = both.verdict(0, q, 0.0);
      if (said == PairVerdict::Clear) CHECK(d >= 0.0);
      if (said == PairVerdict::Below) CHECK(d < 0.0);
      decided += said != PairVerdict::Unknown ? 1 : 0;
    }
  CHECK(decided > 800);  // of 961
  // a joint that moves the pair by less than kUntabulated over its range is no axis, its share added instead
  const double slight[2] = {1e-6, 0.5};
  CHECK(PairTables(view, slight).axes(0).size() == 1);
  // a link whose primitives are on another joint than its capsule's: its weights were not computed there
  chain.prim_joint = {-1, 0};
  CHECK(PairTables(chain.view(), weights).axes(0).empty());
}

TEST(two_threads_fill_one_table_with_the_same_verdicts) {
  // the race of seeds fills one robot's tables from two threads at once (relaxed atomics: each cell one value)
  TwoBalls robot;
  const double weight = 0.5;
  const PairTables shared(robot.view(), &weight), alone(robot.view(), &weight);
  std::vector<PairVerdict> first(601), second(601);
  const auto sweep = [&](std::vector<PairVerdict>& out) {
    for (int i = 0; i <= 600; ++i) {
      const double angle = -3.0 + 0.01 * i;
      out[static_cast<std::size_t>(i)] = shared.verdict(0, &angle, 0.0);
    }
  };
  std::thread other(sweep, std::ref(second));
  sweep(first);
  other.join();
  for (int i = 0; i <= 600; ++i) {
    const double angle = -3.0 + 0.01 * i;
    const PairVerdict expected = alone.verdict(0, &angle, 0.0);
    CHECK(first[static_cast<std::size_t>(i)] == expected && second[static_cast<std::size_t>(i)] == expected);
  }
  CHECK(shared.filled(0) == alone.filled(0));
}
