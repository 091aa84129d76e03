// The output contract (src/core/safety/limits.hpp): its rules on twists and whole-body commands, in the one compiled
// copy every binding and pfield.safety call. Also run under AddressSanitizer and UBSan (make core-test);
// tests/test_output_contract.py holds the bindings' commands to pfield.safety's.
#include <cmath>
#include <limits>

#include "harness.hpp"
#include "safety/limits.hpp"

namespace {

using pfield::safety::Outcome;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

}  // namespace

TEST(safety_a_twist_within_its_limits_is_unchanged) {
  double v[6] = {0.03, 0.0, -0.04, 0.1, 0.2, 0.0};
  CHECK(pfield::safety::limit_twist(v, 0.05, 0.4) == Outcome::Within);
  CHECK(v[0] == 0.03 && v[2] == -0.04 && v[3] == 0.1 && v[4] == 0.2);
}

TEST(safety_a_twist_beyond_a_limit_is_scaled_by_one_factor_keeping_its_direction) {
  double v[6] = {0.3, 0.0, -0.4, 0.1, 0.0, 0.0};  // |linear| = 0.5 m/s: ten times the limit
  CHECK(pfield::safety::limit_twist(v, 0.05, 0.4) == Outcome::Scaled);
  CHECK_NEAR(std::hypot(v[0], v[1], v[2]), 0.05, 1e-15);
  CHECK_NEAR(v[0] / v[2], -0.75, 1e-15);
  CHECK_NEAR(v[3], 0.01, 1e-15);  // the angular part by the same factor
}

TEST(safety_huge_components_scale_to_the_limit_without_overflow) {
  // |linear| = sqrt(2) 1e300 (its square would overflow) against 1 m/s, |angular| = 1e300 against 2 rad/s: the
  // linear part's factor is the smaller
  double v[6] = {1e300, 1e300, 0.0, 0.0, 0.0, 1e300};
  CHECK(pfield::safety::limit_twist(v, 1.0, 2.0) == Outcome::Scaled);
  CHECK_NEAR(std::hypot(v[0], v[1], v[2]), 1.0, 1e-15);
  CHECK_NEAR(v[5], 1.0 / std::sqrt(2.0), 1e-15);
}

TEST(safety_a_command_that_is_not_finite_is_halted) {
  double v[6] = {0.0, kNaN, 0.0, 0.0, 0.0, 0.0};
  CHECK(pfield::safety::limit_twist(v, 1.0, 1.0) == Outcome::Halted);
  for (double x : v) CHECK(x == 0.0);
  double qd[2] = {1.0, kInf}, twist[6] = {0.1, 0.0, 0.0, 0.0, 0.0, 0.0};
  const double limits[2] = {1.0, 1.0};
  CHECK(pfield::safety::limit_joint_command(qd, 2, twist, limits, 1.0, 1.0) == Outcome::Halted);
  CHECK(qd[0] == 0.0 && qd[1] == 0.0 && twist[0] == 0.0);
}

TEST(safety_a_whole_body_command_takes_the_smaller_factor_for_joints_and_twist) {
  // joints: 2 rad/s against 1 (factor 1/2); twist: 0.1 m/s against 0.05 (factor 1/2) and 1 rad/s against 0.4
  double qd[3] = {2.0, -0.5, 0.1}, twist[6] = {0.1, 0.0, 0.0, 1.0, 0.0, 0.0};
  const double limits[3] = {1.0, 0.0, kInf};  // a zero or infinite limit bounds nothing
  CHECK(pfield::safety::limit_joint_command(qd, 3, twist, limits, 0.05, 0.4) == Outcome::Scaled);
  CHECK_NEAR(qd[0], 0.8, 1e-15);
  CHECK_NEAR(qd[1], -0.2, 1e-15);
  CHECK_NEAR(twist[3], 0.4, 1e-15);
  CHECK_NEAR(twist[0], 0.04, 1e-15);
}
