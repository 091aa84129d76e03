// Shared-control assistance (src/core/shared_control/assist): its laws' values and invariants, task space against a
// sphere and whole body on a two-link planar arm. Also run under AddressSanitizer and UBSan (make core-test).
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "field/forces.hpp"
#include "geometry/packed.hpp"
#include "harness.hpp"
#include "robot/kinematics.hpp"
#include "shared_control/assist.hpp"

namespace {

using namespace pfield::shared_control;
using pfield::geometry::PackedView;

constexpr double kInf = std::numeric_limits<double>::infinity();

// FieldConfig()'s damper settings, Servo's scene threshold
AssistParams default_params() { return {0.1, 0.01, 1.0, 0.05, 1.0, 0.4, 0.02}; }

// One packed sphere of radius r at c (identity rotation, no mesh).
struct OneSphere {
  explicit OneSphere(Vec3 c, double r)
      : kinds{0}, rows{c.x, c.y, c.z, 1, 0, 0, 0, 1, 0, 0, 0, 1, r, 0, 0, -1} {
    view.kinds = kinds.data();
    view.rows = rows.data();
    view.obstacle_count = 1;
  }
  std::vector<std::int64_t> kinds;
  std::vector<double> rows;
  PackedView view;
};

// A planar two-link arm (revolute about z, links of 0.3 m along x, one capsule of radius 2 cm and one primitive each,
// limits +-3 rad, 1 rad/s, 5 rad/s^2): views of its own arrays.
struct PlanarArm {
  PlanarArm() {
    robot.kinematics = {2, parents, place_rot, place_pos, axes, kinds, support, 1, ee_rot, ee_pos};
    robot.links = {2, cap_joint, seg_a, seg_b, radii, radii, 0, nullptr, 2, link_start, cap_joint, seg_a, seg_b,
                   radii};
    robot.limits = {lower, upper, vmax, amax};
  }
  PlanarArm(const PlanarArm&) = delete;
  PlanarArm& operator=(const PlanarArm&) = delete;

  const std::int64_t parents[2] = {-1, 0}, kinds[2] = {0, 0}, support[4] = {1, 0, 1, 1};
  const double place_rot[18] = {1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  const double place_pos[6] = {0, 0, 0, 0.3, 0, 0}, axes[6] = {0, 0, 1, 0, 0, 1};
  const double ee_rot[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, ee_pos[3] = {0.3, 0, 0};
  const std::int64_t cap_joint[2] = {0, 1}, link_start[3] = {0, 1, 2};
  const double seg_a[6] = {0, 0, 0, 0, 0, 0}, seg_b[6] = {0.3, 0, 0, 0.3, 0, 0}, radii[2] = {0.02, 0.02};
  const double lower[2] = {-3, -3}, upper[2] = {3, 3}, vmax[2] = {1, 1}, amax[2] = {5, 5};
  pfield::robot::RobotView robot;
};

double approach(const double* v, Vec3 n, Vec3 o) {
  return -(n.x * (v[0] - o.x) + n.y * (v[1] - o.y) + n.z * (v[2] - o.z));
}

}  // namespace

TEST(obstacle_share_and_servo_scale_follow_their_laws) {
  CHECK(obstacle_share(0.2, 0.1, 0.01) == 0.0);
  CHECK(obstacle_share(0.005, 0.1, 0.01) == 1.0);
  CHECK_NEAR(obstacle_share(0.055, 0.1, 0.01), 0.5, 1e-15);
  CHECK(servo_scale(0.02, 0.02) == 1.0 && servo_scale(0.0, 0.02) == 0.0 && servo_scale(-1.0, 0.02) == 0.0);
  CHECK_NEAR(servo_scale(0.01, 0.02), std::pow(1000.0, -0.5), 1e-15);  // halfway: 0.001^(1/2)
  CHECK_NEAR(servo_scale(1e-12, 0.02), 0.001, 1e-12);
}

TEST(limit_approach_passes_motion_away_and_holds_every_damper) {
  // two dampers meeting at 90 degrees, one obstacle moving toward the point
  const MovingDamper dampers[2] = {{{-1.0, 0.0, 0.0}, 0.01, {0.0, 0.0, 0.0}},
                                   {{0.0, -1.0, 0.0}, 0.02, {0.0, -0.03, 0.0}}};
  const Approach away = limit_approach(dampers, 2, {-0.04, -0.05, 0.01});  // away from both (faster than the second)
  CHECK(!away.changed && away.v.x == -0.04 && away.v.y == -0.05 && away.v.z == 0.01);
  const Approach into = limit_approach(dampers, 2, {0.05, 0.05, 0.01});
  CHECK(into.changed);
  CHECK_NEAR(into.v.x, 0.01, 1e-15);           // -n.v = 0.01: the allowance
  CHECK_NEAR(into.v.y - (-0.03), 0.02, 1e-15);  // relative to the moving obstacle
  CHECK(into.v.z == 0.01);                      // tangential motion kept
  const Approach none = limit_approach(dampers, 0, {1.0, 2.0, 3.0});
  CHECK(!none.changed && none.v.x == 1.0 && none.v.y == 2.0 && none.v.z == 3.0);
}

TEST(assist_point_finds_the_sphere_blends_and_limits_the_approach) {
  const OneSphere ball({0.5, 0.0, 0.3}, 0.05);
  const double velocity[3] = {0.0, 0.0, 0.0};
  const double user[6] = {0.04, 0.01, 0.0, 0.0, 0.0, 0.1}, autonomy[6] = {0.0, 0.0, 0.02, 0.0, 0.0, 0.0};
  const AssistParams params = default_params();
  const PointAssistance far = assist_point(ball.view, velocity, {0.0, 0.0, 0.3}, user, autonomy, params,
                                           Arbitration::Linear, 0.0);
  CHECK(far.nearest == 0 && far.alpha == 0.0 && !far.limited && far.speed_scale == 1.0);
  for (int k = 0; k < 6; ++k) CHECK(far.blended[k] == user[k]);
  CHECK_NEAR(far.time_to_collision, 0.45 / 0.04, 1e-12);
  // 1.2 cm from the surface: alpha between 0 and 1, the approach held at the damper, the witness on the surface
  const Vec3 p{0.438, 0.0, 0.3};
  const PointAssistance near = assist_point(ball.view, velocity, p, user, autonomy, params, Arbitration::Linear, 0.0);
  CHECK_NEAR(near.distance, 0.012, 1e-15);
  CHECK_NEAR(near.normal.x, -1.0, 1e-15);
  CHECK_NEAR(near.alpha, (0.1 - 0.012) / 0.09, 1e-12);
  CHECK(!near.limited);  // the blend is mostly the autonomy's, which does not approach
  CHECK_NEAR(near.obstacle_point.x, 0.45, 1e-15);
  // safety_only: the operator's command, its approach limited to the damper; linear_goal: at least the goal share
  const PointAssistance held = assist_point(ball.view, velocity, p, user, autonomy, params, Arbitration::SafetyOnly,
                                            0.9);
  CHECK(held.alpha == 0.0 && held.limited && held.blended[1] == user[1] && held.blended[5] == user[5]);
  const double allowed = pfield::field::damper_speed(held.distance, 0.1, 0.01, 1.0, 0.05, 1.0);
  CHECK_NEAR(approach(held.blended, held.normal, {}), allowed, 1e-15);
  CHECK(assist_point(ball.view, velocity, {0.0, 0.0, 0.3}, user, autonomy, params, Arbitration::LinearGoal, 0.7)
            .alpha == 0.7);
  // no obstacles: nothing near, the goal share still counts in task space
  PackedView empty;
  const PointAssistance alone = assist_point(empty, velocity, p, user, autonomy, params, Arbitration::LinearGoal, 0.5);
  CHECK(alone.nearest == -1 && alone.distance == kInf && alone.alpha == 0.5 && alone.time_to_collision == kInf);
}

TEST(below_singular_value_tests_the_smallest_singular_value) {
  double gram[36] = {};
  for (int k = 0; k < 6; ++k) gram[7 * k] = 1.0;
  gram[35] = 1e-6;  // sigma_min = 1e-3
  CHECK(below_singular_value(gram, 6, 0.01));
  CHECK(!below_singular_value(gram, 6, 1e-4));
  gram[35] = 0.0;
  CHECK(below_singular_value(gram, 6, 1e-9));
}

// The planar arm by a sphere.
TEST(assist_joints_maps_the_command_and_holds_the_nearest_link_point_at_its_damper) {
  const PlanarArm arm;
  const pfield::robot::RobotView& robot = arm.robot;
  // the arm straight along x; the ball 4 cm beyond its tip (clearance 0.04 - 0.02 = 2 cm)
  const OneSphere ball({0.65, 0.0, 0.0}, 0.01);
  const double centres[3] = {0.65, 0.0, 0.0}, bounds[1] = {0.01}, velocities[3] = {0.0, 0.0, 0.0};
  const MovingObstacles obstacles{{&ball.view, centres, bounds}, velocities};
  const JointAssistParams joint_params{0.01, 0.01, 0.01, 0.01, 0.05, 1e-4, 0.2};
  JointWorkspace ws(robot);
  const double q[2] = {0.0, 0.0}, zeros[2] = {0.0, 0.0};
  double qd[2];
  // sideways (+y): the damped least-squares joint velocity, nothing to limit; the arm is singular for x motion
  const double sideways[6] = {0.0, 0.02, 0.0, 0.0, 0.0, 0.0};
  const JointAssistance side = assist_joints(q, robot, obstacles, default_params(), joint_params,
                                             Arbitration::SafetyOnly, 0.0, zeros, OperatorCommand{sideways}, -1, -1,
                                             ws, nullptr, qd);
  CHECK(side.singular && !side.limited && side.nearest.obstacle == 0 && side.nearest.link == 1);
  CHECK_NEAR(side.nearest.distance, 0.02, 1e-12);
  CHECK_NEAR(side.nearest.point.x, 0.62, 1e-12);  // the link's surface point toward the ball
  CHECK_NEAR(side.obstacle_point.x, 0.64, 1e-12);
  // J J^T (J J^T + lambda^2 I)^-1 u in the (v_y, w_z) rows, where the tip's Jacobian rows are (0.6, 0.3), (1, 1)
  const double a = 0.45 + 1e-4, b = 0.9, c = 2.0 + 1e-4, det = a * c - b * b;
  const double y0 = c * 0.02 / det, y1 = -b * 0.02 / det;
  CHECK_NEAR(side.blended[1], 0.45 * y0 + 0.9 * y1, 1e-12);
  CHECK_NEAR(side.blended[5], 0.9 * y0 + 2.0 * y1, 1e-12);
  // toward the ball the arm cannot move (singular along x): its tip gets no approach at all
  const double toward[6] = {0.04, 0.0, 0.0, 0.0, 0.0, 0.0};
  const JointAssistance ahead = assist_joints(q, robot, obstacles, default_params(), joint_params,
                                              Arbitration::SafetyOnly, 0.0, zeros, OperatorCommand{toward}, -1, -1,
                                              ws, nullptr, qd);
  CHECK(ahead.time_to_collision == kInf && !ahead.limited);
  // bent 90 degrees at the elbow the tip moves along x: the approach is held at the damper
  const double bent[2] = {0.0, 1.5707963267948966};
  const OneSphere side_ball({0.3, 0.342, 0.0}, 0.01);  // beyond the tip (0.3, 0.3): clearance 1.2 cm
  const double side_centres[3] = {0.3, 0.342, 0.0};
  const MovingObstacles side_obstacles{{&side_ball.view, side_centres, bounds}, velocities};
  const double up[6] = {0.0, 0.04, 0.0, 0.0, 0.0, 0.0};
  const JointAssistance held = assist_joints(bent, robot, side_obstacles, default_params(), joint_params,
                                             Arbitration::SafetyOnly, 0.0, zeros, OperatorCommand{up}, -1, -1, ws,
                                             nullptr, qd);
  CHECK(held.limited && held.nearest.link == 1);
  CHECK_NEAR(held.nearest.distance, 0.012, 1e-12);
  const double allowed = pfield::field::damper_speed(held.nearest.distance, 0.1, 0.01, 1.0, 0.05, 1.0);
  std::vector<double> jp(6);
  double rotations[18], origins[6];
  pfield::robot::Frames frames{rotations, origins};
  pfield::robot::joint_transforms(robot.kinematics, bent, frames);
  pfield::robot::linear_point_jacobian(robot.kinematics, frames, 1, held.nearest.point, jp.data());
  const double v[3] = {jp[0] * qd[0] + jp[1] * qd[1], jp[2] * qd[0] + jp[3] * qd[1], jp[4] * qd[0] + jp[5] * qd[1]};
  CHECK_NEAR(approach(v, held.nearest.normal, {}), allowed, 1e-12);
  CHECK(held.time_to_collision > 0.0 && held.time_to_collision < kInf);
}

// A joint jog (OperatorCommand::joints) on the arm bent 90 degrees at the elbow (tip at (0.3, 0.3)): far from any
// obstacle the joint velocities as given; by a ball beyond the tip the shoulder's turn (tip velocity (-0.3, 0.3) per
// rad/s, toward the ball) is held at the damper, the elbow's (which moves the tip along x) left as it is.
TEST(assist_joints_takes_a_joint_command_as_it_is_and_holds_it_at_the_damper) {
  const PlanarArm arm;
  const pfield::robot::RobotView& robot = arm.robot;
  const JointAssistParams joint_params{0.01, 0.01, 0.01, 0.01, 0.05, 1e-4, 0.2};
  JointWorkspace ws(robot);
  const double bent[2] = {0.0, 1.5707963267948966}, zeros[2] = {0.0, 0.0}, bounds[1] = {0.01}, velocities[3] = {};
  const double twist_unused[6] = {1.0, 1.0, 1.0, 1.0, 1.0, 1.0};  // not read when joints is set
  double qd[2];
  // the elbow alone, a ball far off: exactly as given; the tip moves at -0.3 m/s along x per rad/s
  const OneSphere far_ball({2.0, 2.0, 0.0}, 0.01);
  const double far_centres[3] = {2.0, 2.0, 0.0};
  const MovingObstacles far{{&far_ball.view, far_centres, bounds}, velocities};
  const double elbow[2] = {0.0, 0.3};
  const JointAssistance free = assist_joints(bent, robot, far, default_params(), joint_params,
                                             Arbitration::SafetyOnly, 0.0, zeros, OperatorCommand{twist_unused, elbow},
                                             -1, -1, ws, nullptr, qd);
  CHECK(!free.limited && qd[0] == 0.0 && qd[1] == 0.3);
  CHECK_NEAR(free.blended[0], -0.09, 1e-12);
  CHECK_NEAR(free.blended[1], 0.0, 1e-12);
  CHECK_NEAR(free.blended[5], 0.3, 1e-12);
  // a ball beyond the tip (clearance 1.2 cm, its nearest point (0.3, 0.32)): the shoulder at 1 rad/s approaches at
  // 0.3 m/s and is held at the damper s(d); the row n^T J_p = (-0.3, 0) leaves the elbow's velocity exactly as given
  const OneSphere side_ball({0.3, 0.342, 0.0}, 0.01);
  const double side_centres[3] = {0.3, 0.342, 0.0};
  const MovingObstacles side{{&side_ball.view, side_centres, bounds}, velocities};
  const double shoulder[2] = {1.0, 0.0};
  const JointAssistance held = assist_joints(bent, robot, side, default_params(), joint_params,
                                             Arbitration::SafetyOnly, 0.0, zeros,
                                             OperatorCommand{twist_unused, shoulder}, -1, -1, ws, nullptr, qd);
  CHECK(held.limited && held.nearest.link == 1);
  CHECK_NEAR(held.nearest.distance, 0.012, 1e-12);
  const double allowed = pfield::field::damper_speed(held.nearest.distance, 0.1, 0.01, 1.0, 0.05, 1.0);
  CHECK_NEAR(qd[0], allowed / 0.3, 1e-12);
  CHECK(qd[1] == 0.0);
  CHECK_NEAR(held.time_to_collision, 0.012 / 0.3, 1e-12);  // under the operator's own joint velocities
  // turning the shoulder back moves the tip away: as given
  const double back[2] = {-1.0, 0.0};
  const JointAssistance away = assist_joints(bent, robot, side, default_params(), joint_params,
                                             Arbitration::SafetyOnly, 0.0, zeros, OperatorCommand{twist_unused, back},
                                             -1, -1, ws, nullptr, qd);
  CHECK(!away.limited && qd[0] == -1.0 && qd[1] == 0.0 && away.time_to_collision == kInf);
}

// The same arm straight along x with a ball above each link: both link points are within Q and both approach too
// fast under the operator's +y command. The nearest link (0) alone would be corrected and link 1 driven on; the
// answer is the projection of the blend onto both rows, which here is the projection onto link 1's row alone
// (link 0's row then holds with room: its multiplier would be negative).
TEST(assist_joints_holds_every_link_point_within_the_influence_distance) {
  const PlanarArm arm;
  const pfield::robot::RobotView& robot = arm.robot;
  // balls of 1 cm above link 0 at x = 0.15 (clearance 12 mm) and above link 1 at x = 0.45 (13 mm)
  const std::int64_t ball_kinds[2] = {0, 0};
  const double ball_rows[32] = {0.15, 0.042, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0.01, 0, 0, -1,
                                0.45, 0.043, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0.01, 0, 0, -1};
  PackedView packed;
  packed.kinds = ball_kinds;
  packed.rows = ball_rows;
  packed.obstacle_count = 2;
  const double centres[6] = {0.15, 0.042, 0, 0.45, 0.043, 0}, bounds[2] = {0.01, 0.01}, velocities[6] = {};
  const MovingObstacles obstacles{{&packed, centres, bounds}, velocities};
  const JointAssistParams joint_params{0.01, 0.01, 0.01, 0.01, 0.05, 1e-4, 0.2};
  JointWorkspace ws(robot, 2);
  const double q[2] = {0.0, 0.0}, zeros[2] = {0.0, 0.0}, up[6] = {0.0, 0.05, 0.0, 0.0, 0.0, 0.0};
  double qd[2];
  const JointAssistance held = assist_joints(q, robot, obstacles, default_params(), joint_params,
                                             Arbitration::SafetyOnly, 0.0, zeros, OperatorCommand{up}, -1, -1, ws,
                                             nullptr, qd);
  CHECK(held.limited && held.nearest.link == 0 && held.nearest.obstacle == 0);
  CHECK_NEAR(held.nearest.distance, 0.012, 1e-12);
  // the blend: J^T (J J^T + lambda^2 I)^-1 u in the (v_y, w_z) rows (0.6, 0.3), (1, 1), as above
  const double a = 0.45 + 1e-4, b = 0.9, c = 2.0 + 1e-4, det = a * c - b * b;
  const double y0 = c * 0.05 / det, y1 = -b * 0.05 / det;
  const double blend[2] = {0.6 * y0 + y1, 0.3 * y0 + y1};
  // the rows n^T J_p qd >= -s(d), n = -y: link 0's point (0.15, 0) moves at 0.15 qd0 along y, link 1's (0.45, 0) at
  // 0.45 qd0 + 0.15 qd1
  const double s0 = pfield::field::damper_speed(0.012, 0.1, 0.01, 1.0, 0.05, 1.0);
  const double s1 = pfield::field::damper_speed(0.013, 0.1, 0.01, 1.0, 0.05, 1.0);
  CHECK(0.15 * blend[0] > s0 && 0.45 * blend[0] + 0.15 * blend[1] > s1);  // both approach too fast
  const double excess = 0.45 * blend[0] + 0.15 * blend[1] - s1, norm2 = 0.45 * 0.45 + 0.15 * 0.15;
  const double expected[2] = {blend[0] - 0.45 * excess / norm2, blend[1] - 0.15 * excess / norm2};
  CHECK_NEAR(qd[0], expected[0], 1e-12);
  CHECK_NEAR(qd[1], expected[1], 1e-12);
  CHECK(0.15 * qd[0] < s0 - 1e-3);                               // link 0 held with room
  CHECK_NEAR(0.45 * qd[0] + 0.15 * qd[1], s1, 1e-12);            // link 1 at its damper
  // a workspace sized for no obstacles grows to the rows and gives the same answer
  JointWorkspace small(robot);
  double again[2];
  assist_joints(q, robot, obstacles, default_params(), joint_params, Arbitration::SafetyOnly, 0.0, zeros,
                OperatorCommand{up}, -1, -1, small, nullptr, again);
  CHECK(again[0] == qd[0] && again[1] == qd[1]);
}
