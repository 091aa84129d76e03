// The robot's kinematics, damped least squares and IK (src/core/robot/{kinematics,ik}, src/core/math/dls.hpp) on a
// small tree robot built here: the Jacobian against finite differences of the forward kinematics, the zero columns
// of joints off the path, the limit check's rule, the DLS step against its normal equations, IK to reachable and
// unreachable targets. Also run under AddressSanitizer and UBSan (make core-test); tests/robot/test_core_kinematics.py
// holds the same functions to numba's twins bit for bit.
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "harness.hpp"
#include "math/dls.hpp"
#include "math/so3.hpp"
#include "robot/ik.hpp"
#include "robot/kinematics.hpp"

namespace {

using namespace pfield;
using robot::Frames;
using robot::KinematicsView;
using robot::Vec3;

// Joint 0 revolute about z at the base; joint 1 prismatic along an oblique unit axis; joint 2 revolute about x;
// joint 3 revolute off joint 0 (a branch, not on the tool's path). The tool sits on joint 2.
struct TreeRobot {
  static constexpr std::size_t n = 4;
  std::int64_t parents[n] = {-1, 0, 1, 0};
  double place_rot[9 * n];
  double place_pos[3 * n] = {0.0, 0.0, 0.1, 0.2, 0.0, 0.3, 0.0, 0.1, 0.25, -0.1, 0.05, 0.0};
  double axes[3 * n] = {0.0, 0.0, 1.0, 0.0, 0.6, 0.8, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0};
  std::int64_t kinds[n] = {0, 1, 0, 0};
  std::int64_t support[n * n] = {1, 0, 0, 0,  //
                                 1, 1, 0, 0,  //
                                 1, 1, 1, 0,  //
                                 1, 0, 0, 1};
  double ee_rot[9];
  double ee_pos[3] = {0.05, 0.0, 0.15};
  double lower[n] = {-3.0, -0.2, -2.0, -1.0};
  double upper[n] = {3.0, 0.5, 2.0, 1.0};

  TreeRobot() {
    // placements: rotations about oblique axes (exp of a rotation vector), the tool's too
    const Vec3 rotvecs[n] = {{0.0, 0.0, 0.0}, {0.3, -0.2, 0.1}, {-0.4, 0.5, 0.2}, {0.1, 0.1, -0.6}};
    for (std::size_t i = 0; i < n; ++i) math::to_matrix(math::so3_exp(rotvecs[i]), place_rot + 9 * i);
    math::to_matrix(math::so3_exp({0.2, -0.1, 0.3}), ee_rot);
  }

  KinematicsView view() const {
    return {n, parents, place_rot, place_pos, axes, kinds, support, 2, ee_rot, ee_pos};
  }
};

struct Workspace {
  std::vector<double> rotations, origins;
  Frames frames;
  explicit Workspace(std::size_t n) : rotations(9 * n), origins(3 * n), frames{rotations.data(), origins.data()} {}
};

// The world rotation vector taking rotation a to rotation b (row-major): log(b a^T).
Vec3 rotation_between(const double* a, const double* b) {
  return math::rotation_error(math::from_matrix(a), math::from_matrix(b));
}

}  // namespace

TEST(jacobian_equals_finite_differences_of_the_forward_kinematics) {
  const TreeRobot robot;
  const KinematicsView view = robot.view();
  Workspace ws(TreeRobot::n);
  const double q[TreeRobot::n] = {0.4, 0.1, -0.7, 0.3};
  double jacobian[6 * TreeRobot::n];
  const robot::FramePose pose = robot::end_effector_kinematics(view, q, ws.frames, jacobian);
  const double h = 1e-6;
  for (std::size_t j = 0; j < TreeRobot::n; ++j) {
    double shifted[TreeRobot::n] = {q[0], q[1], q[2], q[3]};
    shifted[j] += h;
    Workspace other(TreeRobot::n);
    const robot::FramePose moved = robot::end_effector_kinematics(view, shifted, other.frames, nullptr);
    const Vec3 angular = rotation_between(pose.rotation, moved.rotation);
    const double expected[6] = {(moved.position.x - pose.position.x) / h, (moved.position.y - pose.position.y) / h,
                                (moved.position.z - pose.position.z) / h, angular.x / h, angular.y / h, angular.z / h};
    for (std::size_t r = 0; r < 6; ++r) CHECK_NEAR(jacobian[r * TreeRobot::n + j], expected[r], 1e-5);
  }
  // joint 3 is off the tool's path, joint 1 prismatic: zero column, zero angular rows
  for (std::size_t r = 0; r < 6; ++r) CHECK(jacobian[r * TreeRobot::n + 3] == 0.0);
  for (std::size_t r = 3; r < 6; ++r) CHECK(jacobian[r * TreeRobot::n + 1] == 0.0);
}

TEST(point_jacobians_agree_and_the_base_has_none) {
  const TreeRobot robot;
  const KinematicsView view = robot.view();
  Workspace ws(TreeRobot::n);
  const double q[TreeRobot::n] = {-1.1, 0.3, 0.9, -0.5};
  robot::joint_transforms(view, q, ws.frames);
  const Vec3 point{0.3, -0.2, 0.4};
  double full[6 * TreeRobot::n], linear[3 * TreeRobot::n];
  for (std::int64_t joint = -1; joint < static_cast<std::int64_t>(TreeRobot::n); ++joint) {
    robot::point_jacobian(view, ws.frames, joint, point, full);
    robot::linear_point_jacobian(view, ws.frames, joint, point, linear);
    for (std::size_t k = 0; k < 3 * TreeRobot::n; ++k) CHECK(full[k] == linear[k]);
    if (joint < 0)
      for (double v : full) CHECK(v == 0.0);
  }
  // a point on joint 3 (the branch) moves with joints 0 and 3 only
  robot::point_jacobian(view, ws.frames, 3, point, full);
  for (std::size_t r = 0; r < 6; ++r) CHECK(full[r * TreeRobot::n + 1] == 0.0 && full[r * TreeRobot::n + 2] == 0.0);
  // frame_pose with the identity is transform_point
  const double identity[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  const Vec3 p = robot::frame_pose(ws.frames, 2, identity, point).position;
  const Vec3 t = robot::transform_point(ws.frames, 2, point);
  CHECK(p.x == t.x && p.y == t.y && p.z == t.z);
}

TEST(batch_positions_equal_one_by_one) {
  const TreeRobot robot;
  const KinematicsView view = robot.view();
  Workspace ws(TreeRobot::n);
  const double qs[2 * TreeRobot::n] = {0.1, 0.2, 0.3, 0.4, -0.5, -0.1, 1.2, 0.0};
  double out[6];
  robot::batch_end_effector_positions(view, qs, 2, ws.frames, out);
  for (std::size_t k = 0; k < 2; ++k) {
    const robot::FramePose pose = robot::end_effector_kinematics(view, qs + k * TreeRobot::n, ws.frames, nullptr);
    CHECK(out[3 * k] == pose.position.x && out[3 * k + 1] == pose.position.y && out[3 * k + 2] == pose.position.z);
  }
  double pose7[7];
  robot::end_effector_pose7(view, qs, ws.frames, pose7);
  CHECK(pose7[0] == out[0] && pose7[1] == out[1] && pose7[2] == out[2]);
  CHECK_NEAR(pose7[3] * pose7[3] + pose7[4] * pose7[4] + pose7[5] * pose7[5] + pose7[6] * pose7[6], 1.0, 1e-15);
}

TEST(check_limits_clamps_within_tolerance_and_names_the_first_bad_value) {
  const double lower[3] = {-1.0, 0.0, -2.0}, upper[3] = {1.0, 0.5, 2.0};
  double ok[3] = {1.00005, -0.00005, 0.3};
  CHECK(robot::check_limits(ok, lower, upper, 3, 1e-4).status == robot::LimitCheck::Status::Ok);
  CHECK(ok[0] == 1.0 && ok[1] == 0.0 && ok[2] == 0.3);
  double beyond[3] = {0.2, 0.7, std::nan("")};
  const robot::LimitCheck b = robot::check_limits(beyond, lower, upper, 3, 1e-4);
  CHECK(b.status == robot::LimitCheck::Status::BeyondLimits && b.index == 1);
  double nonfinite[3] = {0.2, std::numeric_limits<double>::infinity(), 9.0};
  const robot::LimitCheck f = robot::check_limits(nonfinite, lower, upper, 3, 1e-4);
  CHECK(f.status == robot::LimitCheck::Status::NotFinite && f.index == 1);
}

TEST(dls_step_solves_its_normal_equations_and_skips_frozen_columns) {
  // J (2 x 3); with column 1 frozen, x = J_f^T (J_f J_f^T + d I)^-1 e also solves (J_f^T J_f + d I) x = J_f^T e
  const double jac[6] = {1.0, 2.0, -0.5, 0.3, -1.0, 2.0};
  const double e[2] = {0.7, -0.2};
  const std::uint8_t frozen[3] = {0, 1, 0};
  const double damping = 0.01;
  double x[3];
  math::damped_least_squares(jac, 2, 3, frozen, damping, e, x);
  CHECK(x[1] == 0.0);
  const std::size_t free_columns[2] = {0, 2};
  for (std::size_t a : free_columns) {
    double lhs = damping * x[a], rhs = 0.0;
    for (std::size_t r = 0; r < 2; ++r) {
      rhs += jac[r * 3 + a] * e[r];
      for (std::size_t b : free_columns) lhs += jac[r * 3 + a] * jac[r * 3 + b] * x[b];
    }
    CHECK_NEAR(lhs, rhs, 1e-12);
  }
  // the two sum forms differ at most in the sign of a zero
  double y[3];
  math::damped_least_squares(jac, 2, 3, frozen, damping, e, y, math::DlsSum::FromZero);
  for (std::size_t j = 0; j < 3; ++j) CHECK(x[j] == y[j]);
  // the two-step form equals the whole step
  double gram[4], z[3];
  math::dls_gram(jac, 2, 3, frozen, gram);
  math::dls_from_gram(jac, 2, 3, frozen, gram, damping, e, z);
  for (std::size_t j = 0; j < 3; ++j) CHECK(x[j] == z[j]);
}

TEST(ik_reaches_a_reachable_pose_within_the_limits) {
  const TreeRobot robot;
  const KinematicsView view = robot.view();
  const double q_true[TreeRobot::n] = {0.5, 0.2, -0.6, 0.0};
  Workspace ws(TreeRobot::n);
  const robot::FramePose goal = robot::end_effector_kinematics(view, q_true, ws.frames, nullptr);
  robot::IKTarget target{goal.position, math::from_matrix(goal.rotation)};
  robot::IKSolver solver(view, robot.lower, robot.upper, {});
  const double seed[TreeRobot::n] = {0.3, 0.0, -0.3, 0.5};
  double q[TreeRobot::n];
  const robot::IKOutcome outcome = solver.solve(seed, target, q);
  CHECK(outcome.success);
  CHECK(outcome.position_error <= 1e-4 && outcome.rotation_error <= 1e-3);
  for (std::size_t j = 0; j < TreeRobot::n; ++j) CHECK(q[j] >= robot.lower[j] && q[j] <= robot.upper[j]);
  CHECK(q[3] == 0.5);  // the branch joint does not move the tool: its DLS step is zero

  // far out of reach: the last iterate within the limits, max_iterations spent
  target.position = {5.0, 0.0, 0.0};
  robot::IKSettings few;
  few.max_iterations = 20;
  robot::IKSolver short_solver(view, robot.lower, robot.upper, few);
  const robot::IKOutcome missed = short_solver.solve(seed, target, q);
  CHECK(!missed.success && missed.iterations == 20 && missed.position_error > 4.0);
  for (std::size_t j = 0; j < TreeRobot::n; ++j) CHECK(q[j] >= robot.lower[j] && q[j] <= robot.upper[j]);

  // the checked entry refuses a bad target or seed and leaves q alone
  const double bad_target[7] = {std::nan(""), 0.0, 0.0, 0.0, 0.0, 0.0, 1.0};
  const double skew_target[7] = {0.1, 0.0, 0.0, 0.0, 0.0, 0.0, 1.1};
  const double bad_seed[TreeRobot::n] = {0.0, 0.9, 0.0, 0.0};
  const double good_target[7] = {goal.position.x, goal.position.y, goal.position.z, target.orientation.x,
                                 target.orientation.y, target.orientation.z, target.orientation.w};
  double kept[TreeRobot::n] = {9.0, 9.0, 9.0, 9.0};
  robot::IKOutcome checked;
  CHECK(solver.solve_checked(seed, bad_target, 1e-4, kept, checked) == robot::IKInput::BadPosition);
  CHECK(solver.solve_checked(seed, skew_target, 1e-4, kept, checked) == robot::IKInput::BadOrientation);
  CHECK(solver.solve_checked(bad_seed, good_target, 1e-4, kept, checked) == robot::IKInput::BadSeed);
  CHECK(kept[0] == 9.0 && kept[3] == 9.0);
  CHECK(solver.solve_checked(seed, good_target, 1e-4, kept, checked) == robot::IKInput::Valid && checked.success);

  // a path of the goal twice: the second waypoint starts where the first ended
  const double positions[6] = {goal.position.x, goal.position.y, goal.position.z,
                               goal.position.x, goal.position.y, goal.position.z};
  const double orientations[8] = {good_target[3], good_target[4], good_target[5], good_target[6],
                                  good_target[3], good_target[4], good_target[5], good_target[6]};
  double qs[2 * TreeRobot::n];
  const robot::IKPathOutcome path = solver.solve_path(seed, positions, orientations, 2, qs);
  CHECK(path.failed == -1);
  for (std::size_t j = 0; j < TreeRobot::n; ++j) CHECK(qs[TreeRobot::n + j] == qs[j]);
}
