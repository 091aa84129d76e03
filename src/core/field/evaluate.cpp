#include "field/evaluate.hpp"

#include <cmath>
#include <limits>

#include "field/forces.hpp"
#include "geometry/sdf.hpp"

namespace pfield::field {
namespace {

constexpr int kSweeps = 16;  // damper sweeps: one deflecting, then alternating projections (narrow wedges converge slowly)

struct Bound {
  double bound;  // |p - centre| - radius <= the signed distance
  Vec3 offset;   // p - centre
  double norm;   // |p - centre|
};

Bound lower_bound(const ObstacleAux& aux, const Vec3& p) {
  const double dx = p.x - aux.centre.x, dy = p.y - aux.centre.y, dz = p.z - aux.centre.z;
  const double norm = std::sqrt(dx * dx + dy * dy + dz * dz);
  return {norm - aux.radius, {dx, dy, dz}, norm};
}

// The signed distance and normal of obstacle i; spheres reuse their (exact) bound.
geometry::SignedDistance signed_distance(const Field& field, std::size_t i, const Vec3& p, const Bound& b) {
  if (field.aux[i].sphere != 0.0 && b.norm > 0.0) {
    const double inverse = 1.0 / b.norm;
    return {b.bound, {b.offset.x * inverse, b.offset.y * inverse, b.offset.z * inverse}};
  }
  return geometry::obstacle_signed_distance(*field.packed, i, {p.x, p.y, p.z});
}

double damper_allowance(double d, const FieldParams& params) {
  const double vmax = params.max_linear_velocity;
  return damper_speed(d, params.influence_distance, params.safety_distance, params.damper_gain * vmax, vmax,
                      params.max_linear_acceleration);
}

struct Avoided {
  Vec3 v;
  double clearance;
  std::int64_t nearest;
  Vec3 brake;  // unit, from the previous linear twist toward its projection (zero when it obeys every damper)
};

// Every obstacle's damper on v (sweep 0 deflects; later sweeps project while two or more bind; if they cannot all
// hold, the nearest obstacle's wins), the previous linear twist s projected alongside.
Avoided avoid(const Field& field, const Vec3& p, Vec3 v, const Vec3& previous) {
  const FieldParams& params = *field.params;
  const double influence = params.influence_distance;
  Vec3 s = previous;
  int active = 0, active_previous = 0;
  double clearance = std::numeric_limits<double>::infinity();
  std::int64_t nearest = -1;
  Vec3 m{0.0, 0.0, 0.0};
  for (int sweep = 0; sweep < kSweeps; ++sweep) {
    if (sweep > 0 && active < 2 && active_previous < 2) break;
    bool changed = false;
    for (std::size_t i = 0; i < field.obstacle_count; ++i) {
      const Bound b = lower_bound(field.aux[i], p);
      if (b.bound >= influence && (sweep > 0 || b.bound >= clearance)) continue;
      const geometry::SignedDistance sd = signed_distance(field, i, p, b);
      const double d = sd.distance;
      const Vec3 n{sd.normal.x, sd.normal.y, sd.normal.z};
      if (sweep == 0) {
        if (d < clearance) {
          clearance = d;
          nearest = static_cast<std::int64_t>(i);
          m = n;
        }
        if (d < influence) {
          const double allowed = damper_allowance(d, params);
          const Limited projected = project_damper(s, n, allowed);
          s = projected.v;
          const ObstacleAux& aux = field.aux[i];
          const Limited deflected = deflect(v, n, aux.axis, allowed, params.circulation_gain);
          v = deflected.v;
          active += deflected.changed;
          active_previous += projected.changed;
        }
        continue;
      }
      if (d >= influence) continue;
      const double allowed = damper_allowance(d, params);
      const Limited projected = project_damper(s, n, allowed);
      s = projected.v;
      const Limited hit = project_damper(v, n, allowed);
      v = hit.v;
      changed = changed || hit.changed || projected.changed;
    }
    if (sweep > 0 && !changed) break;
  }
  if (active + active_previous >= 2 && clearance < influence) {  // a gap narrower than 2 d_s: the nearest wins
    const double allowed = damper_allowance(clearance, params);
    v = project_damper(v, m, allowed).v;
    s = project_damper(s, m, allowed).v;
  }
  double bx = s.x - previous.x, by = s.y - previous.y, bz = s.z - previous.z;
  const double brake = std::sqrt(bx * bx + by * by + bz * bz);
  if (brake > 0.0) {
    bx = bx / brake;
    by = by / brake;
    bz = bz / brake;
  }
  return {v, clearance, nearest, {bx, by, bz}};
}

Vec3 cap_speed(const Vec3& v, double vmax) {
  const double speed = std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
  if (speed > vmax) return {v.x * vmax / speed, v.y * vmax / speed, v.z * vmax / speed};
  return v;
}

}  // namespace

Wrench field_wrench(const Field& field, const Vec3& p, const Quat& q) {
  const FieldParams& params = *field.params;
  const Vec3& g = field.goal_position;
  Vec3 f = attraction({g.x - p.x, g.y - p.y, g.z - p.z}, params.attractive_gain, params.attractive_threshold);
  const double influence = params.influence_distance;
  for (std::size_t i = 0; i < field.obstacle_count; ++i) {
    const Bound b = lower_bound(field.aux[i], p);
    if (b.bound >= influence) continue;
    const geometry::SignedDistance sd = signed_distance(field, i, p, b);
    const double m = khatib_magnitude(sd.distance, params.repulsive_gain, influence, params.max_repulsive_force);
    f = {f.x + m * sd.normal.x, f.y + m * sd.normal.y, f.z + m * sd.normal.z};
  }
  const Vec3 r = math::rotation_error(q, field.goal_orientation);
  const double k = params.rotational_attractive_gain;
  return {f, {k * r.x, k * r.y, k * r.z}};
}

ConstrainedTwist constrained_twist(const Field& field, const Vec3& p, const Quat& q, const Twist* previous,
                                   double dt) {
  const FieldParams& params = *field.params;
  const Vec3& g = field.goal_position;
  Vec3 v = soft_saturate(attraction({g.x - p.x, g.y - p.y, g.z - p.z}, params.attractive_gain,
                                    params.attractive_threshold),
                         params.max_linear_velocity);
  const Vec3 r = math::rotation_error(q, field.goal_orientation);
  const double k = params.rotational_attractive_gain;
  Vec3 w = soft_saturate({k * r.x, k * r.y, k * r.z}, params.max_angular_velocity);
  // without a previous twist, zeros steer the dampers' tangential side (as the numba kernels' scratch does)
  const Twist none{};
  const Twist& before = previous != nullptr ? *previous : none;
  const Avoided avoided = avoid(field, p, v, before.linear);
  v = cap_speed(avoided.v, params.max_linear_velocity);
  if (previous != nullptr) {
    v = braking_rate_limit(v, previous->linear, params.max_linear_acceleration * dt, avoided.brake,
                           params.max_linear_velocity);
    w = rate_limit(w, previous->angular, params.max_angular_acceleration * dt);
  }
  return {{v, w}, avoided.clearance, avoided.nearest};
}

}  // namespace pfield::field
