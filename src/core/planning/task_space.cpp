#include "planning/task_space.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "field/steps.hpp"
#include "geometry/sdf.hpp"
#include "math/so3.hpp"
#include "planning/segment_free.hpp"

namespace pfield::planning {
namespace {

using field::Twist;
using math::Quat;
using math::Vec3;

constexpr std::int64_t kSegmentSamples = 16;

struct Stage {
  Twist twist;
  double clearance;
  std::int64_t nearest;
};

// The RK4 mean twist of one step of dt from (p, q), and the clearance at p with its obstacle. `k` holds the stage
// twists, kept from step to step: stage 0 moves by 0 along the previous step's first stage, as the numba loop
// does (the same signed zeros, the same bits).
// Speed: the field's steps are inlined here (field/steps.hpp) and each stage starts from the previous stage's twist
// held in registers (`from`), not read back from k: a plan is one chain of dependent stages, and a call per stage
// with k in memory made the obstacle-free plans 12% slower. (Unrolling the stages gains 8% more there but
// cost 7% on the seed example's primitives and mesh when their distances were calls: the loop stays rolled.)
Stage rk4_twist(const field::Field& field, const Vec3& p, const Quat& q, const Twist& previous, double dt,
                Twist (&k)[4]) {
  double clearance = std::numeric_limits<double>::infinity();
  std::int64_t nearest = -1;
  Twist from = k[0];
  for (int s = 0; s < 4; ++s) {
    const double h = s == 0 ? 0.0 : (s == 3 ? dt : 0.5 * dt);
    const Vec3 stage{p.x + h * from.linear.x, p.y + h * from.linear.y, p.z + h * from.linear.z};
    const Quat turned = math::left_increment(q, from.angular, h);
    const field::ConstrainedTwist result = field::steps::constrained_twist(field, stage, turned, &previous, dt);
    from = result.twist;
    k[s] = result.twist;
    if (s == 0) {
      clearance = result.clearance;
      nearest = result.nearest;
    }
  }
  const auto mean = [](double a, double b, double c, double d) { return (a + 2.0 * b + 2.0 * c + d) / 6.0; };
  const Twist out{{mean(k[0].linear.x, k[1].linear.x, k[2].linear.x, k[3].linear.x),
                   mean(k[0].linear.y, k[1].linear.y, k[2].linear.y, k[3].linear.y),
                   mean(k[0].linear.z, k[1].linear.z, k[2].linear.z, k[3].linear.z)},
                  {mean(k[0].angular.x, k[1].angular.x, k[2].angular.x, k[3].angular.x),
                   mean(k[0].angular.y, k[1].angular.y, k[2].angular.y, k[3].angular.y),
                   mean(k[0].angular.z, k[1].angular.z, k[2].angular.z, k[3].angular.z)}};
  return {out, clearance, nearest};
}

// The straight segment a -> b stays outside every obstacle: certified by 1-Lipschitz distances when
// |b - a| < d(a) + d(b), else sampled at t = 1/16 .. 15/16 (planning/segment_free.hpp; b is the next waypoint,
// which the loop checks itself). A sample collides when its distance is <= 0 (NaN does not): geometry::inside_any,
// distances alone, stopping at the first obstacle that holds it.
bool segment_is_free(const geometry::PackedView& packed, const double* a, const Vec3& b, double clearance_a,
                     double clearance_b) {
  const double ax = a[0], ay = a[1], az = a[2];
  const double length = std::sqrt((b.x - ax) * (b.x - ax) + (b.y - ay) * (b.y - ay) + (b.z - az) * (b.z - az));
  if (clearance_a > 0.0 && clearance_b > 0.0 && length < clearance_a + clearance_b) return true;
  return samples_valid(kSegmentSamples, kSegmentSamples - 1, [&](double t) {
    const geometry::Vec3 point{ax + t * (b.x - ax), ay + t * (b.y - ay), az + t * (b.z - az)};
    return !geometry::inside_any(packed, point);
  });
}

}  // namespace

LoopResult plan_task_space(const field::Field& field, const double* start, const TaskSpaceSettings& settings,
                           const std::uint8_t* cancel, double* poses, double* twists, double* clearances) {
  Vec3 p{start[0], start[1], start[2]};
  Quat q{start[3], start[4], start[5], start[6]};
  std::copy(start, start + 7, poses);
  Twist previous{};
  Twist stages[4] = {};
  const Vec3& g = field.goal_position;
  const Quat& goal = field.goal_orientation;
  const double inf = std::numeric_limits<double>::infinity();
  Progress progress{inf, inf, inf, inf};
  const std::int64_t limit = settings.max_iterations;
  for (std::int64_t i = 0; i <= limit; ++i) {
    const Stage stage = rk4_twist(field, p, q, previous, settings.dt, stages);
    const Twist& twist = stage.twist;
    double* row = twists + 6 * i;
    row[0] = twist.linear.x, row[1] = twist.linear.y, row[2] = twist.linear.z;
    row[3] = twist.angular.x, row[4] = twist.angular.y, row[5] = twist.angular.z;
    clearances[i] = stage.clearance;
    if (stage.clearance <= 0.0) return {std::max<std::int64_t>(i, 1), PlanStatus::Collision, stage.nearest};
    if (i > 0 && !segment_is_free(*field.packed, poses + 7 * (i - 1), p, clearances[i - 1], stage.clearance))
      return {i, PlanStatus::Collision,
              geometry::min_signed_distance(*field.packed, {p.x, p.y, p.z}).index};
    const double position_error =
        std::sqrt((g.x - p.x) * (g.x - p.x) + (g.y - p.y) * (g.y - p.y) + (g.z - p.z) * (g.z - p.z));
    const double rotation_error = math::angle(q, goal);
    if (position_error <= settings.goal_tolerance && rotation_error <= settings.rotation_tolerance)
      return {i + 1, PlanStatus::Reached, -1};
    if (i == limit) return {i + 1, PlanStatus::IterationLimit, stage.nearest};
    if (__atomic_load_n(cancel, __ATOMIC_RELAXED) != 0) return {i + 1, PlanStatus::Cancelled, stage.nearest};
    if (progress.stuck(i, settings.window, settings.progress, position_error, rotation_error))
      return {i + 1, PlanStatus::Stagnation, stage.nearest};
    // advance: p += dt v, q <- exp(dt w) (x) q; the twist becomes the previous one
    p = {p.x + settings.dt * twist.linear.x, p.y + settings.dt * twist.linear.y, p.z + settings.dt * twist.linear.z};
    q = math::left_increment(q, twist.angular, settings.dt);
    previous = twist;
    double* pose = poses + 7 * (i + 1);
    pose[0] = p.x, pose[1] = p.y, pose[2] = p.z, pose[3] = q.x, pose[4] = q.y, pose[5] = q.z, pose[6] = q.w;
    if (!(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))) return {i + 2, PlanStatus::NotFinite, -1};
  }
  return {limit + 1, PlanStatus::IterationLimit, -1};
}

double rk4_steps(const field::Field& field, const double* pose, const double* previous, double dt,
                 std::int64_t count) {
  const Vec3 p{pose[0], pose[1], pose[2]};
  const Quat q{pose[3], pose[4], pose[5], pose[6]};
  const Twist before{{previous[0], previous[1], previous[2]}, {previous[3], previous[4], previous[5]}};
  Twist stages[4] = {};
  double total = 0.0;
  for (std::int64_t i = 0; i < count; ++i) total += rk4_twist(field, p, q, before, dt, stages).twist.linear.x;
  return total;
}

}  // namespace pfield::planning
