// The whole-body field: one joint-velocity step of a robot among obstacles, its planning loop and the prepared
// stepper of shared control, over the robot view of robot/robot.hpp.
//
// Each step solves the small QP (Haviland & Corke, "NEO: A novel expeditious optimisation algorithm for reactive
// motion control of manipulators", RA-L 2021, eqs. 14-20):
//
//     minimise  1/2 |J qd - xd|^2_W + 1/2 lambda^2 |qd - qd_rep|^2
//     s.t.      n_k^T J_k qd >= -s(d_k)     for every link-obstacle and self pair within Q,
//               +-qd_j >= -s_j(q_j)          near the joint position limits,
//
// where xd = [v; w] is the field's end-effector twist (attraction of field/forces.hpp, soft saturated), J the
// end-effector Jacobian, W = diag(1, 1, 1, w_r, w_r, w_r), n_k the unit normal from the obstacle to link point k
// and J_k that point's linear Jacobian (so n_k^T J_k qd is the rate of d_k). The stepped velocity damper
// s(d) = min(xi v_max (d - d_s)/(Q - d_s), (d - d_s)/(2 dt)) lets links approach obstacles only as fast as they
// can still stop at d_s (Faverjon & Tournassoud 1987), so a goal inside the influence distance is still reached.
// The Khatib repulsion eta (1/d - 1/Q)/d^2 (saturated, Khatib 1986) enters only as the posture preference
// qd_rep = sum J_k^T n_k v_max m_k / F_cap, which the small lambda^2 confines to the task's null space. The damped
// least-squares part also bounds the step near singularities (Nakamura & Hanafusa 1986). After the QP (math/qp)
// the joint speeds are scaled uniformly into the velocity limits and rate-limited by the acceleration limits,
// unless the rate limit would break a damper row (safety first).
//
// Every function here keeps the operation order of the numba kernels it replaced (issue 32), so the same bits and
// the test suite's exact figures carried over (tests/planning/test_core_whole_body.py holds digests of those
// kernels' results, beside invariants).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "math/qp.hpp"
#include "math/so3.hpp"
#include "math/vec3.hpp"
#include "planning/status.hpp"
#include "robot/clearance.hpp"
#include "robot/robot.hpp"

namespace pfield::planning {

// The field's and the QP's settings: pfield.planning._whole_body_layout.PARAMS, whose vector (packed by
// pfield.planning.whole_body.kernel_parameters) the binding reads as this struct (a test holds the two orders
// equal).
struct WholeBodyParams {
  double attractive_gain;             // k_att (1/s)
  double rotational_attractive_gain;  // k_rot (1/s)
  double attractive_threshold;        // G (m): quadratic attraction within, conical beyond
  double max_linear_velocity;         // v_max (m/s)
  double max_angular_velocity;        // w_max (rad/s)
  double influence_distance;          // Q (m): dampers act within
  double safety_distance;             // d_s (m): dampers stop links there
  double damper_gain;                 // xi (-): damper speed xi v_max at Q
  double repulsive_gain;              // eta: Khatib's gain
  double max_repulsive_force;         // F_cap: saturation of the repulsion
  double dt;                          // (s) the step, and the dampers' look-ahead
  double goal_tolerance;              // (m)
  double rotation_tolerance;          // (rad)
  double stagnation_steps;            // the stagnation window (a whole number of steps)
  double stagnation_progress;         // (m, rad) least progress per window
  double joint_influence;             // (rad or m) joint-limit dampers act within
  double joint_safety;                // (rad or m) and stop the joint this far inside the limit
  double rotation_weight;             // w_r (m^2/rad^2)
  double damping;                     // lambda^2: damped least squares, and the weight of the null-space repulsion
  double null_space_gain;             // scale of the null-space repulsion
};

// One step's result: pfield.planning._whole_body_layout.STEP_OUT, field for field (the binding writes this struct
// as that row; a test holds the offsets equal). Indices are whole numbers held as doubles, -1 for none, so the
// struct is the row Python reads.
struct StepResult {
  double twist[6];           // end-effector twist J qd (m/s, rad/s), world frame
  double position[3];        // end-effector position (m)
  double orientation[4];     // end-effector quaternion (x, y, z, w), w >= 0
  double clearance;          // smallest link-obstacle distance (m; exact below min(Q, 10 cm), else a lower bound)
  double self_clearance;     // smallest self-pair distance less its start offset (m), inf without pairs
  double position_error;     // |goal - p| (m)
  double rotation_error;     // |log(q_goal (x) q^-1)| (rad)
  double nearest_capsule;    // link of the closest link-obstacle pair (less its offset), -1 if none
  double nearest_obstacle;   // obstacle of that pair, -1 if none
  double nearest_distance;   // that pair's distance less its offset (m; beyond Q a lower bound); < 0: contact
  double nearest_self_pair;  // the closest self pair, -1 if none
};

// The obstacles (packed, with bounding spheres) and the start offsets (<= 0, m) subtracted from each pair's
// distance: the fitted model over-approximates the links, so a valid start may have pairs closer than d_s, which
// may then not get any closer than they start (pfield.planning.whole_body.make_scene).
//
// fitted_self: self pairs on the fitted primitives (robot::fitted_pair_distance_below) instead of the covering
// capsules (robot::link_pair_distance): the global search and the tracking of its path (pfield.planning.global_search,
// issue 34); the field's own plan keeps the covering capsules.
struct WholeBodyScene {
  robot::ObstacleSet obstacles;
  const double* obstacle_offsets = nullptr;  // (caps, M) row-major
  const double* self_offsets = nullptr;      // (pairs,)
  bool fitted_self = false;
};

// The end effector's goal pose, and optionally a joint goal at it (a posture): joints (n,) or null, drawn toward
// at joint_gain (1/s) through the null-space channel (velocity_from_segments). A view: joints must outlive every
// copy of the Goal (the binding's Planner owns them and is not copyable).
struct Goal {
  math::Vec3 position;
  math::Quat orientation;
  const double* joints = nullptr;
  double joint_gain = 0.0;
};

// The scratch of one step, sized once (n joints, caps links, M obstacles, P self pairs, the fitted primitives) and
// reused by every step; after a step it holds that step's joint frames, end-effector Jacobian, world segments,
// joint velocity and result, for a caller that continues from them. Not copyable (the views point into it).
struct WholeBodyWorkspace {
  WholeBodyWorkspace(std::size_t joints, std::size_t capsules, std::size_t obstacle_count, std::size_t pairs,
                     std::size_t primitives);
  WholeBodyWorkspace(const robot::RobotView& robot, const WholeBodyScene& scene);
  WholeBodyWorkspace(const WholeBodyWorkspace&) = delete;
  WholeBodyWorkspace& operator=(const WholeBodyWorkspace&) = delete;

  std::size_t joint_count;
  std::size_t max_rows;             // caps * M + P + 2 n: every damper row a step may add
  std::vector<double> rotations;    // (n, 3, 3) joint frames
  std::vector<double> origins;      // (n, 3)
  std::vector<double> jacobian;     // (6, n) the end effector's, row-major
  std::vector<double> jlin;         // (3, n) a link point's linear Jacobian
  std::vector<double> jlin2;        // (3, n) the second link's, for self pairs
  std::vector<double> rows;         // (max_rows, n) the damper rows A
  std::vector<double> bounds;       // (max_rows,) their bounds b (A qd >= b)
  std::vector<double> h;            // (n, n) J^T W J + lambda^2 I, then its Cholesky factor
  std::vector<double> rhs;          // (n,) J^T W xd + weight * qd_rep
  std::vector<double> x;            // (n,) the joint velocity qd
  std::vector<double> free;         // (n,) the null-space repulsion qd_rep
  std::vector<double> limited;      // (n,) qd under the rate limit
  std::vector<double> segment_ends; // world ends: capsules a, b (caps, 3) each, then primitives a, b (prims, 3)
  std::vector<unsigned char> placed;  // (caps,) the links whose primitives are in `world` for this step's frames
  std::vector<robot::AxisMiddle> middles;  // (caps,) each bounding capsule's axis at this step's frames
  math::QpWorkspace qp;
  StepResult result{};
  robot::Frames frames;             // views of rotations / origins
  robot::WorldSegments world;       // views of segment_ends
};

// Primitive placement into ws.world at ws.frames, its flags ws.placed: which links this configuration has placed
// (step_segments resets them).
robot::PrimitivePlacement primitive_placement(const robot::LinkModelView& links, WholeBodyWorkspace& ws);

// The end effector's pose, Jacobian (ws.jacobian) and the field's desired twist at the joint frames in ws, into
// the QP's normal equations ws.h, ws.rhs; pose and goal errors into ws.result.
void task(const robot::RobotView& robot, const Goal& goal, const WholeBodyParams& params, WholeBodyWorkspace& ws);

// The step's world segments: every bounding capsule (and its axis, ws.middles); a link's fitted primitives are
// placed (ws.placed) by the first obstacle or self pair of the step that reaches its fine level, so the links no
// pair gets that near to are never placed.
void step_segments(const robot::RobotView& robot, WholeBodyWorkspace& ws);

// The joint velocity of the task in ws.h / ws.rhs under the dampers (link-obstacle, self pairs, joint limits) into
// ws.x, speed- and rate-limited, and its twist J qd into ws.result, once the frames are in ws and step_segments
// has placed the capsules (their axes, the reset placement flags).
// previous: the last joint velocity (n,) for the rate limit, or null for none; free_weight scales the null-space
// repulsion added to the task; hold: the start offsets are taken at q itself (pairs closer than d_s may not
// approach further: max(d, d_s)), without the scene's offsets; posture: a goal with joints adds
// joint_gain (q_goal - q) to that free term (the planner's joint goal; shared control has none). Returns the number
// of damper rows.
std::size_t velocity_from_segments(const double* q, const double* previous, const robot::RobotView& robot,
                                   const WholeBodyScene& scene, const WholeBodyParams& params, WholeBodyWorkspace& ws,
                                   double free_weight, bool hold, const Goal* posture = nullptr);

// step_segments, then velocity_from_segments with the scene's offsets (and posture's pull, when given).
std::size_t constrained_velocity(const double* q, const double* previous, const robot::RobotView& robot,
                                 const WholeBodyScene& scene, const WholeBodyParams& params, WholeBodyWorkspace& ws,
                                 double free_weight, const Goal* posture = nullptr);

// The planner's step at q (n,): joint frames, task, constrained_velocity with free weight lambda^2 and the goal's
// posture.
std::size_t joint_velocity_step(const double* q, const double* previous, const robot::RobotView& robot,
                                const WholeBodyScene& scene, const Goal& goal, const WholeBodyParams& params,
                                WholeBodyWorkspace& ws);

// Shared control's step at q: as joint_velocity_step, but the offsets are taken at q itself (hold).
std::size_t autonomy_step(const double* q, const double* previous, const robot::RobotView& robot,
                          const WholeBodyScene& scene, const Goal& goal, const WholeBodyParams& params,
                          WholeBodyWorkspace& ws);

// The plan's waypoints, caller storage of max_iterations + 1 rows each.
struct WholeBodyPath {
  double* joints = nullptr;          // (rows, n) q_k
  double* velocities = nullptr;      // (rows, n) the qd applied from q_k (zero at a reached goal's waypoint)
  double* positions = nullptr;       // (rows, 3) end effector
  double* orientations = nullptr;    // (rows, 4)
  double* twists = nullptr;          // (rows, 6) J(q_k) qd_k
  double* clearances = nullptr;      // (rows,)
};

struct WholeBodyPlanResult {
  PlanStatus status = PlanStatus::IterationLimit;
  std::int64_t count = 0;  // waypoints recorded, the start included
  StepResult last{};       // the last step evaluated: its nearest pairs name the culprit of a failure
};

// The waypoint rules every plan loop shares (plan_whole_body, track_path), after the step at q = q_k (in ws):
// waypoint k's q, pose and clearance; a contact (Collision / SelfCollision: the plan stops before it, at waypoint
// max(k, 1) - 1) or, when may_reach, the goal within both tolerances (Reached, at k) ends the plan with a zero
// velocity and twist at its last waypoint; otherwise waypoint k's velocity and twist, and the iteration limit (k the
// last row) or *cancel != 0 (Cancelled, read atomically) end it. True when the plan ends at k (result set).
bool record_step(std::int64_t k, std::int64_t total, const std::vector<double>& q, const WholeBodyWorkspace& ws,
                 const WholeBodyParams& params, bool may_reach, const std::uint8_t* cancel, const WholeBodyPath& path,
                 WholeBodyPlanResult& result);

// The step from waypoint k to k + 1: q <- clip(q + qd dt, lower, upper) and previous <- qd, with qd = ws.x.
void advance(std::vector<double>& q, std::vector<double>& previous, const WholeBodyWorkspace& ws,
             const robot::JointLimitsView& limits, double dt);

// Integrates q <- clip(q + qd dt, lower, upper) from q0 until the goal (Reached), a step that brought capsules into
// contact (Collision / SelfCollision: the plan stops before that waypoint), the stagnation rule (Progress), the
// iteration limit or *cancel != 0 (Cancelled, read atomically every step). params.stagnation_steps must be >= 1.
WholeBodyPlanResult plan_whole_body(const double* q0, const robot::RobotView& robot, const WholeBodyScene& scene,
                                    const Goal& goal, const WholeBodyParams& params, std::int64_t max_iterations,
                                    const std::uint8_t* cancel, const WholeBodyPath& path);

// The prepared whole-body step (pfield.planning.WholeBodyStepper's core, the autonomy vector's hot path): robot,
// scene and goal bound once, the workspace owned. Views must outlive the stepper.
class WholeBodyStepper {
 public:
  WholeBodyStepper(const robot::RobotView& robot, const WholeBodyScene& scene, const Goal& goal,
                   const WholeBodyParams& params);

  // autonomy_step at q with the parameters of dt (s; 0: the bound parameters' own dt), rate-limited against
  // previous when given and dt > 0. Checks its inputs first as pfield.robot.RobotModel.check_joint_angles does: q
  // must have n finite values within the limits up to limit_tolerance (then clamped onto them); previous (or
  // null) n finite values, clipped into the velocity limits (the output contract's rule 3); dt finite and >= 0.
  // Returns false, computing nothing, when an input breaks these rules (the caller words the error).
  bool step(const double* q, std::size_t q_size, const double* previous, std::size_t previous_size, double dt,
            double limit_tolerance);

  std::size_t joint_count() const { return ws_.joint_count; }
  const StepResult& result() const { return ws_.result; }
  const double* joint_velocities() const { return ws_.x.data(); }
  const WholeBodyWorkspace& workspace() const { return ws_; }
  // Places a link's primitives at the last step's frames on first use (the step placed only those its pairs needed).
  robot::PrimitivePlacement placement() { return primitive_placement(robot_.links, ws_); }

 private:
  robot::RobotView robot_;
  WholeBodyScene scene_;
  Goal goal_;
  WholeBodyParams params_;
  WholeBodyWorkspace ws_;
  std::vector<double> q_, previous_;
};

}  // namespace pfield::planning
