#include "field/evaluate.hpp"

#include <cmath>

#include "field/forces.hpp"
#include "field/steps.hpp"

namespace pfield::field {

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

// The steps are steps::constrained_twist's (steps.hpp), which the task-space loop inlines.
ConstrainedTwist constrained_twist(const Field& field, const Vec3& p, const Quat& q, const Twist* previous,
                                   double dt) {
  return steps::constrained_twist(field, p, q, previous, dt);
}

}  // namespace pfield::field
