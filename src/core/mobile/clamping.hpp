// The speed clamping strategy of the original vector-field controller (seed document 004); see
// pfield/mobile/clamping.py for the rules and why the sum's clamp is always hard.
#pragma once

#include <algorithm>
#include <cmath>

namespace pfield::mobile {

enum class Clamping { Hard = 0, Tanh = 1 };

struct Vec2 {
  double x = 0.0;
  double y = 0.0;
};

struct SpeedLimits {
  double min_speed = 0.0;  // m/s, lower bound of the attractive part
  double max_speed = 1.0;  // m/s, upper bound of every part and of the command
  Clamping mode = Clamping::Hard;
};

// (vx, vy) rescaled so that its norm lies in [lower, upper], direction kept; zero stays zero. Works on
// v / max(|vx|, |vy|), so neither the norm nor its inverse under- or overflows (subnormal vectors keep their
// direction, 1e308 components do not overflow).
inline Vec2 clamp_norm(Vec2 v, double lower, double upper, Clamping mode) {
  const double scale = std::max(std::abs(v.x), std::abs(v.y));
  if (scale == 0.0) return {0.0, 0.0};
  const double ux = v.x / scale, uy = v.y / scale;
  const double length = std::hypot(ux, uy);  // in [1, sqrt 2]
  const double norm = scale * length;
  const double target = mode == Clamping::Tanh ? std::max(lower, upper * std::tanh(norm / upper))
                                               : std::min(std::max(norm, lower), upper);
  const double factor = target / length;
  return {ux * factor, uy * factor};
}

// The command from the raw attractive and repulsive parts: repulsion clamped to [0, max], attraction to
// [min, max], their sum (hard) to [0, max].
inline Vec2 clamped_sum(Vec2 attraction, Vec2 repulsion, const SpeedLimits& limits) {
  const Vec2 r = clamp_norm(repulsion, 0.0, limits.max_speed, limits.mode);
  const Vec2 a = clamp_norm(attraction, limits.min_speed, limits.max_speed, limits.mode);
  return clamp_norm({a.x + r.x, a.y + r.y}, 0.0, limits.max_speed, Clamping::Hard);
}

}  // namespace pfield::mobile
