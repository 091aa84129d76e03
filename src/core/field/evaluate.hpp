// The field at one pose: the raw wrench and the constrained twist (the task-space autonomy vector).
//
// Laws in docs/field.md and field/forces.hpp; the steps and their order are those of the Python kernel this
// replaced (issue 32), so the results kept their last bit.
#pragma once

#include <cstddef>
#include <cstdint>

#include "geometry/packed.hpp"
#include "math/so3.hpp"
#include "math/vec3.hpp"

namespace pfield::field {

using math::Quat;
using math::Vec3;

// FieldConfig's parameters in declaration order (FieldConfig.packed() is this struct's memory: 16 doubles).
struct FieldParams {
  double attractive_gain;
  double rotational_attractive_gain;
  double repulsive_gain;
  double max_linear_velocity;
  double max_angular_velocity;
  double max_linear_acceleration;
  double max_angular_acceleration;
  double influence_distance;
  double attractive_threshold;
  double rotation_tolerance;
  double max_repulsive_force;
  double safety_distance;
  double damper_gain;
  double circulation_gain;
  double stagnation_window;
  double stagnation_progress;
};

// What the field keeps per obstacle besides its shape (pfield.field._evaluate.obstacle_aux: 8 doubles a row): the
// unit circulation axis, a bounding radius about the centre (the signed distance is at least |p - centre| -
// radius, so far obstacles are skipped exactly), the shape centre, and 1 for spheres (their bound is exact).
struct ObstacleAux {
  Vec3 axis;
  double radius;
  Vec3 centre;
  double sphere;
};

struct Field {
  const geometry::PackedView* packed;
  const ObstacleAux* aux;
  std::size_t obstacle_count;
  Vec3 goal_position;
  Quat goal_orientation;
  const FieldParams* params;
};

struct Wrench {
  Vec3 force;   // N
  Vec3 torque;  // N m
};

struct Twist {
  Vec3 linear;   // m/s
  Vec3 angular;  // rad/s
};

struct ConstrainedTwist {
  Twist twist;
  double clearance;      // m, the smallest signed distance over all obstacles (inf without any)
  std::int64_t nearest;  // its obstacle index, -1 without
};

// Attraction + sum of saturated Khatib repulsions, and the rotational torque k_rot log(q_g (x) q^-1).
Wrench field_wrench(const Field& field, const Vec3& p, const Quat& q);

// The constrained twist: soft-saturated attraction and rotation, the velocity dampers (deflect, then alternating
// projections while two or more bind), |v| <= v_max, and with `previous` (not null) the rate limits
// |v - v_prev| <= a_max dt (braking first) and |w - w_prev| <= alpha_max dt.
ConstrainedTwist constrained_twist(const Field& field, const Vec3& p, const Quat& q, const Twist* previous, double dt);

}  // namespace pfield::field
