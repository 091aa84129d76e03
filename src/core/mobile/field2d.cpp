#include "mobile/field2d.hpp"

#include <algorithm>
#include <cmath>

#include "math/fast_exp.hpp"

namespace pfield::mobile {
namespace {

constexpr double kMaxMagnitude = 1e300;  // cap of the power law's ka d^(ka-1) for ka < 1 at d -> 0

Vec2 attraction_at(double px, double py, const Goal& goal, const FieldParams& params) {
  const double dx = goal.x - px, dy = goal.y - py;
  if (params.law == Attraction::Linear) return {params.ka * dx, params.ka * dy};
  const double distance = std::hypot(dx, dy);  // hypot: no underflow to 0 next to the goal
  if (distance == 0.0 || params.ka == 0.0) return {0.0, 0.0};
  const double magnitude = std::min(params.ka * std::pow(distance, params.ka - 1.0), kMaxMagnitude);
  return {magnitude * (dx / distance), magnitude * (dy / distance)};
}

double attraction_potential(double px, double py, const Goal& goal, const FieldParams& params) {
  const double d2 = (goal.x - px) * (goal.x - px) + (goal.y - py) * (goal.y - py);
  if (params.law == Attraction::Linear) return 0.5 * params.ka * d2;
  return std::pow(d2, 0.5 * params.ka);  // 0^0 = 1
}

// The hill h's gradient factor h / r along the unit direction (dx, dy) / r; 0 where the direction is undefined, and
// a subnormal r gives no infinity.
inline double per_distance(double h, double r) { return r > 0.0 ? h / std::max(r, 1e-300) : 0.0; }

// One obstacle point's hill at distance r, w e^(kr_slope (kr_dist - r)): V_r's term without kr_height / kr_slope.
inline double hill(double weight, double r, double slope, double dist) {
  return weight * math::fast_exp(slope * (dist - r));
}

// (V_r, -dV_r/dx, -dV_r/dy) summed over the weighted obstacle points; the reduction is vectorised.
Components repulsion_at(double px, double py, const ObstaclePoints& obstacles, const FieldParams& params) {
  double value = 0.0, fx = 0.0, fy = 0.0;
  const double slope = params.kr_slope, dist = params.kr_dist;
  const double *ox = obstacles.x, *oy = obstacles.y, *weight = obstacles.weight;  // see potential_batch
  const std::size_t count = obstacles.count;
#pragma omp simd reduction(+ : value, fx, fy)
  for (std::size_t j = 0; j < count; ++j) {
    const double dx = px - ox[j], dy = py - oy[j];
    const double r = std::sqrt(dx * dx + dy * dy);
    const double h = hill(weight[j], r, slope, dist);
    value += h;
    const double along = per_distance(h, r);
    fx += along * dx;
    fy += along * dy;
  }
  Components out;
  out.potential = value * (params.kr_height / slope);
  out.repulsion = {fx * params.kr_height, fy * params.kr_height};
  return out;
}

}  // namespace

Components components_at(double px, double py, const Goal& goal, const ObstaclePoints& obstacles,
                         const FieldParams& params) {
  Components out = repulsion_at(px, py, obstacles, params);
  if (goal.present) {
    out.attraction = attraction_at(px, py, goal, params);
    out.potential += attraction_potential(px, py, goal, params);
  }
  return out;
}

Vec2 velocity_at(double px, double py, const Goal& goal, const ObstaclePoints& obstacles, const FieldParams& params,
                 const SpeedLimits& limits) {
  const Components parts = components_at(px, py, goal, obstacles, params);
  return clamped_sum(parts.attraction, parts.repulsion, limits);
}

void potential_batch(const double* points, std::size_t n, const Goal& goal, const ObstaclePoints& obstacles,
                     const FieldParams& params, double* out) {
  const double slope = params.kr_slope, dist = params.kr_dist;
  // The columns as locals: read through `obstacles` in the loop, GCC built each lane's address from the struct's
  // pointer and loaded the lanes one by one (a gather, 3.7x slower than the contiguous loads it makes here).
  const double *ox = obstacles.x, *oy = obstacles.y, *weight = obstacles.weight;
  const std::size_t count = obstacles.count;
  const double scale = params.kr_height / slope;
  auto finish = [&](std::size_t i, double hills) {
    out[i] = hills * scale;
    if (goal.present) out[i] += attraction_potential(points[2 * i], points[2 * i + 1], goal, params);
  };
  // Four points per pass over the obstacles: each column is loaded once for the four, and their sums are independent
  // chains (the bench's 200x200 image of 720 points: 21.9 ms one point per pass, 19.1 two, 18.2 four; an array of
  // sums with an inner loop over the points instead: 27 ms, GCC 12 does not vectorise that reduction). The last
  // pass repeats the last point where n is not a multiple of four.
  for (std::size_t a = 0; a < n; a += 4) {
    const std::size_t b = std::min(a + 1, n - 1), c = std::min(a + 2, n - 1), d = std::min(a + 3, n - 1);
    const double ax = points[2 * a], ay = points[2 * a + 1], bx = points[2 * b], by = points[2 * b + 1];
    const double cx = points[2 * c], cy = points[2 * c + 1], dx_ = points[2 * d], dy_ = points[2 * d + 1];
    double hills_a = 0.0, hills_b = 0.0, hills_c = 0.0, hills_d = 0.0;
#pragma omp simd reduction(+ : hills_a, hills_b, hills_c, hills_d)
    for (std::size_t j = 0; j < count; ++j) {
      const double adx = ax - ox[j], ady = ay - oy[j], bdx = bx - ox[j], bdy = by - oy[j];
      const double cdx = cx - ox[j], cdy = cy - oy[j], ddx = dx_ - ox[j], ddy = dy_ - oy[j];
      hills_a += hill(weight[j], std::sqrt(adx * adx + ady * ady), slope, dist);
      hills_b += hill(weight[j], std::sqrt(bdx * bdx + bdy * bdy), slope, dist);
      hills_c += hill(weight[j], std::sqrt(cdx * cdx + cdy * cdy), slope, dist);
      hills_d += hill(weight[j], std::sqrt(ddx * ddx + ddy * ddy), slope, dist);
    }
    finish(a, hills_a);
    finish(b, hills_b);
    finish(c, hills_c);
    finish(d, hills_d);
  }
}

void components_batch(const double* points, std::size_t n, const Goal& goal, const ObstaclePoints& obstacles,
                      const FieldParams& params, double* potential, double* attraction, double* repulsion) {
  // Four points per pass over the obstacles, as potential_batch, three sums each (the command image: 31.6 ms one
  // point per pass, 29.4 two, 26.4 four). The last pass repeats the last point where n is not a multiple of four.
  const double slope = params.kr_slope, dist = params.kr_dist;
  const double *ox = obstacles.x, *oy = obstacles.y, *weight = obstacles.weight;  // see potential_batch
  const std::size_t count = obstacles.count;
  auto finish = [&](std::size_t i, double value, double fx, double fy) {
    const double px = points[2 * i], py = points[2 * i + 1];
    potential[i] = value * (params.kr_height / slope);
    repulsion[2 * i] = fx * params.kr_height;
    repulsion[2 * i + 1] = fy * params.kr_height;
    Vec2 pull;
    if (goal.present) {
      pull = attraction_at(px, py, goal, params);
      potential[i] += attraction_potential(px, py, goal, params);
    }
    attraction[2 * i] = pull.x;
    attraction[2 * i + 1] = pull.y;
  };
  for (std::size_t a = 0; a < n; a += 4) {
    const std::size_t b = std::min(a + 1, n - 1), c = std::min(a + 2, n - 1), d = std::min(a + 3, n - 1);
    const double ax = points[2 * a], ay = points[2 * a + 1], bx = points[2 * b], by = points[2 * b + 1];
    const double cx = points[2 * c], cy = points[2 * c + 1], dx = points[2 * d], dy = points[2 * d + 1];
    double va = 0.0, fxa = 0.0, fya = 0.0, vb = 0.0, fxb = 0.0, fyb = 0.0;
    double vc = 0.0, fxc = 0.0, fyc = 0.0, vd = 0.0, fxd = 0.0, fyd = 0.0;
#pragma omp simd reduction(+ : va, fxa, fya, vb, fxb, fyb, vc, fxc, fyc, vd, fxd, fyd)
    for (std::size_t j = 0; j < count; ++j) {
      const double adx = ax - ox[j], ady = ay - oy[j], bdx = bx - ox[j], bdy = by - oy[j];
      const double cdx = cx - ox[j], cdy = cy - oy[j], ddx = dx - ox[j], ddy = dy - oy[j];
      const double ra = std::sqrt(adx * adx + ady * ady), rb = std::sqrt(bdx * bdx + bdy * bdy);
      const double rc = std::sqrt(cdx * cdx + cdy * cdy), rd = std::sqrt(ddx * ddx + ddy * ddy);
      const double ha = hill(weight[j], ra, slope, dist), hb = hill(weight[j], rb, slope, dist);
      const double hc = hill(weight[j], rc, slope, dist), hd = hill(weight[j], rd, slope, dist);
      const double ia = per_distance(ha, ra), ib = per_distance(hb, rb), ic = per_distance(hc, rc);
      const double id = per_distance(hd, rd);
      va += ha, fxa += ia * adx, fya += ia * ady;
      vb += hb, fxb += ib * bdx, fyb += ib * bdy;
      vc += hc, fxc += ic * cdx, fyc += ic * cdy;
      vd += hd, fxd += id * ddx, fyd += id * ddy;
    }
    finish(a, va, fxa, fya);
    finish(b, vb, fxb, fyb);
    finish(c, vc, fxc, fyc);
    finish(d, vd, fxd, fyd);
  }
}

void clamped_sum_batch(const double* attraction, const double* repulsion, std::size_t n, const SpeedLimits& limits,
                       double* out) {
  for (std::size_t i = 0; i < n; ++i) {
    const Vec2 v = clamped_sum({attraction[2 * i], attraction[2 * i + 1]}, {repulsion[2 * i], repulsion[2 * i + 1]},
                               limits);
    out[2 * i] = v.x;
    out[2 * i + 1] = v.y;
  }
}

}  // namespace pfield::mobile
