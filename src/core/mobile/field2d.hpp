// The seed's 2D potential, its exact gradient and the clamped command (seed document 004):
//
//   V(p) = V_a(p) + sum_i w_i (kr_height / kr_slope) exp(kr_slope (kr_dist - |p - p_ri|))
//   power law:  V_a = |p - p_a|^ka,       -grad V_a = ka |p - p_a|^(ka-2) (p_a - p)
//   linear law: V_a = (ka/2)|p - p_a|^2,  -grad V_a = ka (p_a - p)
//   repulsion:  -grad V_r = sum_i w_i kr_height exp(kr_slope (kr_dist - r_i)) (p - p_ri) / r_i
//
// Where a direction is undefined (p on the goal, p on an obstacle point) that term is zero, so no NaN arises.
// Preconditions (checked by pfield.mobile in Python): finite coordinates and weights >= 0, kr_slope > 0.
#pragma once

#include <cstddef>

#include "mobile/clamping.hpp"

namespace pfield::mobile {

enum class Attraction { Power = 0, Linear = 1 };

struct FieldParams {
  double ka = 1.0;
  Attraction law = Attraction::Power;
  double kr_dist = 0.0;
  double kr_height = 1.0;
  double kr_slope = 1.0;
};

// Obstacle points as two columns (structure of arrays, so the sums vectorise) and their weights; views.
struct ObstaclePoints {
  const double* x = nullptr;
  const double* y = nullptr;
  const double* weight = nullptr;
  std::size_t count = 0;
};

struct Goal {
  double x = 0.0;
  double y = 0.0;
  bool present = false;  // no goal: no attraction
};

// V and the two raw parts of -grad V at one point.
struct Components {
  double potential = 0.0;
  Vec2 attraction;
  Vec2 repulsion;
};

Components components_at(double px, double py, const Goal& goal, const ObstaclePoints& obstacles,
                         const FieldParams& params);

// The clamped command at one point (what the base controller runs every tick).
Vec2 velocity_at(double px, double py, const Goal& goal, const ObstaclePoints& obstacles, const FieldParams& params,
                 const SpeedLimits& limits);

// V only, at n points (row-major (n, 2)): one exponential per point and obstacle, nothing else (images).
void potential_batch(const double* points, std::size_t n, const Goal& goal, const ObstaclePoints& obstacles,
                     const FieldParams& params, double* out);

// components_at over n points: V (n,), attraction (n, 2), repulsion (n, 2).
void components_batch(const double* points, std::size_t n, const Goal& goal, const ObstaclePoints& obstacles,
                      const FieldParams& params, double* potential, double* attraction, double* repulsion);

// clamped_sum over n rows of (n, 2) attraction and repulsion arrays into (n, 2) out.
void clamped_sum_batch(const double* attraction, const double* repulsion, std::size_t n, const SpeedLimits& limits,
                       double* out);

}  // namespace pfield::mobile
