// Local time stretching of a sampled joint path within velocity and acceleration limits (pfield.planning.retime
// holds the method and why it was chosen over TOPP-RA).
//
// Intervals h_k separate the samples q_k. At sample k the velocity and acceleration are the derivatives of the
// parabola through samples k-1, k, k+1; the ends are at rest. Each round lengthens every interval next to a sample
// that breaks a limit by that sample's violation ratio r = max_j(|qd_j|/v_j, sqrt(|qdd_j|/a_j)) (qd scales with
// 1/r, qdd with 1/r^2); no interval is ever shortened, so the rounds converge.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace pfield::planning {

struct JointPath {
  const double* q;    // (count, joints) row-major
  std::size_t count;  // samples
  std::size_t joints;
};

struct Timing {
  std::vector<double> h;              // (count - 1) interval durations, s
  std::vector<double> velocities;     // (count, joints)
  std::vector<double> accelerations;  // (count, joints)
};

// Velocities and accelerations of the samples for the intervals h: the derivatives at t_k of the parabola
// through k-1, k, k+1 (exact for quadratic motion on a non-uniform grid), zero velocity at both ends.
void differences(const JointPath& path, const double* h, double* v, double* a);

// Durations h >= h0 under which the samples keep the limits (ratios within 1e-9 of 1 are left to the caller's
// final uniform stretch), with the samples' velocities and accelerations.
Timing stretch_intervals(const JointPath& path, const double* h0, const double* v_max, const double* a_max,
                         int rounds);

// The samples that carry the timing: the first, each next one at least `spacing` of joint-space arc length after
// the previous one, and the last (when it lies further along).
std::vector<std::int64_t> knot_indices(const double* arc, std::size_t count, double spacing);

// times with each repeat nudged one representable step later (strictly increasing), in place.
void strictly_increasing(double* times, std::size_t count);

}  // namespace pfield::planning
