// The self pairs on the fitted primitives (robot::fitted_pair_distance_below, issue 34) on a two-link case whose
// answers are exact: the bounding capsules' distance when it is not below the cutoff, the nearest primitive pair
// below it, the cutoff itself when no primitive pair is below it. Run under the sanitizers (the cull's indexing).
#include <cstdint>
#include <limits>
#include <vector>

#include "harness.hpp"
#include "robot/clearance.hpp"
#include "robot/robot.hpp"

namespace {

using namespace pfield::robot;

constexpr double kInf = std::numeric_limits<double>::infinity();

// Two parallel links along x, 0.5 m apart in y, in world coordinates (the "joint frames" are the world).
//   link 0: bounding capsule (0,0,0)-(1,0,0) r 0.2; primitives [0, 0.5] r 0.1 and [0.5, 1] r 0.15
//   link 1: bounding capsule (0,.5,0)-(1,.5,0) r 0.2; primitives [0, 0.5] r 0.1 and [0.6, 1] r 0.05
// Primitive pairs: 0.3, 0.5099 - 0.15, 0.25 (link 0's second and link 1's first: the nearest), 0.3; the bounding
// capsules 0.1.
struct TwoLinks {
  std::vector<std::int64_t> cap_joint{0, 0}, pairs{0, 1}, link_start{0, 2, 4}, prim_joint{0, 0, 0, 0};
  std::vector<double> cap_a{0, 0, 0, 0, 0.5, 0}, cap_b{1, 0, 0, 1, 0.5, 0}, cap_r{0.2, 0.2}, self_r{0.2, 0.2};
  std::vector<double> prim_a{0, 0, 0, 0.5, 0, 0, 0, 0.5, 0, 0.6, 0.5, 0};
  std::vector<double> prim_b{0.5, 0, 0, 1, 0, 0, 0.5, 0.5, 0, 1, 0.5, 0};
  std::vector<double> prim_r{0.1, 0.15, 0.1, 0.05};

  LinkModelView links() {
    LinkModelView v;
    v.capsule_count = 2;
    v.cap_joint = cap_joint.data();
    v.cap_a = cap_a.data();
    v.cap_b = cap_b.data();
    v.cap_r = cap_r.data();
    v.self_r = self_r.data();
    v.pair_count = 1;
    v.self_pairs = pairs.data();
    v.primitive_count = 4;
    v.link_start = link_start.data();
    v.prim_joint = prim_joint.data();
    v.prim_a = prim_a.data();
    v.prim_b = prim_b.data();
    v.prim_r = prim_r.data();
    return v;
  }
  WorldSegments world() { return {cap_a.data(), cap_b.data(), prim_a.data(), prim_b.data()}; }
};

}  // namespace

TEST(fitted_self_pairs_are_the_nearest_primitive_pair_below_the_cutoff) {
  TwoLinks model;
  const LinkModelView links = model.links();
  const WorldSegments world = model.world();
  for (const double cutoff : {kInf, 1.0, 0.26}) {
    const LinkPairDistance pair = fitted_pair_distance_below(links, world, 0, 1, cutoff);
    CHECK_NEAR(pair.distance, 0.25, 1e-15);
    CHECK(pair.first.x == 0.5 && pair.first.y == 0.0 && pair.second.x == 0.5 && pair.second.y == 0.5);
  }
  // no primitive pair below the cutoff: the cutoff itself ("not below it")
  CHECK(fitted_pair_distance_below(links, world, 0, 1, 0.2).distance == 0.2);
  // the bounding capsules not below the cutoff: their distance, a lower bound
  CHECK_NEAR(fitted_pair_distance_below(links, world, 0, 1, 0.05).distance, 0.1, 1e-15);
  // symmetric in the two links (the culls run from either side)
  CHECK_NEAR(fitted_pair_distance_below(links, world, 1, 0, kInf).distance, 0.25, 1e-15);
  // the covering capsules alone say 0.1: the fitted level is what lets such links pass closer
  CHECK_NEAR(link_pair_distance(links, world, 0, 1).distance, 0.1, 1e-15);
}
