// The steps of the field at a pose, shared by the one-pose evaluation (evaluate.cpp) and the lane-wise batches
// (batch.cpp): the goal's attraction and rotation terms, the obstacles' distances, the repulsion sum and the
// damper sweeps of the constrained twist. This is their one home; both callers take the same steps in the same
// order, so a pose gives the same bits whichever way it is evaluated. The laws themselves are in forces.hpp.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>

#include "field/evaluate.hpp"
#include "field/forces.hpp"
#include "geometry/sdf.hpp"
#include "math/so3.hpp"

namespace pfield::field::steps {

// damper sweeps: one deflecting, then alternating projections (narrow wedges converge slowly)
constexpr int kSweeps = 16;
constexpr double kInfinity = std::numeric_limits<double>::infinity();

// v = soft-saturated attraction toward the goal (m/s), before obstacles.
inline Vec3 attraction_twist(const Field& field, const Vec3& p) {
  const FieldParams& params = *field.params;
  const Vec3& g = field.goal_position;
  return soft_saturate(attraction({g.x - p.x, g.y - p.y, g.z - p.z}, params.attractive_gain,
                                  params.attractive_threshold),
                       params.max_linear_velocity);
}

// The goal's torque k_rot log(q_g (x) q^-1) (N m) at a unit quaternion q.
inline Vec3 goal_torque(const Field& field, const Quat& q) {
  const Vec3 r = math::rotation_error(q, field.goal_orientation);
  const double k = field.params->rotational_attractive_gain;
  return {k * r.x, k * r.y, k * r.z};
}

// omega = soft-saturated k_rot log(q_g (x) q^-1) (rad/s).
inline Vec3 rotation_twist(const Field& field, const Quat& q) {
  return soft_saturate(goal_torque(field, q), field.params->max_angular_velocity);
}

struct Bound {
  double bound;  // |p - centre| - radius <= the signed distance (equal to it for a sphere)
  Vec3 offset;   // p - centre
  double norm;   // |p - centre|
};

inline Bound lower_bound(const ObstacleAux& aux, const Vec3& p) {
  const double dx = p.x - aux.centre.x, dy = p.y - aux.centre.y, dz = p.z - aux.centre.z;
  const double norm = std::sqrt(dx * dx + dy * dy + dz * dz);
  return {norm - aux.radius, {dx, dy, dz}, norm};
}

// A sphere's outward normal from its bound, where the norm is not zero (one division, then three products).
inline Vec3 sphere_normal(const Bound& b) {
  const double inverse = 1.0 / b.norm;
  return {b.offset.x * inverse, b.offset.y * inverse, b.offset.z * inverse};
}

// The signed distance and normal of obstacle i; spheres reuse their (exact) bound, except at the centre.
inline geometry::SignedDistance signed_distance(const Field& field, std::size_t i, const Vec3& p, const Bound& b) {
  if (field.aux[i].sphere != 0.0 && b.norm > 0.0) return {b.bound, sphere_normal(b)};
  return geometry::obstacle_signed_distance(*field.packed, i, {p.x, p.y, p.z});
}

// f + m(d) n, m the saturated Khatib magnitude (forces.hpp): obstacle i's repulsion added to the force f.
inline Vec3 add_repulsion(const Vec3& f, double d, const Vec3& n, const FieldParams& params) {
  const double m = khatib_magnitude(d, params.repulsive_gain, params.influence_distance, params.max_repulsive_force);
  return {f.x + m * n.x, f.y + m * n.y, f.z + m * n.z};
}

// The approach speed (m/s) the dampers allow at signed distance d < Q (damper_speed, forces.hpp).
inline double damper_allowance(double d, const FieldParams& params) {
  const double vmax = params.max_linear_velocity;
  return damper_speed(d, params.influence_distance, params.safety_distance, params.damper_gain * vmax, vmax,
                      params.max_linear_acceleration);
}

// damper_allowance within Q, +inf beyond: with it, project_damper and deflect leave a finite twist as it is, which is
// what skipping the obstacle does (so the lanes need no branch).
inline double allowance_within(double d, const FieldParams& params) {
  return d < params.influence_distance ? damper_allowance(d, params) : kInfinity;
}

// The damper sweeps' state at one pose: the twist v, the previous linear twist s projected alongside, how many
// dampers bound on each in sweep 0, and the nearest obstacle so far (clearance, index, normal m).
struct DamperState {
  Vec3 v;
  Vec3 s;
  int active = 0;
  int active_previous = 0;
  double clearance = kInfinity;
  std::int64_t nearest = -1;
  Vec3 m;
};

// Sweep 0's bookkeeping of obstacle i at signed distance d with normal n and allowance `allowed` (allowance_within):
// the nearest obstacle so far, and s projected onto the damper. Returns the excess of v's approach speed over the
// allowance: where it is positive, deflect binds (first_sweep_deflect); elsewhere it would return v unchanged.
// `State` is a DamperState, or the batches' view of one lane of their arrays (batch.cpp): member by member, in
// selects, so that the lanes take this same function in SIMD instructions.
template <class State>
inline double first_sweep_track(State& st, std::size_t i, double d, const Vec3& n, double allowed) {
  const bool nearer = d < st.clearance;
  st.clearance = nearer ? d : st.clearance;
  st.nearest = nearer ? static_cast<std::int64_t>(i) : st.nearest;
  st.m.x = nearer ? n.x : st.m.x;
  st.m.y = nearer ? n.y : st.m.y;
  st.m.z = nearer ? n.z : st.m.z;
  const Limited projected = project_damper({st.s.x, st.s.y, st.s.z}, n, allowed);
  st.s.x = projected.v.x;
  st.s.y = projected.v.y;
  st.s.z = projected.v.z;
  st.active_previous += projected.changed;
  return -(st.v.x * n.x + st.v.y * n.y + st.v.z * n.z) - allowed;  // deflect's own test of its excess
}

// Sweep 0's deflection of v by obstacle i's damper, where first_sweep_track found a positive excess.
inline void first_sweep_deflect(DamperState& st, const Field& field, std::size_t i, const Vec3& n, double allowed) {
  const Limited deflected = deflect(st.v, n, field.aux[i].axis, allowed, field.params->circulation_gain);
  st.v = deflected.v;
  st.active += deflected.changed;
}

// Obstacle i as a sweep sees it: its signed distance, normal and damper allowance (allowance_within).
struct Sighting {
  double distance;
  Vec3 normal;
  double allowed;
};

// Obstacle i at a pose alone, in sweep `sweep` (false where the sweep skips it: beyond Q, and in sweep 0 also no
// nearer than the nearest obstacle so far), from its bound and, when needed, its exact signed distance.
inline bool sighting_at(const Field& field, std::size_t i, const Vec3& p, int sweep, double clearance, Sighting& seen) {
  const double influence = field.params->influence_distance;
  const Bound b = lower_bound(field.aux[i], p);
  if (b.bound >= influence && (sweep > 0 || b.bound >= clearance)) return false;
  const geometry::SignedDistance sd = signed_distance(field, i, p, b);
  seen = {sd.distance, sd.normal, allowance_within(sd.distance, *field.params)};
  return true;
}

// The damper sweeps from sweep `first` on, and the last step (the constrained twist's velocity dampers: docs/field.md).
// Sweep 0 deflects v by every damper within Q and projects s, tracking the nearest obstacle; while two or more dampers
// bound there, later sweeps project v and s onto every damper within Q until a sweep changes nothing (alternating
// projections onto half-spaces converge to their intersection); then, if the dampers could not all hold (a gap
// narrower than 2 d_s), the nearest obstacle's wins. `seen(i, sweep, clearance, sighting)` gives obstacle i (false
// where the sweep skips it): sighting_at for a pose alone; the batches run sweep 0 lane-wise themselves, then this
// from sweep 1 with the geometry they kept.
template <class Seen>
void damper_sweeps(DamperState& st, const Field& field, int first, Seen&& seen) {
  const FieldParams& params = *field.params;
  for (int sweep = first; sweep < kSweeps; ++sweep) {
    if (sweep > 0 && st.active < 2 && st.active_previous < 2) break;
    bool changed = false;
    for (std::size_t i = 0; i < field.obstacle_count; ++i) {
      Sighting o;
      if (!seen(i, sweep, st.clearance, o)) continue;
      if (sweep == 0) {
        if (first_sweep_track(st, i, o.distance, o.normal, o.allowed) > 0.0)
          first_sweep_deflect(st, field, i, o.normal, o.allowed);
        continue;
      }
      if (o.distance >= params.influence_distance) continue;
      const Limited projected = project_damper(st.s, o.normal, o.allowed);
      st.s = projected.v;
      const Limited hit = project_damper(st.v, o.normal, o.allowed);
      st.v = hit.v;
      changed = changed || hit.changed || projected.changed;
    }
    if (sweep > 0 && !changed) break;
  }
  if (st.active + st.active_previous >= 2 && st.clearance < params.influence_distance) {
    const double allowed = damper_allowance(st.clearance, params);
    st.v = project_damper(st.v, st.m, allowed).v;
    st.s = project_damper(st.s, st.m, allowed).v;
  }
}

// v scaled to |v| <= v_max: a projection that pushes away from an obstacle can add speed.
inline Vec3 cap_speed(const Vec3& v, double vmax) {
  const double speed = std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
  if (speed > vmax) return {v.x * vmax / speed, v.y * vmax / speed, v.z * vmax / speed};
  return v;
}

struct Avoided {
  Vec3 v;
  double clearance;
  std::int64_t nearest;
  Vec3 brake;  // unit, from the previous linear twist toward its projection (zero when it obeys every damper)
};

// Every obstacle's damper on v (sweep 0 deflects; later sweeps project while two or more bind; if they cannot all
// hold, the nearest obstacle's wins), the previous linear twist s projected alongside.
inline Avoided avoid(const Field& field, const Vec3& p, const Vec3& v, const Vec3& previous) {
  DamperState st;
  st.v = v;
  st.s = previous;
  damper_sweeps(st, field, 0, [&](std::size_t i, int sweep, double clearance, Sighting& seen) {
    return sighting_at(field, i, p, sweep, clearance, seen);
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

// field::constrained_twist (evaluate.hpp), here so that the task-space loop inlines it into its RK4 stages
// (planning/task_space.cpp): out of line, every stage passed its pose and twist through memory.
inline ConstrainedTwist constrained_twist(const Field& field, const Vec3& p, const Quat& q, const Twist* previous,
                                          double dt) {
  const FieldParams& params = *field.params;
  Vec3 w = rotation_twist(field, q);
  // without a previous twist, zeros steer the dampers' tangential side
  const Twist none{};
  const Twist& before = previous != nullptr ? *previous : none;
  const Avoided avoided = avoid(field, p, attraction_twist(field, p), before.linear);
  Vec3 v = cap_speed(avoided.v, params.max_linear_velocity);
  if (previous != nullptr) {
    v = braking_rate_limit(v, previous->linear, params.max_linear_acceleration * dt, avoided.brake,
                           params.max_linear_velocity);
    w = rate_limit(w, previous->angular, params.max_angular_acceleration * dt);
  }
  return {{v, w}, avoided.clearance, avoided.nearest};
}

}  // namespace pfield::field::steps
