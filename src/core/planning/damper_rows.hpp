// The damper rows of the velocity QP (math/qp.hpp), one home for every caller that builds them: the whole-body
// step (planning/whole_body.cpp: obstacle, self and joint-limit rows) and shared control's whole-body assistance
// (shared_control/assist.cpp: obstacle rows on the blended joint velocity).
//
// A damper row bounds the rate of one distance: for a link-obstacle pair at signed distance d, with n the unit
// normal from the obstacle toward the link point p and J_p that point's linear Jacobian, d's rate is n^T J_p qd
// (less n^T v_obs for a moving obstacle), so the row n^T J_p qd >= b holds the approach speed below -b (Faverjon &
// Tournassoud 1987; Haviland & Corke, "NEO", RA-L 2021, eq. 20). The point may be any point of the link on the line
// through p along n (the deciding segment's axis point or its surface point): n^T J_p is the same for all of them,
// since the link's rotation adds w x (r n) to the point's velocity and n^T (w x n) = 0.
//
// Which pairs get a row: scan_link_obstacle_pairs, the two levels of robot/clearance.hpp with cutoff = fine_cutoff =
// the influence distance Q (exact below Q, robot::link_obstacle_distance_below).
#pragma once

#include <cstddef>
#include <cstdint>

#include "math/qp.hpp"
#include "math/vec3.hpp"
#include "robot/clearance.hpp"
#include "robot/kinematics.hpp"
#include "robot/robot.hpp"

namespace pfield::planning {

// The QP settings of damper rows: at most 200 sweeps, rows held within 1e-7 (m/s).
inline constexpr math::QpSettings kDamperQpSettings{200, 1e-7};

// The QP's constraint rows A qd >= b as the constraints fill them (each kind of damper adds its own rows through
// this one interface; the QP never knows which constraint a row came from).
struct ConstraintRows {
  double* a;        // (capacity, n) row-major
  double* b;        // (capacity,)
  std::size_t n;
  std::size_t count;

  // A new row with bound `bound`; its n coefficients are the caller's to write.
  double* add(double bound) {
    b[count] = bound;
    return a + n * count++;
  }

  // The row n^T J_p of the world point p carried by `joint` (its linear Jacobian into jlin, 3 x n), bound `bound`.
  double* add_point_row(const robot::KinematicsView& kinematics, const robot::Frames& frames, std::int64_t joint,
                        math::Vec3 point, math::Vec3 normal, double bound, double* jlin) {
    robot::linear_point_jacobian(kinematics, frames, joint, point, jlin);
    double* row = add(bound);
    for (std::size_t j = 0; j < n; ++j)
      row[j] = normal.x * jlin[j] + normal.y * jlin[n + j] + normal.z * jlin[2 * n + j];
    return row;
  }

  math::QpRows view() const { return {a, n, b, count}; }
};

// Every link-obstacle pair of the link model at the world segments `world` (links in order, each against the
// obstacles in order), by the levels of robot::link_obstacle_distance_below with cutoff = fine_cutoff = `cutoff`:
// a pair whose cheap bound (robot::capsule_lower_bound, that function's own first test, inline here because most
// pairs end there) is at least cutoff goes to culled(link, obstacle, bound), every other one to
// evaluated(link, obstacle, pair) with its LinkObstacleDistance (exact below cutoff; not exact: a lower bound, at
// least cutoff). world.prim_* as link_obstacle_distance_below requires: placed already (robot::near_segments), or
// by `placement` when a pair reaches the fine level.
template <class Culled, class Evaluated>
void scan_link_obstacle_pairs(const robot::LinkModelView& links, const robot::WorldSegments& world,
                              const robot::ObstacleSet& obstacles, double cutoff,
                              const robot::PrimitivePlacement* placement, Culled&& culled, Evaluated&& evaluated) {
  const std::size_t count = obstacles.count();
  for (std::size_t c = 0; c < links.capsule_count; ++c) {
    for (std::size_t i = 0; i < count; ++i) {
      const double lower = robot::capsule_lower_bound(obstacles, i, world, links, c);
      if (lower >= cutoff) {
        culled(c, i, lower);
        continue;
      }
      evaluated(c, i, robot::link_obstacle_distance_below(links, world, obstacles, c, i, cutoff, cutoff, placement));
    }
  }
}

}  // namespace pfield::planning
