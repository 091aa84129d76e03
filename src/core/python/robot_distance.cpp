// Bindings of the link distances (pfield.robot's closest points and clearances): a thin list of defs over
// robot/distance.hpp and robot/clearance.hpp. The link model is a robot.Robot's, the obstacles a robot.Obstacles
// (python/robot_arrays.hpp: each held once, validated). No arithmetic here (this file is compiled with the default
// contraction): the core computes.
#include <nanobind/nanobind.h>
#include <nanobind/stl/tuple.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <tuple>

#include "geometry/packed.hpp"
#include "python/arrays.hpp"
#include "python/robot_arrays.hpp"
#include "robot/clearance.hpp"
#include "robot/distance.hpp"
#include "robot/robot.hpp"

namespace pfield::python {
namespace {

using namespace nb::literals;
using math::Vec3;
using robot::ClearanceLevel;
using robot::LinkObstacleDistance;
using robot::LinkPairDistance;
using robot::SegmentDistance;
using robot::SegmentParameters;

constexpr double kInf = std::numeric_limits<double>::infinity();

Vec3 vec3(const Point& p) { return {p.data()[0], p.data()[1], p.data()[2]}; }
std::tuple<double, double, double> tuple3(const Vec3& v) { return {v.x, v.y, v.z}; }

// World ends of a link model's segments (new arrays; rows near_segments leaves untouched are NaN).
struct Segments {
  NumpyArray cap_a, cap_b, prim_a, prim_b;
  robot::WorldSegments view;

  Segments(std::size_t caps, std::size_t prims) {
    double *ca, *cb, *pa, *pb;
    std::tie(cap_a, ca) = new_array({caps, 3});
    std::tie(cap_b, cb) = new_array({caps, 3});
    std::tie(prim_a, pa) = new_array({prims, 3});
    std::tie(prim_b, pb) = new_array({prims, 3});
    const double nan = std::numeric_limits<double>::quiet_NaN();
    std::fill(ca, ca + 3 * caps, nan), std::fill(cb, cb + 3 * caps, nan);
    std::fill(pa, pa + 3 * prims, nan), std::fill(pb, pb + 3 * prims, nan);
    view = {ca, cb, pa, pb};
  }
};

// Link-obstacle (caps, M) and self-pair (pairs,) clearances.
struct Clearances {
  NumpyArray obstacle, own;
};

// A robot's link model at joint frames read in place (rotations (n, 3, 3), origins (n, 3): Frames' pointers are
// not const; nothing here writes them).
robot::Frames frames_of(const RobotArrays& robot, const Rotations& rotations, const Rows<3>& origins) {
  require(rotations.shape(0) == robot.joints() && origins.shape(0) == robot.joints(),
          "frames: rotations (n, 3, 3) and origins (n, 3), one per joint");
  return {const_cast<double*>(rotations.data()), const_cast<double*>(origins.data())};
}

// World ends of the robot's segments, new arrays (rows near_segments leaves untouched are NaN).
Segments new_segments(const RobotArrays& robot) { return Segments(robot.capsules(), robot.primitives()); }

void check(const RobotArrays& robot, const Segments& world) {
  require(world.cap_a.shape(0) == robot.capsules() && world.prim_a.shape(0) == robot.primitives(),
          "segments: not this robot's link model");
}

std::size_t link(const RobotArrays& robot, std::int64_t l) {
  require(l >= 0 && static_cast<std::size_t>(l) < robot.capsules(), "link: index out of range");
  return static_cast<std::size_t>(l);
}

// Link-obstacle (caps, M) and self-pair (pairs,) clearances, new arrays.
Clearances new_clearances(const RobotArrays& robot, const ObstacleArrays& obstacles, double** obstacle, double** own) {
  Clearances out;
  std::tie(out.obstacle, *obstacle) = new_array({robot.capsules(), obstacles.count()});
  std::tie(out.own, *own) = new_array({robot.pairs()});
  return out;
}

}  // namespace

void bind_robot_distance(nb::module_& m) {
  m.doc() = "Closest points between link segments and obstacles, and the link model's clearances "
            "(pfield.robot's compiled core).";

  nb::class_<SegmentParameters>(m, "SegmentParameters", "Parameters in [0, 1] of two segments' closest points.")
      .def_ro("s", &SegmentParameters::s, "on the first segment")
      .def_ro("t", &SegmentParameters::t, "on the second segment");
  nb::class_<SegmentDistance>(m, "SegmentDistance", "min over t of a segment point's signed distance to an obstacle.")
      .def_ro("distance", &SegmentDistance::distance, "m, negative inside")
      .def_ro("t", &SegmentDistance::t, "the minimising parameter in [0, 1]")
      .def_prop_ro("normal", [](const SegmentDistance& d) { return tuple3(d.normal); },
                   "the obstacle's outward unit normal at a + t (b - a)");
  nb::enum_<ClearanceLevel>(m, "ClearanceLevel", "Which level of the link model answered a link-obstacle pair.")
      .value("Culled", ClearanceLevel::Culled, "bounding sphere against bounding capsule: a bound >= cutoff")
      .value("Capsule", ClearanceLevel::Capsule, "the bounding capsule: exact from 10 cm, else a bound")
      .value("Primitives", ClearanceLevel::Primitives, "the fitted primitives");
  nb::class_<LinkObstacleDistance>(m, "LinkObstacleDistance", "One link-obstacle pair's clearance.")
      .def_ro("distance", &LinkObstacleDistance::distance, "m; a lower bound when not exact")
      .def_ro("exact", &LinkObstacleDistance::exact)
      .def_ro("level", &LinkObstacleDistance::level)
      .def_prop_ro("point", [](const LinkObstacleDistance& d) { return tuple3(d.point); },
                   "closest point on the deciding segment's axis (world)")
      .def_prop_ro("normal", [](const LinkObstacleDistance& d) { return tuple3(d.normal); },
                   "the obstacle's outward unit normal there")
      .def_ro("link", &LinkObstacleDistance::link)
      .def_ro("obstacle", &LinkObstacleDistance::obstacle)
      .def_ro("primitive", &LinkObstacleDistance::primitive, "the deciding fitted primitive, -1 for none");
  nb::class_<LinkPairDistance>(m, "LinkPairDistance", "A self pair's clearance on the covering capsules.")
      .def_ro("distance", &LinkPairDistance::distance, "m, less both radii")
      .def_prop_ro("first", [](const LinkPairDistance& d) { return tuple3(d.first); }, "on the first link's axis")
      .def_prop_ro("second", [](const LinkPairDistance& d) { return tuple3(d.second); }, "on the second link's axis");
  nb::class_<Segments>(m, "WorldSegments", "World ends of a link model's segments at one configuration.")
      .def_prop_ro("cap_a", [](const Segments& x) { return x.cap_a; }, nb::rv_policy::automatic)
      .def_prop_ro("cap_b", [](const Segments& x) { return x.cap_b; }, nb::rv_policy::automatic)
      .def_prop_ro("prim_a", [](const Segments& x) { return x.prim_a; }, nb::rv_policy::automatic)
      .def_prop_ro("prim_b", [](const Segments& x) { return x.prim_b; }, nb::rv_policy::automatic);
  nb::class_<Clearances>(m, "Clearances", "Link-obstacle clearances (caps, M) and self-pair clearances (pairs,).")
      .def_prop_ro("obstacle", [](const Clearances& x) { return x.obstacle; }, nb::rv_policy::automatic)
      .def_prop_ro("own", [](const Clearances& x) { return x.own; }, nb::rv_policy::automatic);

  m.def(
      "closest_segment_points",
      [](const Point& p1, const Point& q1, const Point& p2, const Point& q2) {
        return robot::closest_segment_points(vec3(p1), vec3(q1), vec3(p2), vec3(q2));
      },
      "p1"_a, "q1"_a, "p2"_a, "q2"_a, "Parameters (s, t) of the closest points of segments p1-q1 and p2-q2.");
  m.def(
      "segment_segment_distance",
      [](const Point& p1, const Point& q1, const Point& p2, const Point& q2) {
        return robot::segment_segment_distance(vec3(p1), vec3(q1), vec3(p2), vec3(q2));
      },
      "p1"_a, "q1"_a, "p2"_a, "q2"_a, "Euclidean distance (m) between segments p1-q1 and p2-q2.");
  m.def(
      "point_segment_distance",
      [](const Point& c, const Point& a, const Point& b) {
        return robot::point_segment_distance(vec3(c), vec3(a), vec3(b));
      },
      "c"_a, "a"_a, "b"_a, "Euclidean distance (m) from point c to segment a-b.");
  m.def(
      "segment_obstacle_distance",
      [](const ObstacleArrays& obstacles, std::int64_t i, const Point& a, const Point& b) {
        return robot::segment_obstacle_distance(obstacles.packed(), obstacles.index(i), vec3(a), vec3(b));
      },
      "obstacles"_a, "i"_a, "a"_a, "b"_a, "min over t in [0, 1] of the signed distance of a + t (b - a) to obstacle i.");
  m.def(
      "segment_obstacle_distances",
      [](const ObstacleArrays& obstacles, const Rows<3>& a, const Rows<3>& b) {
        const std::size_t n = a.shape(0), count = obstacles.count();
        require(b.shape(0) == n, "a, b: expected the same number of segments");
        auto [distances, d] = new_array({n, count});
        auto [ts, t] = new_array({n, count});
        auto [normals, normal] = new_array({n, count, 3});
        {
          nb::gil_scoped_release release;
          for (std::size_t k = 0; k < n; ++k) {
            const Vec3 ak{a.data()[3 * k], a.data()[3 * k + 1], a.data()[3 * k + 2]};
            const Vec3 bk{b.data()[3 * k], b.data()[3 * k + 1], b.data()[3 * k + 2]};
            for (std::size_t i = 0; i < count; ++i) {
              const SegmentDistance s = robot::segment_obstacle_distance(obstacles.packed(), i, ak, bk);
              d[k * count + i] = s.distance;
              t[k * count + i] = s.t;
              double* row = normal + 3 * (k * count + i);
              row[0] = s.normal.x, row[1] = s.normal.y, row[2] = s.normal.z;
            }
          }
        }
        return std::make_tuple(distances, ts, normals);
      },
      "obstacles"_a, "a"_a, "b"_a,
      "segment_obstacle_distance of N segments a-b (N, 3) to every obstacle: (distances (N, M), t (N, M),\n"
      "normals (N, M, 3)).");
  m.def(
      "capsule_level_distance",
      [](const ObstacleArrays& obstacles, std::int64_t i, const Point& a, const Point& b, double radius) {
        return robot::capsule_level_distance(obstacles.packed(), obstacles.index(i), vec3(a), vec3(b), radius);
      },
      "obstacles"_a, "i"_a, "a"_a, "b"_a, "radius"_a,
      "The coarse level: a bounding capsule (world axis a-b, radius) against obstacle i.");

  // a robot.Robot's link model
  m.def(
      "world_segments",
      [](const RobotArrays& robot, const Rotations& rotations, const Rows<3>& origins) {
        const robot::Frames frames = frames_of(robot, rotations, origins);
        Segments world = new_segments(robot);
        robot::capsule_segments(robot.view().links, frames, world.view);
        robot::primitive_segments(robot.view().links, frames, world.view);
        return world;
      },
      "robot"_a, "rotations"_a, "origins"_a, "World ends of every capsule and primitive at the joint frames.");
  m.def(
      "near_segments",
      [](const RobotArrays& robot, const Rotations& rotations, const Rows<3>& origins,
         const ObstacleArrays& obstacles) {
        const robot::Frames frames = frames_of(robot, rotations, origins);
        Segments world = new_segments(robot);
        robot::capsule_segments(robot.view().links, frames, world.view);
        robot::near_segments(robot.view().links, frames, obstacles.set(), world.view);
        return world;
      },
      "robot"_a, "rotations"_a, "origins"_a, "obstacles"_a,
      "World ends of every capsule, and of the primitives of links near an obstacle (the others NaN).");
  m.def(
      "link_obstacle_distance",
      [](const RobotArrays& robot, const Segments& world, const ObstacleArrays& obstacles, std::int64_t l,
         std::int64_t i, double cutoff, double fine_cutoff) {
        check(robot, world);
        return robot::link_obstacle_distance_below(robot.view().links, world.view, obstacles.set(), link(robot, l),
                                                   obstacles.index(i), cutoff, fine_cutoff);
      },
      "robot"_a, "world"_a, "obstacles"_a, "link"_a, "i"_a, "cutoff"_a = kInf, "fine_cutoff"_a = kInf,
      "Signed clearance of a link to obstacle i: exact below fine_cutoff (<= cutoff), else a bound.");
  m.def(
      "fitted_distance_below",
      [](const RobotArrays& robot, const Segments& world, const ObstacleArrays& obstacles, std::int64_t l,
         std::int64_t i, double fine_cutoff) {
        check(robot, world);
        const std::size_t c = link(robot, l), k = obstacles.index(i);
        const robot::LinkModelView& v = robot.view().links;
        return robot::fitted_distance_below(obstacles.packed(), k, obstacles.set().centre(k),
                                            obstacles.set().bounds[k], v, world.view,
                                            static_cast<std::size_t>(v.link_start[c]),
                                            static_cast<std::size_t>(v.link_start[c + 1]), fine_cutoff);
      },
      "robot"_a, "world"_a, "obstacles"_a, "link"_a, "i"_a, "fine_cutoff"_a = kInf,
      "The fine level: the minimum over a link's fitted primitives, exact below fine_cutoff.");
  m.def(
      "link_pair_distance",
      [](const RobotArrays& robot, const Segments& world, std::int64_t l1, std::int64_t l2) {
        check(robot, world);
        return robot::link_pair_distance(robot.view().links, world.view, link(robot, l1), link(robot, l2));
      },
      "robot"_a, "world"_a, "l1"_a, "l2"_a, "Clearance between two links' covering capsules.");
  m.def(
      "fill_clearances",
      [](const RobotArrays& robot, const Segments& world, const ObstacleArrays& obstacles, double cutoff) {
        check(robot, world);
        double *obstacle, *own;
        Clearances out = new_clearances(robot, obstacles, &obstacle, &own);
        {
          nb::gil_scoped_release release;
          robot::fill_clearances(robot.view().links, world.view, obstacles.set(), cutoff, obstacle, own);
        }
        return out;
      },
      "robot"_a, "world"_a, "obstacles"_a, "cutoff"_a = kInf,
      "Clearances from world segments; pairs whose bound is >= cutoff get a bound.");
  m.def(
      "clearances",
      [](const RobotArrays& robot, const Rotations& rotations, const Rows<3>& origins,
         const ObstacleArrays& obstacles) {
        const robot::Frames frames = frames_of(robot, rotations, origins);
        Segments world = new_segments(robot);
        double *obstacle, *own;
        Clearances out = new_clearances(robot, obstacles, &obstacle, &own);
        {
          nb::gil_scoped_release release;
          robot::clearances(robot.view().links, frames, obstacles.set(), world.view, obstacle, own);
        }
        return out;
      },
      "robot"_a, "rotations"_a, "origins"_a, "obstacles"_a, "Exact clearances at the joint frames.");
  m.def(
      "clearances_at",
      [](const RobotArrays& robot, const Vector& q, const ObstacleArrays& obstacles, double cutoff) {
        require(q.shape(0) == robot.joints(), "q: expected one value per joint");
        double *obstacle, *own;
        Clearances out = new_clearances(robot, obstacles, &obstacle, &own);
        {
          nb::gil_scoped_release release;
          robot::clearances_at(robot.view().kinematics, robot.view().links, q.data(), obstacles.set(), obstacle,
                               own, cutoff);
        }
        return out;
      },
      "robot"_a, "q"_a, "obstacles"_a, "cutoff"_a = kInf,
      "Clearances at configuration q (forward kinematics of the robot, then clearances): the link-obstacle pairs\n"
      "exact below cutoff (some value at least cutoff for the others), the self pairs exact.");
  m.def(
      "fitted_self_clearances_at",
      [](const RobotArrays& robot, const Vector& q, double cutoff) {
        require(q.shape(0) == robot.joints(), "q: expected one value per joint");
        auto [out, own] = new_array({robot.pairs()});
        {
          nb::gil_scoped_release release;
          robot::fitted_self_clearances_at(robot.view().kinematics, robot.view().links, q.data(), own, cutoff);
        }
        return out;
      },
      "robot"_a, "q"_a, "cutoff"_a = kInf,
      "Self-pair clearances (pairs,) at configuration q on the fitted primitives "
      "(robot::fitted_pair_distance_below): exact below cutoff, some value at least cutoff for the others.");
  m.def(
      "covering_clearances",
      [](const RobotArrays& robot, const Matrix& qs, const ObstacleArrays& obstacles) {
        require(qs.shape(1) == robot.joints(), "qs: expected (N, n), one value per joint");
        const std::size_t count = qs.shape(0);
        auto [obstacle_out, obstacle] = new_array({count, robot.capsules(), obstacles.count()});
        auto [own_out, own] = new_array({count, robot.pairs()});
        {
          nb::gil_scoped_release release;
          robot::covering_clearances(robot.view().kinematics, robot.view().links, qs.data(), count,
                                     obstacles.packed(), obstacle, own);
        }
        return std::make_tuple(obstacle_out, own_out);
      },
      "robot"_a, "qs"_a, "obstacles"_a,
      "The covering capsules (radii self_r) alone at N configurations qs (N, n): (capsule-obstacle clearances\n"
      "(N, caps, M), self-pair clearances (N, pairs)).");
  m.def(
      "covering_needed",
      [](const RobotArrays& robot, const Matrix& qs, const ObstacleArrays& obstacles, const Matrix& travel,
         const Matrix& weights, const Vector& slack) {
        const std::size_t n = robot.joints(), count = qs.shape(0);
        const std::size_t pairs = robot.capsules() * obstacles.count() + robot.pairs();
        require(qs.shape(1) == n && travel.shape(0) == count && travel.shape(1) == n,
                "qs, travel: expected (N, n), one value per joint");
        require(weights.shape(0) == pairs && weights.shape(1) == n && slack.shape(0) == pairs,
                "weights (P, n), slack (P,): one row per pair (capsule x obstacle, then self pairs)");
        auto [out, needed] = new_array_of<std::uint8_t>({pairs, count});
        {
          nb::gil_scoped_release release;
          robot::covering_needed(robot.view().kinematics, robot.view().links, qs.data(), count,
                                 obstacles.packed(), travel.data(), weights.data(), slack.data(), needed);
        }
        return out;
      },
      "robot"_a, "qs"_a, "obstacles"_a, "travel"_a, "weights"_a, "slack"_a,
      "(P, N) uint8: 1 where the covering capsules (less slack) and their advancement (motion bound weights (P, n)\n"
      "times the accumulated joint travel (N, n)) cannot clear pair p at configuration k of qs (N, n).");
}

}  // namespace pfield::python
