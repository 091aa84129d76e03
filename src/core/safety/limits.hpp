// The output contract: every command pfield returns is finite and within its velocity limits (docs/assistance.md
// "The output contract"; pfield.safety is its Python face and calls these). The one home of these rules.
//
// 1. A command with a NaN or an infinity is replaced by zeros (Halted).
// 2. A twist whose linear part is longer than max_linear or whose angular part is longer than max_angular is
//    scaled by the one factor that brings both within (direction kept); joint velocities by s = min_j v_j / |qd_j|
//    (MoveIt Servo's scaling), and a whole-body command's joints and twist by one factor, the smaller (Scaled).
// 3. Inputs beyond the limits (a previous twist, previous joint velocities) are clipped before use (clip_*).
// Norms are taken as m |v/m| with m = max |v_i|, so 1e308 components neither overflow nor lose their direction.
//
// One compiled copy (limits.cpp, built without fused multiply-adds like the core's field and robot files): every
// caller, the binding files (built with -ffp-contract=fast) and pfield.safety's Python face alike, gets the same
// bits. Inline here, std::hypot's sum of squares would take fused multiply-adds in some files and not in others.
#pragma once

#include <cstddef>

namespace pfield::safety {

enum class Outcome : int { Within = 0, Scaled = 1, Halted = 2 };

// The largest s <= 1 with s |(x, y, z)| <= limit, for finite components.
double part_scale(double x, double y, double z, double limit);

// The factor in [0, 1] that brings the twist (linear, angular) within both limits; NaN when a component is not
// finite.
double twist_scale(const double* v, double max_linear, double max_angular);

// min(1, min_j limit_j / |qd_j|) over joints with a positive finite limit; NaN when a qd_j is not finite.
double joint_scale(const double* qd, const double* limits, std::size_t n);

// Rules 1 and 2 with a factor of twist_scale / joint_scale on `count` values in place.
Outcome apply(double scale, double* values, std::size_t count);

// Rules 1 and 2 on a twist (6) in place.
Outcome limit_twist(double* v, double max_linear, double max_angular);

// Rules 1 and 2 on a whole-body command in place: qd (n) and its twist J qd (6) by one factor, the smaller of
// the two rules (both zeroed when either is not finite).
Outcome limit_joint_command(double* qd, std::size_t n, double* twist, const double* limits, double max_linear,
                            double max_angular);

}  // namespace pfield::safety
