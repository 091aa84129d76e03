// The field's core (src/core/field, src/core/math/so3.hpp): the laws' exact values and invariants, and the
// constrained twist against a sphere. Also run under AddressSanitizer and UBSan (make core-test).
#include <cmath>
#include <vector>

#include "field/evaluate.hpp"
#include "field/forces.hpp"
#include "harness.hpp"
#include "math/so3.hpp"
#include "planning/retime.hpp"

namespace {

using namespace pfield::field;
using pfield::math::Quat;

constexpr double kPi = 3.141592653589793;

double norm(const Vec3& v) { return std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z); }

FieldParams default_params() {  // FieldConfig()'s defaults
  return {3.0, 0.15, 0.3, 0.05, 0.4, 1.0, 0.2, 0.1, 1.0, 0.05, 10.0, 0.01, 1.0, 1.0, 10.0, 0.001};
}

}  // namespace

TEST(attraction_is_continuous_at_the_threshold_and_conical_beyond) {
  const Vec3 inside = attraction({1.0, 0.0, 0.0}, 3.0, 1.0);
  const Vec3 beyond = attraction({4.0, 0.0, 0.0}, 3.0, 1.0);
  CHECK_NEAR(inside.x, 3.0, 0.0);
  CHECK_NEAR(beyond.x, 3.0, 1e-15);  // k G e/|e|
  CHECK_NEAR(attraction({0.0, 0.5, 0.0}, 3.0, 1.0).y, 1.5, 0.0);
}

TEST(khatib_magnitude_saturates_and_vanishes_at_the_influence_distance) {
  CHECK(khatib_magnitude(0.1, 0.3, 0.1, 10.0) == 0.0);
  CHECK(khatib_magnitude(-0.01, 0.3, 0.1, 10.0) == 10.0);
  const double raw = 0.3 * (1.0 / 0.05 - 1.0 / 0.1) / (0.05 * 0.05);  // 1200 N
  CHECK_NEAR(khatib_magnitude(0.05, 0.3, 0.1, 10.0), raw / std::sqrt(1.0 + (raw / 10.0) * (raw / 10.0)), 1e-12);
  CHECK(khatib_magnitude(0.05, 0.3, 0.1, 10.0) < 10.0);
}

TEST(soft_saturation_and_rate_limits_bound_the_twist) {
  const Vec3 big = soft_saturate({3.0, 4.0, 0.0}, 0.05);
  CHECK(norm(big) <= 0.05 && norm(big) > 0.0499);  // tanh(100) rounds to 1: exactly the limit
  CHECK_NEAR(big.x / big.y, 0.75, 1e-15);
  const Vec3 step = rate_limit({1.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, 0.02);
  CHECK_NEAR(step.x, 0.02, 0.0);
  const Vec3 braked = braking_rate_limit({0.0, 0.0, 0.0}, {0.05, 0.0, 0.0}, 0.02, {-1.0, 0.0, 0.0}, 0.05);
  CHECK_NEAR(braked.x, 0.03, 1e-17);
}

TEST(dampers_allow_the_NEO_speed_and_deflect_keeps_the_speed) {
  const double s = damper_speed(0.055, 0.1, 0.01, 0.05, 0.05, 1.0);
  CHECK_NEAR(s, 0.05 * 0.045 / 0.09, 1e-17);
  CHECK_NEAR(damper_speed(0.0, 0.1, 0.01, 0.05, 0.05, 1.0), -0.05 * 0.01 / 0.09, 1e-17);
  const Vec3 toward{0.05, 0.0, 0.0}, normal{-1.0, 0.0, 0.0}, axis{0.0, 1.0, 0.0};
  const Limited deflected = deflect(toward, normal, axis, 0.01, 1.0);
  CHECK(deflected.changed);
  CHECK_NEAR(-(deflected.v.x * normal.x), 0.01, 1e-15);  // the approach is exactly the allowed one
  CHECK_NEAR(norm(deflected.v), 0.05, 1e-15);          // and the speed is kept (turned tangential)
  const Limited projected = project_damper(toward, normal, 0.01);
  CHECK_NEAR(projected.v.x, 0.01, 1e-17);
  CHECK(!project_damper({-0.05, 0.0, 0.0}, normal, 0.01).changed);  // motion away is never slowed
}

TEST(so3_exp_log_round_trip_and_rotation_error) {
  const Vec3 a{0.3, -1.1, 0.7};
  const Vec3 back = pfield::math::so3_log(pfield::math::so3_exp(a));
  CHECK_NEAR(back.x, a.x, 1e-15);
  CHECK_NEAR(back.y, a.y, 1e-15);
  CHECK_NEAR(back.z, a.z, 1e-15);
  const Quat quarter{0.0, 0.0, std::sin(kPi / 4), std::cos(kPi / 4)};  // 90 degrees about z
  const Vec3 error = pfield::math::rotation_error(Quat{}, quarter);
  CHECK_NEAR(error.z, kPi / 2, 1e-15);
  const Vec3 tiny = pfield::math::so3_log(pfield::math::so3_exp({1e-10, 0.0, 0.0}));
  CHECK_NEAR(tiny.x, 1e-10, 1e-25);
}

TEST(the_constrained_twist_slows_the_approach_to_a_sphere) {
  const FieldParams params = default_params();
  // one sphere of radius 0.1 at the origin, the goal behind it
  const std::int64_t kinds[1] = {0};
  double rows[16] = {0.0, 0.0, 0.0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0.1, 0.0, 0.0, -1.0};
  pfield::geometry::PackedView packed;
  packed.kinds = kinds;
  packed.rows = rows;
  packed.obstacle_count = 1;
  const ObstacleAux aux[1] = {{{0.0, 1.0, 0.0}, 0.1, {0.0, 0.0, 0.0}, 1.0}};
  const Field field{&packed, aux, 1, {0.5, 0.0, 0.0}, Quat{}, &params};
  const Vec3 p{-0.16, 0.0, 0.0};  // 6 cm from the surface, heading straight at it
  const ConstrainedTwist twist = constrained_twist(field, p, Quat{}, nullptr, 0.0);
  CHECK_NEAR(twist.clearance, 0.06, 1e-15);
  CHECK(twist.nearest == 0);
  const double allowed = damper_speed(0.06, 0.1, 0.01, 0.05, 0.05, 1.0);
  CHECK(twist.twist.linear.x <= allowed + 1e-15);          // the approach is held to the damper
  CHECK(norm(twist.twist.linear) <= 0.05 * (1 + 1e-15));   // and the speed to v_max
  const Field empty{&packed, aux, 0, {0.5, 0.0, 0.0}, Quat{}, &params};
  const ConstrainedTwist free = constrained_twist(empty, p, Quat{}, nullptr, 0.0);
  const Vec3 expected = soft_saturate(attraction({0.66, 0.0, 0.0}, 3.0, 1.0), 0.05);
  CHECK_NEAR(free.twist.linear.x, expected.x, 0.0);
  CHECK(std::isinf(free.clearance) && free.nearest == -1);
  const Wrench wrench = field_wrench(field, p, Quat{});
  CHECK(wrench.force.x < 3.0 * 0.66);  // repulsion pushes back against the attraction
}

TEST(retiming_keeps_the_limits_and_never_shortens_an_interval) {
  using namespace pfield::planning;
  // one joint: rest, a jump of 1 rad in one 0.02 s step, rest
  const double q[4] = {0.0, 0.0, 1.0, 1.0};
  const double h0[3] = {0.02, 0.02, 0.02};
  const double v_max[1] = {2.0}, a_max[1] = {1.4};
  const Timing timing = stretch_intervals({q, 4, 1}, h0, v_max, a_max, 2000);
  for (double h : timing.h) CHECK(h >= 0.02);
  for (std::size_t k = 0; k < 4; ++k) {
    CHECK(std::abs(timing.velocities[k]) <= 2.0 * (1 + 1e-8));
    CHECK(std::abs(timing.accelerations[k]) <= 1.4 * (1 + 1e-8));
  }
  const double arc[5] = {0.0, 0.01, 0.07, 0.08, 0.2};
  const std::vector<std::int64_t> knots = knot_indices(arc, 5, 0.05);
  CHECK(knots.size() == 3 && knots[0] == 0 && knots[1] == 2 && knots[2] == 4);
  double times[3] = {0.0, 0.0, 0.5};
  strictly_increasing(times, 3);
  CHECK(times[1] > 0.0 && times[1] < 1e-300);
}
