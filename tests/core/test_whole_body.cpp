// The whole-body step, loop and stepper (src/core/planning/whole_body) on a small planar arm built here: a plan to a
// reachable pose is reached within the joint limits, a sphere in the way keeps its distance (the dampers), a set
// cancel flag ends the plan at once, the stepper refuses what check_joint_angles refuses and clips a previous
// velocity beyond the limits. Run under AddressSanitizer and UBSan (make core-test): the workspace is sized for the
// most rows a step can add. tests/planning/test_core_whole_body.py holds these functions to numba's twins bit for
// bit.
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "harness.hpp"
#include "math/so3.hpp"
#include "planning/whole_body.hpp"
#include "robot/kinematics.hpp"

namespace {

using namespace pfield;
using planning::PlanStatus;
using planning::WholeBodyParams;

// Three revolute joints about z, 0.3 m apart along x; the tool 0.2 m beyond the last. Each joint carries one link
// capsule (its segment to the next joint) with one fitted primitive inside it; links 0 and 2 are a self pair.
struct PlanarArm {
  static constexpr std::size_t n = 3, caps = 3, prims = 3, pairs = 1;
  std::int64_t parents[n] = {-1, 0, 1};
  double place_rot[9 * n] = {1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  double place_pos[3 * n] = {0.0, 0.0, 0.0, 0.3, 0.0, 0.0, 0.3, 0.0, 0.0};
  double axes[3 * n] = {0, 0, 1, 0, 0, 1, 0, 0, 1};
  std::int64_t kinds[n] = {0, 0, 0};
  std::int64_t support[n * n] = {1, 0, 0, 1, 1, 0, 1, 1, 1};
  double ee_rot[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  double ee_pos[3] = {0.2, 0.0, 0.0};
  std::int64_t cap_joint[caps] = {0, 1, 2};
  double cap_a[3 * caps] = {0.02, 0, 0, 0.02, 0, 0, 0.02, 0, 0};
  double cap_b[3 * caps] = {0.26, 0, 0, 0.26, 0, 0, 0.18, 0, 0};
  double cap_r[caps] = {0.04, 0.04, 0.04};
  double self_r[caps] = {0.03, 0.03, 0.03};
  std::int64_t self_pairs[2 * pairs] = {0, 2};
  std::int64_t link_start[caps + 1] = {0, 1, 2, 3};
  std::int64_t prim_joint[prims] = {0, 1, 2};
  double prim_r[prims] = {0.03, 0.03, 0.03};
  double lower[n] = {-2.5, -2.5, -2.5};
  double upper[n] = {2.5, 2.5, 2.5};
  double max_velocity[n] = {1.5, 1.5, 1.5};
  double max_acceleration[n] = {8.0, 8.0, 8.0};

  robot::RobotView view() const {
    robot::RobotView v;
    v.kinematics = {n, parents, place_rot, place_pos, axes, kinds, support, 2, ee_rot, ee_pos};
    v.links = {caps,  cap_joint, cap_a,      cap_b,      cap_r,  self_r, pairs,
               self_pairs, prims, link_start, prim_joint, cap_a, cap_b,  prim_r};
    v.limits = {lower, upper, max_velocity, max_acceleration};
    return v;
  }
};

// A packed set of zero or one sphere, with its bounding sphere and zero offsets.
struct Obstacles {
  std::int64_t kinds[1] = {0};
  double rows[16] = {};
  double centres[3] = {};
  double bounds[1] = {};
  double obstacle_offsets[PlanarArm::caps] = {};
  double self_offsets[PlanarArm::pairs] = {};
  geometry::PackedView packed{};

  Obstacles(bool one, math::Vec3 centre, double radius) {
    rows[0] = centres[0] = centre.x, rows[1] = centres[1] = centre.y, rows[2] = centres[2] = centre.z;
    rows[3] = rows[7] = rows[11] = 1.0;  // identity rotation
    rows[12] = bounds[0] = radius;
    rows[15] = -1.0;
    packed.kinds = kinds;
    packed.rows = rows;
    packed.obstacle_count = one ? 1 : 0;
  }

  planning::WholeBodyScene scene() const { return {{&packed, centres, bounds}, obstacle_offsets, self_offsets}; }
};

WholeBodyParams params() {
  WholeBodyParams p{};
  p.attractive_gain = 2.0, p.rotational_attractive_gain = 1.0, p.attractive_threshold = 0.3;
  p.max_linear_velocity = 0.5, p.max_angular_velocity = 1.0;
  p.influence_distance = 0.15, p.safety_distance = 0.03, p.damper_gain = 1.0;
  p.repulsive_gain = 0.01, p.max_repulsive_force = 5.0;
  p.dt = 0.01, p.goal_tolerance = 0.005, p.rotation_tolerance = 0.05;
  p.stagnation_steps = 200, p.stagnation_progress = 1e-4;
  p.joint_influence = 0.1, p.joint_safety = 0.01;
  p.rotation_weight = 0.1, p.damping = 1e-3, p.null_space_gain = 0.3;
  return p;
}

// The tool's pose at q, as a goal.
planning::Goal goal_at(const PlanarArm& arm, const double* q) {
  std::vector<double> rotations(9 * PlanarArm::n), origins(3 * PlanarArm::n);
  robot::Frames frames{rotations.data(), origins.data()};
  const robot::FramePose pose = robot::end_effector_kinematics(arm.view().kinematics, q, frames, nullptr);
  return {pose.position, math::from_matrix(pose.rotation)};
}

struct Path {
  std::vector<double> joints, velocities, positions, orientations, twists, clearances;
  explicit Path(std::size_t rows)
      : joints(rows * PlanarArm::n), velocities(rows * PlanarArm::n), positions(rows * 3), orientations(rows * 4),
        twists(rows * 6), clearances(rows) {}
  planning::WholeBodyPath view() {
    return {joints.data(), velocities.data(), positions.data(), orientations.data(), twists.data(),
            clearances.data()};
  }
};

TEST(a_reachable_pose_is_reached_within_the_limits) {
  const PlanarArm arm;
  const Obstacles none(false, {}, 0.0);
  const double q0[3] = {0.2, 0.4, -0.3}, target[3] = {0.9, -0.5, 0.6};
  const std::int64_t iterations = 3000;
  Path path(iterations + 1);
  const std::uint8_t cancel = 0;
  const planning::WholeBodyPlanResult result = planning::plan_whole_body(
      q0, arm.view(), none.scene(), goal_at(arm, target), params(), iterations, &cancel, path.view());
  CHECK(result.status == PlanStatus::Reached);
  CHECK(result.count > 1 && result.count <= iterations + 1);
  CHECK(result.last.position_error <= 0.005 && result.last.rotation_error <= 0.05);
  for (std::int64_t k = 0; k < result.count; ++k)
    for (std::size_t j = 0; j < PlanarArm::n; ++j) {
      CHECK(path.joints[k * 3 + j] >= arm.lower[j] && path.joints[k * 3 + j] <= arm.upper[j]);
      CHECK(std::abs(path.velocities[k * 3 + j]) <= arm.max_velocity[j] + 1e-12);
    }
  for (std::size_t j = 0; j < PlanarArm::n; ++j) CHECK(path.velocities[(result.count - 1) * 3 + j] == 0.0);
  CHECK(std::isinf(path.clearances[0]));  // no obstacles
}

TEST(the_dampers_keep_the_links_off_a_sphere_in_the_way) {
  const PlanarArm arm;
  // a ball beside the arm's straight-line sweep toward the target
  const Obstacles ball(true, {0.45, 0.25, 0.0}, 0.05);
  const double q0[3] = {0.0, 0.0, 0.0}, target[3] = {1.2, 0.0, 0.0};
  const std::int64_t iterations = 2000;
  Path path(iterations + 1);
  const std::uint8_t cancel = 0;
  const WholeBodyParams p = params();
  const planning::WholeBodyPlanResult result = planning::plan_whole_body(
      q0, arm.view(), ball.scene(), goal_at(arm, target), p, iterations, &cancel, path.view());
  CHECK(result.status != PlanStatus::Collision);
  for (std::int64_t k = 0; k < result.count; ++k) CHECK(path.clearances[k] > 0.0);
  CHECK(result.last.nearest_obstacle == 0.0 || result.last.nearest_obstacle == -1.0);
}

TEST(a_set_cancel_flag_ends_the_plan_after_the_start) {
  const PlanarArm arm;
  const Obstacles none(false, {}, 0.0);
  const double q0[3] = {0.2, 0.4, -0.3}, target[3] = {0.9, -0.5, 0.6};
  Path path(101);
  const std::uint8_t cancel = 1;
  const planning::WholeBodyPlanResult result = planning::plan_whole_body(
      q0, arm.view(), none.scene(), goal_at(arm, target), params(), 100, &cancel, path.view());
  CHECK(result.status == PlanStatus::Cancelled && result.count == 1);
}

TEST(the_stepper_checks_its_inputs_and_clips_the_previous_velocity) {
  const PlanarArm arm;
  const Obstacles ball(true, {0.45, 0.25, 0.0}, 0.05);
  const double target[3] = {0.9, -0.5, 0.6};
  planning::WholeBodyStepper stepper(arm.view(), ball.scene(), goal_at(arm, target), params());
  const double q[3] = {0.1, 0.2, 0.3}, tolerance = 1e-4;
  CHECK(stepper.step(q, 3, nullptr, 0, 0.0, tolerance));
  CHECK(stepper.joint_count() == 3);
  CHECK(!stepper.step(q, 2, nullptr, 0, 0.0, tolerance));                          // too few values
  const double beyond[3] = {2.5 + 2e-4, 0.0, 0.0}, within[3] = {2.5 + 5e-5, 0.0, 0.0};
  CHECK(!stepper.step(beyond, 3, nullptr, 0, 0.0, tolerance));                     // beyond the tolerance
  CHECK(stepper.step(within, 3, nullptr, 0, 0.0, tolerance));                      // clamped onto the limit
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double bad[3] = {0.0, nan, 0.0};
  CHECK(!stepper.step(bad, 3, nullptr, 0, 0.0, tolerance));
  CHECK(!stepper.step(q, 3, bad, 3, 0.01, tolerance));                             // previous not finite
  CHECK(!stepper.step(q, 3, q, 2, 0.01, tolerance));                               // previous too short
  CHECK(!stepper.step(q, 3, nullptr, 0, -0.01, tolerance));                        // dt < 0
  CHECK(!stepper.step(q, 3, nullptr, 0, nan, tolerance));
  // a previous velocity far beyond the limits is clipped first: the rate limit then starts from the limit
  const double fast[3] = {100.0, -100.0, 0.0}, clipped[3] = {1.5, -1.5, 0.0};
  CHECK(stepper.step(q, 3, fast, 3, 0.01, tolerance));
  std::vector<double> from_fast(stepper.joint_velocities(), stepper.joint_velocities() + 3);
  CHECK(stepper.step(q, 3, clipped, 3, 0.01, tolerance));
  for (std::size_t j = 0; j < 3; ++j) CHECK(from_fast[j] == stepper.joint_velocities()[j]);
}

}  // namespace
