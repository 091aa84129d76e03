#include "field/evaluate.hpp"

#include <cmath>

#include "field/forces.hpp"
#include "field/steps.hpp"

namespace pfield::field {
namespace {

struct Avoided {
  Vec3 v;
  double clearance;
  std::int64_t nearest;
  Vec3 brake;  // unit, from the previous linear twist toward its projection (zero when it obeys every damper)
};

// Every obstacle's damper on v (sweep 0 deflects; later sweeps project while two or more bind; if they cannot all
// hold, the nearest obstacle's wins), the previous linear twist s projected alongside (steps.hpp).
Avoided avoid(const Field& field, const Vec3& p, const Vec3& v, const Vec3& previous) {
  steps::DamperState st;
  st.v = v;
  st.s = previous;
  steps::damper_sweeps(st, field, 0, [&](std::size_t i, int sweep, double clearance, steps::Sighting& seen) {
    return steps::sighting_at(field, i, p, sweep, clearance, seen);
  });
  double bx = st.s.x - previous.x, by = st.s.y - previous.y, bz = st.s.z - previous.z;
  const double brake = std::sqrt(bx * bx + by * by + bz * bz);
  if (brake > 0.0) {
    bx = bx / brake;
    by = by / brake;
    bz = bz / brake;
  }
  return {st.v, st.clearance, st.nearest, {bx, by, bz}};
}

}  // namespace

Wrench field_wrench(const Field& field, const Vec3& p, const Quat& q) {
  const FieldParams& params = *field.params;
  const Vec3& g = field.goal_position;
  Vec3 f = attraction({g.x - p.x, g.y - p.y, g.z - p.z}, params.attractive_gain, params.attractive_threshold);
  for (std::size_t i = 0; i < field.obstacle_count; ++i) {
    const steps::Bound b = steps::lower_bound(field.aux[i], p);
    if (b.bound >= params.influence_distance) continue;
    const geometry::SignedDistance sd = steps::signed_distance(field, i, p, b);
    f = steps::add_repulsion(f, sd.distance, sd.normal, params);
  }
  return {f, steps::goal_torque(field, q)};
}

ConstrainedTwist constrained_twist(const Field& field, const Vec3& p, const Quat& q, const Twist* previous,
                                   double dt) {
  const FieldParams& params = *field.params;
  Vec3 w = steps::rotation_twist(field, q);
  // without a previous twist, zeros steer the dampers' tangential side
  const Twist none{};
  const Twist& before = previous != nullptr ? *previous : none;
  const Avoided avoided = avoid(field, p, steps::attraction_twist(field, p), before.linear);
  Vec3 v = steps::cap_speed(avoided.v, params.max_linear_velocity);
  if (previous != nullptr) {
    v = braking_rate_limit(v, previous->linear, params.max_linear_acceleration * dt, avoided.brake,
                           params.max_linear_velocity);
    w = rate_limit(w, previous->angular, params.max_angular_acceleration * dt);
  }
  return {{v, w}, avoided.clearance, avoided.nearest};
}

}  // namespace pfield::field
