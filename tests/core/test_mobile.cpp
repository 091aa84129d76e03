// The 2D vector field's core (src/core/mobile): exact values, the gradient against central differences, the
// clamping invariants and fast_exp's accuracy. Also run under AddressSanitizer and UBSan (make core-sanitize).
#include <cmath>
#include <vector>

#include "harness.hpp"
#include "math/fast_exp.hpp"
#include "mobile/field2d.hpp"
#include "mobile/scan.hpp"
#include "mobile/world.hpp"

namespace {

using namespace pfield::mobile;

const std::vector<double> kObstaclesX = {1.0, -0.8, 0.3, 2.0};
const std::vector<double> kObstaclesY = {0.5, 1.2, -1.1, 2.0};
const std::vector<double> kWeights = {1.0, 1.0, 0.5, 2.0};

ObstaclePoints obstacles() { return {kObstaclesX.data(), kObstaclesY.data(), kWeights.data(), kObstaclesX.size()}; }

double potential_at(double x, double y, const Goal& goal, const FieldParams& params) {
  const double point[2] = {x, y};
  double value = 0.0;
  potential_batch(point, 1, goal, obstacles(), params, &value);
  return value;
}

}  // namespace

TEST(fast_exp_is_within_a_few_ulp_on_its_range) {
  double worst = 0.0;
  for (double x = -700.0; x <= 700.0; x += 0.0137) worst = std::max(worst, std::abs(pfield::math::fast_exp(x) / std::exp(x) - 1.0));
  CHECK(worst < 1e-15);
  CHECK(pfield::math::fast_exp(-1e308) == pfield::math::fast_exp(-700.0));  // clipped below, never 0
  CHECK(pfield::math::fast_exp(-1e308) > 0.0);
}

TEST(potential_has_the_seed_values) {
  const FieldParams params{2.0, Attraction::Power, 0.5, 2.0, 4.0};
  const double origin[2] = {3.0, 0.0};
  double value = 0.0;
  potential_batch(origin, 1, Goal{0.0, 0.0, true}, ObstaclePoints{}, params, &value);
  CHECK_NEAR(value, 9.0, 1e-15);  // |d|^ka at distance 3
  const double ox = 0.0, oy = 0.0, w = 1.0;
  const double on_hill[2] = {0.5, 0.0};
  potential_batch(on_hill, 1, Goal{}, ObstaclePoints{&ox, &oy, &w, 1}, params, &value);
  CHECK_NEAR(value, 0.5, 1e-14);  // one hill of height kr_height / kr_slope at r = kr_dist
}

TEST(gradient_matches_central_differences) {
  for (Attraction law : {Attraction::Power, Attraction::Linear}) {
    const FieldParams params{2.5, law, 0.3, 1.5, 2.0};
    const Goal goal{0.4, 0.2, true};
    for (double x = -2.9; x < 3.0; x += 0.77) {
      for (double y = -2.7; y < 3.0; y += 0.83) {
        const Components c = components_at(x, y, goal, obstacles(), params);
        const double h = 1e-6;
        const double gx = (potential_at(x + h, y, goal, params) - potential_at(x - h, y, goal, params)) / (2 * h);
        const double gy = (potential_at(x, y + h, goal, params) - potential_at(x, y - h, goal, params)) / (2 * h);
        const double scale = 1.0 + std::hypot(gx, gy);
        CHECK_NEAR(c.attraction.x + c.repulsion.x, -gx, 1e-6 * scale);
        CHECK_NEAR(c.attraction.y + c.repulsion.y, -gy, 1e-6 * scale);
        CHECK_NEAR(c.potential, potential_at(x, y, goal, params), 1e-12 * (1.0 + std::abs(c.potential)));
      }
    }
  }
}

TEST(batches_agree_with_the_single_point_evaluation) {
  // the batches take four points per pass over the obstacles (the last pass repeats the last point): every row, a
  // full pass's and the short last one's, is the single-point evaluation's (to rounding: the vectorised sums may add
  // in another order)
  const FieldParams params{2.5, Attraction::Power, 0.3, 1.5, 2.0};
  const Goal goal{0.4, 0.2, true};
  // five points (a full pass and one more), the fourth on an obstacle point
  const std::vector<double> points = {-1.0, 0.5, 0.3, -1.1, 2.2, 1.9, 1.0, 0.5, -2.5, 0.0};
  const std::size_t n = points.size() / 2;
  std::vector<double> potential(n), only(n), attraction(2 * n), repulsion(2 * n);
  components_batch(points.data(), n, goal, obstacles(), params, potential.data(), attraction.data(), repulsion.data());
  potential_batch(points.data(), n, goal, obstacles(), params, only.data());
  for (std::size_t i = 0; i < n; ++i) {
    const Components c = components_at(points[2 * i], points[2 * i + 1], goal, obstacles(), params);
    const auto near = [](double a, double b) { return std::abs(a - b) <= 1e-13 * (1.0 + std::abs(b)); };
    CHECK(near(potential[i], c.potential) && near(only[i], c.potential));
    CHECK(near(attraction[2 * i], c.attraction.x) && near(attraction[2 * i + 1], c.attraction.y));
    CHECK(near(repulsion[2 * i], c.repulsion.x) && near(repulsion[2 * i + 1], c.repulsion.y));
  }
}

TEST(no_direction_no_nan) {
  const FieldParams params{0.5, Attraction::Power, 0.0, 1.0, 1.0};
  const double ox = 1.0, oy = 1.0, w = 1.0;
  const Components c = components_at(1.0, 1.0, Goal{1.0, 1.0, true}, ObstaclePoints{&ox, &oy, &w, 1}, params);
  CHECK(c.attraction.x == 0.0 && c.attraction.y == 0.0 && c.repulsion.x == 0.0 && c.repulsion.y == 0.0);
}

TEST(clamping_keeps_direction_and_bounds) {
  for (Clamping mode : {Clamping::Hard, Clamping::Tanh}) {
    for (double angle = 0.0; angle < 6.3; angle += 0.41) {
      for (double norm : {5e-324, 1e-3, 0.3, 2.0, 1e308}) {
        const Vec2 v{norm * std::cos(angle), norm * std::sin(angle)};
        const Vec2 c = clamp_norm(v, 0.1, 1.0, mode);
        const double length = std::hypot(c.x, c.y);
        CHECK(length >= 0.1 * (1 - 1e-12) && length <= 1.0 * (1 + 1e-12));
        CHECK_NEAR(c.x * v.y - c.y * v.x, 0.0, 1e-12 * std::abs(norm));  // parallel
        CHECK(c.x * v.x + c.y * v.y >= 0.0);                               // same way
      }
    }
  }
  const Vec2 zero = clamp_norm({0.0, 0.0}, 0.1, 1.0, Clamping::Hard);
  CHECK(zero.x == 0.0 && zero.y == 0.0);
  const Vec2 sum = clamped_sum({5.0, 0.0}, {5.0, 0.0}, SpeedLimits{0.1, 1.0, Clamping::Hard});
  CHECK_NEAR(sum.x, 1.0, 1e-15);
}

TEST(raycast_and_clearance_of_a_circle_and_a_square) {
  const double circle[3] = {2.0, 0.0, 0.5};
  const double square[16] = {-1, 2, 1, 2, 1, 2, 1, 4, 1, 4, -1, 4, -1, 4, -1, 2};  // edges of [-1,1]x[2,4]
  const double point[2] = {-3.0, 0.0};
  const World2DView world{circle, 1, square, 4, point, 1};
  const double angles[4] = {0.0, 1.5707963267948966, 3.141592653589793, -1.5707963267948966};
  double ranges[4];
  raycast(world, 0.0, 0.0, angles, 4, 10.0, ranges);
  CHECK_NEAR(ranges[0], 1.5, 1e-12);  // the circle's near side
  CHECK_NEAR(ranges[1], 2.0, 1e-12);  // the square's lower edge
  CHECK(std::isinf(ranges[2]) && std::isinf(ranges[3]));  // points are not seen by rays; nothing below
  CHECK_NEAR(clearance(world, 0.0, 0.0), 1.5, 1e-12);
  CHECK_NEAR(clearance(world, 2.0, 0.0), -0.5, 1e-12);  // inside the circle
  CHECK_NEAR(clearance(world, -2.5, 0.0), 0.5, 1e-12);  // the point
}

TEST(scan_keeps_the_nearest_beam_per_sector) {
  std::vector<double> ranges(72, 5.0);
  ranges[10] = 1.0;
  ranges[11] = std::nan("");
  const ScanGeometry geometry{-3.141592653589793, 3.141592653589793 / 36, 0.1, 10.0};
  const ScanPoints every = scan_points(ranges.data(), ranges.size(), geometry, Pose2D{}, ScanWeighting::Sum, 0.1);
  CHECK(every.weights.size() == 71);  // the NaN beam is dropped
  const ScanPoints sectors = scan_points(ranges.data(), ranges.size(), geometry, Pose2D{1.0, 0.0, 0.0},
                                         ScanWeighting::Sector, 3.141592653589793 / 2);
  CHECK(sectors.weights.size() == 4);
  const double angle = -3.141592653589793 + 10 * 3.141592653589793 / 36;
  bool found = false;
  for (std::size_t k = 0; k < 4; ++k)
    found = found || (std::abs(sectors.points[2 * k] - (1.0 + std::cos(angle))) < 1e-12 &&
                      std::abs(sectors.points[2 * k + 1] - std::sin(angle)) < 1e-12);
  CHECK(found);
}
