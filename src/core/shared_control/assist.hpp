// Shared-control assistance (ComputeAssistance): the operator's command arbitrated with the field's, the dampers on
// the blend, and why; the laws are documented in pfield/shared_control/assistance.py (docs/assistance.md).
//
// * Arbitration by linear blending u = alpha u_auto + (1 - alpha) u_user (Dragan & Srinivasa 2013, "A
//   policy-blending formalism for shared control", section 3), alpha = clip((Q - d)/(Q - d_s), 0, 1) from the
//   nearest obstacle's distance d (obstacle_share), at least the goal share in linear_goal, 0 in safety_only.
// * The dampers on the blend: the relative approach speed -n^T (v - v_obs) to every obstacle within Q is held below
//   the NEO velocity damper s(d) (Haviland & Corke 2021, eq. 20; field::damper_speed) by projection onto the
//   half-spaces (task space, limit_approach), or in the whole body (assist_joints) at every link point within Q of
//   an obstacle by the nearest joint velocity (Euclidean) that holds all their rows: the minimum-norm correction
//   dqd = J_p^T n e / |J_p^T n|^2 of the nearest link point alone when that holds the others, else the velocity QP
//   (math/qp.hpp) on the rows of planning/damper_rows.hpp.
// * MoveIt Servo's collision velocity scale (servo_scale), reported, not applied; the first-order time to collision.
//
// The same operations in the same order as the numba kernels this replaced (issue 32), so the same bits; every
// file here is compiled without fused multiply-adds (CMakeLists.txt).
// The commands here come before the output contract (safety/limits.hpp): the caller applies it (pfield's binding,
// python/assistance.cpp, as pfield.safety does: compiled with the same flags, which let GCC fuse the multiply-adds
// of the contract's inline norms, so the same bits as pfield.safety's).
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "geometry/packed.hpp"
#include "math/qp.hpp"
#include "math/vec3.hpp"
#include "planning/whole_body.hpp"
#include "robot/clearance.hpp"
#include "robot/robot.hpp"

namespace pfield::shared_control {

using math::Vec3;

// How alpha is chosen (pfield.shared_control.ARBITRATIONS, in that order).
enum class Arbitration : std::int64_t { Linear = 0, LinearGoal = 1, SafetyOnly = 2 };

// The scene's settings: the dampers' law (FieldConfig), Servo's threshold (AssistanceOptions.scene_threshold) and
// the output contract's speed limits.
struct AssistParams {
  double influence_distance;       // Q (m): alpha is 0 and no damper acts beyond it
  double safety_distance;          // d_s (m): alpha is 1 there
  double damper_gain;              // FieldConfig.damper_gain, the damper's speed (m/s) at Q before its caps
  double max_linear_velocity;      // v_max (m/s): the damper's floor -v_max, and the contract's linear limit
  double max_linear_acceleration;  // a_max (m/s^2): the damper's braking cap sqrt(a_max (d - d_s))
  double max_angular_velocity;     // (rad/s) the contract's angular limit
  double scale_threshold;          // d_t (m): MoveIt Servo's scene_collision_proximity_threshold
};

// The obstacles as the assistance reads them: packed, with bounding spheres (the whole body's culling) and their
// world velocities (M, 3) (m/s; zero for a static obstacle).
struct MovingObstacles {
  robot::ObstacleSet set;
  const double* velocities = nullptr;

  std::size_t count() const { return set.count(); }
  Vec3 velocity(std::size_t i) const { return {velocities[3 * i], velocities[3 * i + 1], velocities[3 * i + 2]}; }
};

// alpha_obs = clip((Q - d)/(Q - d_s), 0, 1): 0 beyond the influence distance Q, 1 at the safety distance d_s.
double obstacle_share(double distance, double influence, double safety);

// MoveIt Servo's collision velocity scale exp(k (d - d_t)), k = -ln(0.001)/d_t, for 0 < d < d_t: 1 beyond the
// threshold d_t, 0.001 at contact, 0 in collision (d <= 0), where Servo halts (moveit_servo's collision_monitor).
double servo_scale(double distance, double threshold);

// One obstacle's damper at the robot point: its outward unit normal n, the allowed approach speed s(d) and the
// obstacle's velocity.
struct MovingDamper {
  Vec3 normal;
  double allowed;
  Vec3 velocity;
};

struct Approach {
  Vec3 v;
  bool changed = false;  // some damper moved v
};

// The sweeps of limit_approach: alternating projections (von Neumann) over the active dampers, which 1-2 sweeps
// settle in practice; beyond this many the last iterate stands. Not the field's kSweeps (16, field/steps.hpp): that
// loop is another (sweep 0 deflects, then v and the previous twist are projected together, and where the dampers
// cannot all hold the nearest one's wins), and either count binds where alternating projections converge only
// geometrically or not at all (narrow wedges, dampers that exclude each other): on cluttered random inputs 8 and 16
// sweeps gave different commands in 6 % of the assistance's calls and 14 % of the field's, so one shared count would
// change results.
constexpr int kApproachSweeps = 8;

// The nearest velocity whose approach speed -n_i^T (v - v_obs,i) to each damper's obstacle obeys it, by alternating
// projections onto the half-spaces (field::project_damper on the relative velocity): each projection only adds
// velocity along n_i, away from obstacle i, so motion away from an obstacle is never slowed. Stops after a sweep
// that moved nothing, or after kApproachSweeps.
Approach limit_approach(const MovingDamper* dampers, std::size_t count, Vec3 v);

// The task-space answer at one robot point p.
struct PointAssistance {
  double blended[6] = {};  // the command: the blend under its dampers (m/s, rad/s), before the output contract
  double alpha = 0.0;
  double speed_scale = 1.0;
  std::int64_t nearest = -1;  // the nearest obstacle, -1 without obstacles
  double distance = std::numeric_limits<double>::infinity();  // its signed distance (m)
  Vec3 normal;          // n = grad d at p, from the obstacle toward the robot (0 without obstacles)
  Vec3 obstacle_point;  // p - d n, the obstacle's witness point (p without obstacles)
  double time_to_collision = std::numeric_limits<double>::infinity();  // s: 0 in collision, inf if none approached
  bool limited = false;  // a damper changed the blend
};

// Assistance for the robot point p, the operator's twist `user` (6,) and the autonomy twist `autonomy` (6,) (world
// frame; user already within the speed limits): nearest obstacle (exact signed distance, ties to the lowest index),
// the time to collision of the operator's command held, alpha by `mode` (goal_share: linear_goal's share of the
// goal), the blend, its dampers (limit_approach over the obstacles within Q) and the speed scale.
PointAssistance assist_point(const geometry::PackedView& packed, const double* velocities, Vec3 p, const double* user,
                             const double* autonomy, const AssistParams& params, Arbitration mode, double goal_share);

// The closest link-obstacle pair of the link model at the world segments `world` (near_segments' filling, or the
// primitives `placement` places on first use): the pair with the smallest exact clearance
// (robot::link_obstacle_distance_below with cutoff = fine_cutoff = the best so far, robot/clearance.hpp). The point
// is the robot's witness point on the link's surface: the deciding segment's axis point less its radius along n (that
// radius taken as d_O(axis point) - d).
struct NearestLink {
  std::int64_t link = -1;      // -1 without obstacles (or links)
  std::int64_t obstacle = -1;
  double distance = std::numeric_limits<double>::infinity();
  Vec3 normal;  // the obstacle's outward unit normal (toward the link); 0 when none
  Vec3 point;   // 0 when none
};

// hint_link, hint_obstacle: a pair already known to be the closest (both in range), then evaluated alone; -1: none.
NearestLink nearest_link(const robot::LinkModelView& links, const robot::WorldSegments& world,
                         const robot::ObstacleSet& obstacles, std::int64_t hint_link = -1,
                         std::int64_t hint_obstacle = -1, const robot::PrimitivePlacement* placement = nullptr);

// sigma_min(J) < threshold (> 0) for gram = J J^T (m x m, row-major), without an eigen solver: sigma_min^2 is the
// smallest eigenvalue of J J^T, so sigma_min < t exactly when J J^T - t^2 I is not positive definite, i.e. when its
// Cholesky factorisation (math::cholesky_in_place) meets a pivot <= 0.
bool below_singular_value(const double* gram, std::size_t m, double threshold);

// The whole body's settings beyond the scene's (AssistanceOptions).
struct JointAssistParams {
  double damping;                // lambda of the operator's map qd_user = J^T (J J^T + lambda^2 I)^-1 u_user
  double joint_limit_margin;     // (rad or m) at_limit within it of a position limit
  double singularity_threshold;  // singular when sigma_min(J) is below it
  double goal_tolerance;         // (m) at_goal within it (and within the rotation tolerance)
  double rotation_tolerance;     // (rad) the field's FieldConfig.rotation_tolerance
  double stall_speed;            // (m/s, rad/s) stalled below it in both parts, away from the goal
  double goal_radius;            // R (m): linear_goal's share clip(1 - |g - p|/R, 0, 1)
};

// The whole-body answer (the joint velocities go to the caller's storage).
struct JointAssistance {
  double blended[6] = {};  // J qd (m/s, rad/s), before the output contract
  double alpha = 0.0;
  double speed_scale = 1.0;
  NearestLink nearest;     // its point: robot_point
  Vec3 obstacle_point;     // point - d n (point when none)
  double time_to_collision = std::numeric_limits<double>::infinity();  // of the nearest link point under qd_user
  bool limited = false;    // the dampers corrected qd
  bool at_limit = false;   // a joint within joint_limit_margin of a limit
  bool singular = false;   // sigma_min(J) < singularity_threshold
  // with the field's step (WholeBodyAssistance::step) only:
  bool at_goal = false;    // position and rotation errors within their tolerances
  bool stalled = false;    // not at the goal and the autonomy twist slower than stall_speed in both parts
  double autonomy[6] = {};  // the step's twist J qd_auto, before the output contract
};

// The scratch of assist_joints at one robot: joint frames, Jacobians, world segments, the operator's joint velocity,
// and the damper QP's rows (sized for obstacle_count obstacles; assist_joints grows them, once, for more).
struct JointWorkspace {
  explicit JointWorkspace(const robot::RobotView& robot, std::size_t obstacle_count = 0);
  JointWorkspace(const JointWorkspace&) = delete;
  JointWorkspace& operator=(const JointWorkspace&) = delete;

  // Room for `rows` damper rows (caps x M: one per link-obstacle pair); allocates only when it grows.
  void fit_rows(std::size_t rows);

  std::vector<double> rotations, origins;  // (n, 3, 3), (n, 3)
  std::vector<double> jacobian;            // (6, n) the end effector's
  std::vector<double> point_jacobian;      // (3, n) a link point's linear Jacobian (the nearest's, then each row's)
  std::vector<double> segment_ends;        // capsules a, b (caps, 3) each, then primitives a, b (prims, 3)
  std::vector<unsigned char> placed;       // (caps,) the links whose primitives are in `world` for this q
  std::vector<double> qd_user;             // (n,)
  std::vector<double> blend;               // (n,) qd before the dampers
  std::vector<double> identity;            // (n, n) the QP's Hessian I, its own Cholesky factor
  std::vector<double> rows;                // (capacity, n) the damper rows A
  std::vector<double> bounds;              // (capacity,) their bounds b (A qd >= b)
  math::QpWorkspace qp;                    // (capacity rows, n variables)
  robot::Frames frames;                    // views of rotations / origins
  robot::WorldSegments world;              // views of segment_ends
};

// The operator's command to the whole body: a twist (6: m/s, rad/s, world frame) that damped least squares maps to
// the joints, or, with joints set, the joint velocities themselves (n: rad/s or m/s, a joint jog), which the blend and
// the dampers take as they are (twist is then not read).
struct OperatorCommand {
  const double* twist = nullptr;
  const double* joints = nullptr;
};

// Where assist_joints takes the robot's state at q from: computed into the workspace, or a field step's.
struct JointState {
  const robot::Frames* frames = nullptr;       // joint frames at q
  const double* jacobian = nullptr;            // (6, n) the end effector's at q
  const robot::WorldSegments* world = nullptr;  // capsules at q, and the primitives the step placed
  // places a link's primitives into world on first use (the step places only those its own pairs needed); required
  const robot::PrimitivePlacement* placement = nullptr;
};

// Whole-body assistance at q (n, within the limits) in one call: qd_user by damped least squares (math::dls_from_gram,
// the sums from 0.0) or the operator's joint velocities (OperatorCommand), the singularity test on J J^T, the
// joint-limit test, the nearest pair (nearest_link, with the hint), alpha and the blend qd = alpha qd_auto + (1 -
// alpha) qd_user, the nearest link point's time to collision, the dampers of every link point within Q, and blended = J
// qd (before the output contract). The dampers: qd becomes the nearest joint velocity (Euclidean norm) whose link
// points each approach their obstacle no faster than the damper allows, -n^T (J_p qd - v_obs) <= s(d), at every
// link-obstacle pair within Q (planning::scan_link_obstacle_pairs with cutoff Q: one row n^T J_p qd >= n^T v_obs - s(d)
// per pair, the nearest pair among them). The nearest pair's correction in closed form first, qd += J_p^T n e / |J_p^T
// n|^2 (e > 0 its excess, J_p at its surface point): the projection onto its half-space, and so onto all of them
// whenever it holds the other rows (within planning::kDamperQpSettings' tolerance: the projection onto a superset that
// lands in the set). Only when it does not, the QP min |x - qd|^2 s.t. the rows (math::hildreth, H = I) from the blend
// decides. state: null to compute the frames, Jacobian and segments at q into ws; else a field step's, used as they
// are. qd (n,) receives the joint velocities.
JointAssistance assist_joints(const double* q, const robot::RobotView& robot, const MovingObstacles& obstacles,
                              const AssistParams& params, const JointAssistParams& joint_params, Arbitration mode,
                              double goal_share, const double* qd_auto, const OperatorCommand& user,
                              std::int64_t hint_link, std::int64_t hint_obstacle, JointWorkspace& ws,
                              const JointState* state, double* qd);

// Shared control's whole-body assistance for one robot among one scene's obstacles (pfield's AssistanceScene with a
// RobotModel): robot, obstacles and settings bound once, the workspace owned, and with a goal the field's step
// (planning::WholeBodyStepper, the autonomy vector's) fused in front of the assistance. Views must outlive it.
class WholeBodyAssistance {
 public:
  // Without a goal: the assistance alone (assist).
  WholeBodyAssistance(const robot::RobotView& robot, const MovingObstacles& obstacles, const AssistParams& params,
                      const JointAssistParams& joint_params);
  // With the field's goal and step parameters: step as well.
  WholeBodyAssistance(const robot::RobotView& robot, const MovingObstacles& obstacles, const AssistParams& params,
                      const JointAssistParams& joint_params, const planning::Goal& goal,
                      const planning::WholeBodyParams& step_params);
  WholeBodyAssistance(const WholeBodyAssistance&) = delete;
  WholeBodyAssistance& operator=(const WholeBodyAssistance&) = delete;

  std::size_t joint_count() const { return robot_.kinematics.joint_count; }
  bool has_step() const { return stepper_ != nullptr; }
  const robot::RobotView& robot() const { return robot_; }
  // The last step's qd_auto (n,), before the output contract (its twist is JointAssistance::autonomy).
  const double* autonomy_joint_velocities() const { return stepper_->joint_velocities(); }

  // The assistance at q (validated: n values within the limits) with the autonomy vector zero (no goal),
  // goal_share given; qd (n,) receives the joint velocities.
  JointAssistance assist(const double* q, const OperatorCommand& user, Arbitration mode, double goal_share,
                         double* qd);

  // The field's step at q (planning::WholeBodyStepper::step: it checks q, previous and dt, and clamps q onto the
  // limits) and the assistance on its qd_auto at the clamped q, from the step's frames, Jacobian and world segments,
  // in one call. The step's position and rotation errors give at_goal and stalled (its twist before the contract)
  // and linear_goal's share; its nearest pair, when strictly between d_s (plus rounding) and Q, is the closest of
  // all (the step evaluated every pair exactly below Q) and is taken as the hint. Returns false, computing nothing,
  // when the step refuses an input (the caller validates, and raises).
  bool step(const double* q, std::size_t q_size, const double* previous, std::size_t previous_size, double dt,
            double limit_tolerance, const OperatorCommand& user, Arbitration mode, JointAssistance& out, double* qd);

 private:
  robot::RobotView robot_;
  MovingObstacles obstacles_;
  AssistParams params_;
  JointAssistParams joint_params_;
  JointWorkspace ws_;
  std::vector<double> zeros_;     // (n,) the autonomy's qd without a goal
  std::vector<double> clamped_;   // (n,) q clamped onto the limits
  std::vector<double> obstacle_offsets_, self_offsets_;  // the step's scene offsets: zero (its hold ignores them)
  planning::WholeBodyScene scene_;
  std::unique_ptr<planning::WholeBodyStepper> stepper_;
};

}  // namespace pfield::shared_control
