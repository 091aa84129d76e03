// Bindings of the 2D vector field (pfield.mobile): a thin list of defs over mobile/field2d.hpp.
#include <nanobind/nanobind.h>
#include <nanobind/stl/pair.h>
#include <nanobind/stl/tuple.h>

#include <algorithm>
#include <stdexcept>
#include <string>
#include <tuple>

#include "math/fast_exp.hpp"
#include "mobile/field2d.hpp"
#include "mobile/scan.hpp"
#include "mobile/world.hpp"
#include "python/arrays.hpp"

namespace pfield::python {
namespace {

using namespace nb::literals;
using mobile::Attraction;
using mobile::Clamping;
using mobile::FieldParams;
using mobile::ScanWeighting;
using mobile::SpeedLimits;

mobile::ObstaclePoints obstacle_points(const Vector& x, const Vector& y, const Vector& weight) {
  if (y.shape(0) != x.shape(0) || weight.shape(0) != x.shape(0))
    throw std::invalid_argument("obstacles: x, y and weights must have one entry per point");
  return {x.data(), y.data(), weight.data(), x.shape(0)};
}

mobile::Goal goal_of(const Vector& goal, bool present) {
  if (present && goal.shape(0) != 2) throw std::invalid_argument("goal: expected 2 numbers");
  return present ? mobile::Goal{goal.data()[0], goal.data()[1], true} : mobile::Goal{};
}

}  // namespace

void bind_mobile(nb::module_& m) {
  m.doc() = "The seed's 2D vector field and its clamping (pfield.mobile's compiled core).";

  nb::enum_<Attraction>(m, "Attraction").value("POWER", Attraction::Power).value("LINEAR", Attraction::Linear);
  nb::enum_<Clamping>(m, "Clamping").value("HARD", Clamping::Hard).value("TANH", Clamping::Tanh);

  nb::class_<FieldParams>(m, "FieldParams")
      .def(
          "__init__",
          [](FieldParams* self, double ka, Attraction law, double kr_dist, double kr_height, double kr_slope) {
            new (self) FieldParams{ka, law, kr_dist, kr_height, kr_slope};
          },
          "ka"_a, "law"_a, "kr_dist"_a, "kr_height"_a, "kr_slope"_a)
      .def_ro("ka", &FieldParams::ka)
      .def_ro("law", &FieldParams::law)
      .def_ro("kr_dist", &FieldParams::kr_dist)
      .def_ro("kr_height", &FieldParams::kr_height)
      .def_ro("kr_slope", &FieldParams::kr_slope);

  nb::class_<SpeedLimits>(m, "SpeedLimits")
      .def(
          "__init__",
          [](SpeedLimits* self, double min_speed, double max_speed, Clamping mode) {
            new (self) SpeedLimits{min_speed, max_speed, mode};
          },
          "min_speed"_a, "max_speed"_a, "mode"_a)
      .def_ro("min_speed", &SpeedLimits::min_speed)
      .def_ro("max_speed", &SpeedLimits::max_speed)
      .def_ro("mode", &SpeedLimits::mode);

  nb::class_<mobile::Components>(m, "Components", "V and the raw parts of -grad V at one point (components_at).")
      .def_ro("potential", &mobile::Components::potential, "V")
      .def_prop_ro(
          "attraction", [](const mobile::Components& c) { return std::make_tuple(c.attraction.x, c.attraction.y); },
          "(x, y) of the attraction's -grad V_a")
      .def_prop_ro(
          "repulsion", [](const mobile::Components& c) { return std::make_tuple(c.repulsion.x, c.repulsion.y); },
          "(x, y) of the repulsion's -grad V_r");

  nb::enum_<ScanWeighting>(m, "ScanWeighting")
      .value("SECTOR", ScanWeighting::Sector)
      .value("ARC_LENGTH", ScanWeighting::ArcLength)
      .value("SUM", ScanWeighting::Sum);

  m.def(
      "scan_points",
      [](const Vector& ranges, double angle_min, double angle_increment, double range_min, double range_max,
         double sensor_x, double sensor_y, double sensor_yaw, ScanWeighting weighting, double sector_angle) {
        mobile::ScanPoints scan;
        {
          nb::gil_scoped_release release;
          scan = mobile::scan_points(ranges.data(), ranges.shape(0), {angle_min, angle_increment, range_min, range_max},
                                     {sensor_x, sensor_y, sensor_yaw}, weighting, sector_angle);
        }
        const std::size_t count = scan.weights.size();
        auto [points, p] = new_array({count, 2});
        auto [weights, w] = new_array({count});
        std::copy(scan.points.begin(), scan.points.end(), p);
        std::copy(scan.weights.begin(), scan.weights.end(), w);
        return std::make_tuple(points, weights);
      },
      "ranges"_a, "angle_min"_a, "angle_increment"_a, "range_min"_a, "range_max"_a, "sensor_x"_a, "sensor_y"_a,
      "sensor_yaw"_a, "weighting"_a, "sector_angle"_a,
      "Valid beams -> (points (M, 2) in the sensor pose's parent frame, weights (M,)).");

  m.def(
      "raycast",
      [](double ox, double oy, const Vector& angles, double range_max, const Rows<3>& circles,
         const Rows<4>& segments) {
        const std::size_t count = angles.shape(0);
        auto [ranges, data] = new_array({count});
        const mobile::World2DView world{circles.data(), circles.shape(0), segments.data(), segments.shape(0)};
        {
          nb::gil_scoped_release release;
          mobile::raycast(world, ox, oy, angles.data(), count, range_max, data);
        }
        return ranges;
      },
      "ox"_a, "oy"_a, "angles"_a, "range_max"_a, "circles"_a, "segments"_a,
      "Range (m) of each beam from (ox, oy) at the world angles; inf where nothing is within range_max.");

  m.def(
      "clearance",
      [](double px, double py, const Rows<3>& circles, const Rows<4>& segments, const Points2& points) {
        const mobile::World2DView world{circles.data(), circles.shape(0), segments.data(), segments.shape(0),
                                        points.data(), points.shape(0)};
        return mobile::clearance(world, px, py);
      },
      "px"_a, "py"_a, "circles"_a, "segments"_a, "points"_a,
      "Distance (m) to the nearest circle boundary (negative inside), edge or point.");

  m.def("fast_exp", &math::fast_exp, "x"_a, "exp(x) to ~1 ulp on [-700, 700] (clipped outside), vectorisable.");

  m.def(
      "clamp_norm",
      [](double vx, double vy, double lower, double upper, Clamping mode) {
        const mobile::Vec2 v = mobile::clamp_norm({vx, vy}, lower, upper, mode);
        return std::make_tuple(v.x, v.y);
      },
      "vx"_a, "vy"_a, "lower"_a, "upper"_a, "mode"_a,
      "(vx, vy) rescaled so that its norm lies in [lower, upper], direction kept; zero stays zero.");

  m.def(
      "clamped_sum",
      [](double ax, double ay, double rx, double ry, const SpeedLimits& limits) {
        const mobile::Vec2 v = mobile::clamped_sum({ax, ay}, {rx, ry}, limits);
        return std::make_tuple(v.x, v.y);
      },
      "ax"_a, "ay"_a, "rx"_a, "ry"_a, "limits"_a, "The command from the raw attractive and repulsive parts.");

  m.def(
      "clamped_sum_batch",
      [](const Points2& attraction, const Points2& repulsion, const SpeedLimits& limits) {
        if (repulsion.shape(0) != attraction.shape(0))
          throw std::invalid_argument("repulsion: expected as many rows as attraction");
        auto [out, data] = new_array({attraction.shape(0), 2});
        {
          nb::gil_scoped_release release;
          mobile::clamped_sum_batch(attraction.data(), repulsion.data(), attraction.shape(0), limits, data);
        }
        return out;
      },
      "attraction"_a, "repulsion"_a, "limits"_a, "clamped_sum over the rows of (N, 2) arrays.");

  m.def(
      "components_at",
      [](double px, double py, const Vector& goal, bool has_goal, const Vector& ox, const Vector& oy,
         const Vector& weights, const FieldParams& params) {
        return mobile::components_at(px, py, goal_of(goal, has_goal), obstacle_points(ox, oy, weights), params);
      },
      "px"_a, "py"_a, "goal"_a, "has_goal"_a, "obstacles_x"_a, "obstacles_y"_a, "weights"_a, "params"_a,
      "Components: the potential and the raw attractive and repulsive parts of -grad V.");

  m.def(
      "velocity_at",
      [](double px, double py, const Vector& goal, bool has_goal, const Vector& ox, const Vector& oy,
         const Vector& weights, const FieldParams& params, const SpeedLimits& limits) {
        const mobile::Vec2 v = mobile::velocity_at(px, py, goal_of(goal, has_goal), obstacle_points(ox, oy, weights),
                                                   params, limits);
        return std::make_tuple(v.x, v.y);
      },
      "px"_a, "py"_a, "goal"_a, "has_goal"_a, "obstacles_x"_a, "obstacles_y"_a, "weights"_a, "params"_a, "limits"_a,
      "The clamped command at one point.");

  m.def(
      "components_batch",
      [](const Points2& points, const Vector& goal, bool has_goal, const Vector& ox, const Vector& oy,
         const Vector& weights, const FieldParams& params) {
        const std::size_t n = points.shape(0);
        auto [potential, v] = new_array({n});
        auto [attraction, a] = new_array({n, 2});
        auto [repulsion, r] = new_array({n, 2});
        const mobile::Goal target = goal_of(goal, has_goal);
        const mobile::ObstaclePoints obstacles = obstacle_points(ox, oy, weights);
        {
          nb::gil_scoped_release release;
          mobile::components_batch(points.data(), n, target, obstacles, params, v, a, r);
        }
        return std::make_tuple(potential, attraction, repulsion);
      },
      "points"_a, "goal"_a, "has_goal"_a, "obstacles_x"_a, "obstacles_y"_a, "weights"_a, "params"_a,
      "components_at over (N, 2) points: V (N,), attraction (N, 2), repulsion (N, 2).");

  m.def(
      "potential_batch",
      [](const Points2& points, const Vector& goal, bool has_goal, const Vector& ox, const Vector& oy,
         const Vector& weights, const FieldParams& params) {
        const std::size_t n = points.shape(0);
        auto [out, data] = new_array({n});
        const mobile::Goal target = goal_of(goal, has_goal);
        const mobile::ObstaclePoints obstacles = obstacle_points(ox, oy, weights);
        {
          nb::gil_scoped_release release;
          mobile::potential_batch(points.data(), n, target, obstacles, params, data);
        }
        return out;
      },
      "points"_a, "goal"_a, "has_goal"_a, "obstacles_x"_a, "obstacles_y"_a, "weights"_a, "params"_a,
      "V only, at (N, 2) points.");
}

}  // namespace pfield::python
