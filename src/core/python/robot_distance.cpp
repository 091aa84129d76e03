// Bindings of the link distances (pfield.robot's closest points and clearances): a thin list of defs over
// robot/distance.hpp and robot/clearance.hpp. Two classes hold their arrays once, validated: Obstacles (the packed
// set, PackedObstacles' eight arrays in field order, and the bounding spheres) and LinkModel (the robot's bounding
// capsules, fitted primitives and self pairs, pfield.planning._whole_body_layout.RobotArrays' link arrays). No
// arithmetic here (this file is compiled with the default contraction): the core computes.
#include <nanobind/nanobind.h>
#include <nanobind/stl/tuple.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <tuple>

#include "geometry/packed.hpp"
#include "python/arrays.hpp"
#include "python/packed.hpp"
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

using Point = nb::ndarray<const double, nb::shape<3>, nb::c_contig, nb::device::cpu>;
using Ints = nb::ndarray<const std::int64_t, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
using Pairs = nb::ndarray<const std::int64_t, nb::shape<-1, 2>, nb::c_contig, nb::device::cpu>;
using Rotations = nb::ndarray<const double, nb::shape<-1, 3, 3>, nb::c_contig, nb::device::cpu>;

constexpr double kInf = std::numeric_limits<double>::infinity();

Vec3 vec3(const Point& p) { return {p.data()[0], p.data()[1], p.data()[2]}; }
std::tuple<double, double, double> tuple3(const Vec3& v) { return {v.x, v.y, v.z}; }

void require(bool condition, const std::string& message) {
  if (!condition) throw std::invalid_argument(message);
}

// The packed obstacles and their bounding spheres (pfield.planning.whole_body.obstacle_bounds), held and viewed.
class Obstacles {
 public:
  Obstacles(const Kinds& kinds, const Rows<16>& rows, const Triangles& triangles, const PseudoNormals& pseudo_normals,
            const Rows<3>& bvh_lower, const Rows<3>& bvh_upper, const Nodes& bvh_nodes, const MeshTable& mesh_table,
            const Rows<3>& centres, const Vector& bounds)
      : kinds_(kinds), rows_(rows), triangles_(triangles), pseudo_normals_(pseudo_normals), bvh_lower_(bvh_lower),
        bvh_upper_(bvh_upper), bvh_nodes_(bvh_nodes), mesh_table_(mesh_table), centres_(centres), bounds_(bounds),
        packed_(packed_view(kinds, rows, triangles, pseudo_normals, bvh_lower, bvh_upper, bvh_nodes, mesh_table)) {
    require(centres.shape(0) == kinds.shape(0) && bounds.shape(0) == kinds.shape(0),
            "obstacles: centres (M, 3) and bounds (M,) must have one row per obstacle");
    set_ = {&packed_, centres.data(), bounds.data()};
  }

  const robot::ObstacleSet& set() const { return set_; }
  std::size_t count() const { return packed_.obstacle_count; }
  const geometry::PackedView& packed() const { return packed_; }

  std::size_t index(std::int64_t i) const {
    require(i >= 0 && static_cast<std::size_t>(i) < count(), "obstacle: index out of range");
    return static_cast<std::size_t>(i);
  }

 private:
  Kinds kinds_;
  Rows<16> rows_;
  Triangles triangles_;
  PseudoNormals pseudo_normals_;
  Rows<3> bvh_lower_, bvh_upper_;
  Nodes bvh_nodes_;
  MeshTable mesh_table_;
  Rows<3> centres_;
  Vector bounds_;
  geometry::PackedView packed_;
  robot::ObstacleSet set_;
};

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

// Joint frames at one configuration, read in place (Frames' pointers are not const; nothing here writes them).
struct FrameArrays {
  robot::Frames frames;
  std::size_t joint_count;
};

FrameArrays frame_arrays(const Rotations& rotations, const Rows<3>& origins) {
  require(origins.shape(0) == rotations.shape(0), "frames: rotations (n, 3, 3) and origins (n, 3) differ in length");
  return {{const_cast<double*>(rotations.data()), const_cast<double*>(origins.data())}, rotations.shape(0)};
}

// The link model (bounding capsules, fitted primitives, self pairs), held and viewed; every index checked once.
class LinkModel {
 public:
  LinkModel(const Ints& cap_joint, const Rows<3>& cap_a, const Rows<3>& cap_b, const Vector& cap_r,
            const Vector& self_r, const Pairs& self_pairs, const Ints& link_start, const Ints& prim_joint,
            const Rows<3>& prim_a, const Rows<3>& prim_b, const Vector& prim_r)
      : cap_joint_(cap_joint), cap_a_(cap_a), cap_b_(cap_b), cap_r_(cap_r), self_r_(self_r), self_pairs_(self_pairs),
        link_start_(link_start), prim_joint_(prim_joint), prim_a_(prim_a), prim_b_(prim_b), prim_r_(prim_r) {
    const std::size_t caps = cap_joint.shape(0), prims = prim_joint.shape(0);
    require(cap_a.shape(0) == caps && cap_b.shape(0) == caps && cap_r.shape(0) == caps && self_r.shape(0) == caps,
            "link model: cap_a, cap_b (caps, 3), cap_r, self_r (caps,) must match cap_joint");
    require(prim_a.shape(0) == prims && prim_b.shape(0) == prims && prim_r.shape(0) == prims,
            "link model: prim_a, prim_b (prims, 3), prim_r (prims,) must match prim_joint");
    require(link_start.shape(0) == caps + 1, "link model: link_start must have caps + 1 entries");
    const std::int64_t* start = link_start.data();
    require(start[0] >= 0 && start[caps] <= static_cast<std::int64_t>(prims),
            "link model: link_start must lie within the primitives");
    for (std::size_t l = 0; l < caps; ++l) require(start[l] <= start[l + 1], "link model: link_start must not decrease");
    const std::int64_t* pairs = self_pairs.data();
    for (std::size_t k = 0; k < 2 * self_pairs.shape(0); ++k)
      require(pairs[k] >= 0 && pairs[k] < static_cast<std::int64_t>(caps), "link model: self pair out of range");
    max_joint_ = -1;
    for (std::size_t c = 0; c < caps; ++c) {
      require(cap_joint.data()[c] >= -1, "link model: cap_joint below -1");
      max_joint_ = std::max(max_joint_, cap_joint.data()[c]);
    }
    for (std::size_t p = 0; p < prims; ++p) {
      require(prim_joint.data()[p] >= -1, "link model: prim_joint below -1");
      max_joint_ = std::max(max_joint_, prim_joint.data()[p]);
    }
    view_ = {caps,         cap_joint.data(), cap_a.data(),  cap_b.data(),      cap_r.data(),
             self_r.data(), self_pairs.shape(0), pairs,     prims,             link_start.data(),
             prim_joint.data(), prim_a.data(),  prim_b.data(), prim_r.data()};
  }

  const robot::LinkModelView& view() const { return view_; }

  // The frames must cover every joint the model names.
  void check_joints(std::size_t joint_count) const {
    require(max_joint_ < static_cast<std::int64_t>(joint_count), "link model: a segment's joint has no frame");
  }

  void check(const Segments& world) const {
    require(world.cap_a.shape(0) == view_.capsule_count && world.prim_a.shape(0) == view_.primitive_count,
            "segments: not this link model's");
  }

  std::size_t link(std::int64_t l) const {
    require(l >= 0 && static_cast<std::size_t>(l) < view_.capsule_count, "link: index out of range");
    return static_cast<std::size_t>(l);
  }

  Segments new_segments() const { return Segments(view_.capsule_count, view_.primitive_count); }

  Clearances new_clearances(std::size_t obstacles, double** obstacle, double** own) const {
    Clearances out;
    std::tie(out.obstacle, *obstacle) = new_array({view_.capsule_count, obstacles});
    std::tie(out.own, *own) = new_array({view_.pair_count});
    return out;
  }

 private:
  Ints cap_joint_;
  Rows<3> cap_a_, cap_b_;
  Vector cap_r_, self_r_;
  Pairs self_pairs_;
  Ints link_start_, prim_joint_;
  Rows<3> prim_a_, prim_b_;
  Vector prim_r_;
  std::int64_t max_joint_ = -1;
  robot::LinkModelView view_;
};

// The kinematic tree of a configuration q, read in place, checked (tree order: parents[i] < i).
robot::KinematicsView kinematics_view(const Vector& q, const Ints& parents, const Rotations& place_rot,
                                      const Rows<3>& place_pos, const Rows<3>& axes, const Ints& kinds) {
  const std::size_t n = parents.shape(0);
  require(q.shape(0) == n && place_rot.shape(0) == n && place_pos.shape(0) == n && axes.shape(0) == n &&
              kinds.shape(0) == n,
          "kinematics: q, parents, place_rot, place_pos, axes and kinds must have one entry per joint");
  for (std::size_t i = 0; i < n; ++i)
    require(parents.data()[i] >= -1 && parents.data()[i] < static_cast<std::int64_t>(i),
            "kinematics: parents must be in tree order (-1 <= parents[i] < i)");
  robot::KinematicsView view;
  view.joint_count = n;
  view.parents = parents.data();
  view.place_rot = place_rot.data();
  view.place_pos = place_pos.data();
  view.axes = axes.data();
  view.kinds = kinds.data();
  return view;
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

  nb::class_<Obstacles>(m, "Obstacles", "Packed obstacles (PackedObstacles' eight arrays) and bounding spheres.")
      .def(nb::init<const Kinds&, const Rows<16>&, const Triangles&, const PseudoNormals&, const Rows<3>&,
                    const Rows<3>&, const Nodes&, const MeshTable&, const Rows<3>&, const Vector&>(),
           "kinds"_a, "rows"_a, "triangles"_a, "pseudo_normals"_a, "bvh_lower"_a, "bvh_upper"_a, "bvh_nodes"_a,
           "mesh_table"_a, "centres"_a, "bounds"_a)
      .def_prop_ro("count", &Obstacles::count);

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
      [](const Obstacles& obstacles, std::int64_t i, const Point& a, const Point& b) {
        return robot::segment_obstacle_distance(obstacles.packed(), obstacles.index(i), vec3(a), vec3(b));
      },
      "obstacles"_a, "i"_a, "a"_a, "b"_a, "min over t in [0, 1] of the signed distance of a + t (b - a) to obstacle i.");
  m.def(
      "segment_obstacle_distances",
      [](const Obstacles& obstacles, const Rows<3>& a, const Rows<3>& b) {
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
      [](const Obstacles& obstacles, std::int64_t i, const Point& a, const Point& b, double radius) {
        return robot::capsule_level_distance(obstacles.packed(), obstacles.index(i), vec3(a), vec3(b), radius);
      },
      "obstacles"_a, "i"_a, "a"_a, "b"_a, "radius"_a,
      "The coarse level: a bounding capsule (world axis a-b, radius) against obstacle i.");

  nb::class_<LinkModel>(m, "LinkModel", "A robot's link model: bounding capsules, fitted primitives, self pairs.")
      .def(nb::init<const Ints&, const Rows<3>&, const Rows<3>&, const Vector&, const Vector&, const Pairs&,
                    const Ints&, const Ints&, const Rows<3>&, const Rows<3>&, const Vector&>(),
           "cap_joint"_a, "cap_a"_a, "cap_b"_a, "cap_r"_a, "self_r"_a, "self_pairs"_a, "link_start"_a,
           "prim_joint"_a, "prim_a"_a, "prim_b"_a, "prim_r"_a)
      .def(
          "world_segments",
          [](const LinkModel& model, const Rotations& rotations, const Rows<3>& origins) {
            const FrameArrays f = frame_arrays(rotations, origins);
            model.check_joints(f.joint_count);
            Segments world = model.new_segments();
            robot::capsule_segments(model.view(), f.frames, world.view);
            robot::primitive_segments(model.view(), f.frames, world.view);
            return world;
          },
          "rotations"_a, "origins"_a, "World ends of every capsule and primitive at the joint frames.")
      .def(
          "near_segments",
          [](const LinkModel& model, const Rotations& rotations, const Rows<3>& origins, const Obstacles& obstacles) {
            const FrameArrays f = frame_arrays(rotations, origins);
            model.check_joints(f.joint_count);
            Segments world = model.new_segments();
            robot::capsule_segments(model.view(), f.frames, world.view);
            robot::near_segments(model.view(), f.frames, obstacles.set(), world.view);
            return world;
          },
          "rotations"_a, "origins"_a, "obstacles"_a,
          "World ends of every capsule, and of the primitives of links near an obstacle (the others NaN).")
      .def(
          "link_obstacle_distance",
          [](const LinkModel& model, const Segments& world, const Obstacles& obstacles, std::int64_t link,
             std::int64_t i, double cutoff, double fine_cutoff) {
            model.check(world);
            return robot::link_obstacle_distance_below(model.view(), world.view, obstacles.set(), model.link(link),
                                                       obstacles.index(i), cutoff, fine_cutoff);
          },
          "world"_a, "obstacles"_a, "link"_a, "i"_a, "cutoff"_a = kInf, "fine_cutoff"_a = kInf,
          "Signed clearance of a link to obstacle i: exact below fine_cutoff (<= cutoff), else a bound.")
      .def(
          "fitted_distance_below",
          [](const LinkModel& model, const Segments& world, const Obstacles& obstacles, std::int64_t link,
             std::int64_t i, double fine_cutoff) {
            model.check(world);
            const std::size_t l = model.link(link), k = obstacles.index(i);
            const robot::LinkModelView& v = model.view();
            return robot::fitted_distance_below(obstacles.packed(), k, obstacles.set().centre(k),
                                                obstacles.set().bounds[k], v, world.view,
                                                static_cast<std::size_t>(v.link_start[l]),
                                                static_cast<std::size_t>(v.link_start[l + 1]), fine_cutoff);
          },
          "world"_a, "obstacles"_a, "link"_a, "i"_a, "fine_cutoff"_a = kInf,
          "The fine level: the minimum over a link's fitted primitives, exact below fine_cutoff.")
      .def(
          "link_pair_distance",
          [](const LinkModel& model, const Segments& world, std::int64_t l1, std::int64_t l2) {
            model.check(world);
            return robot::link_pair_distance(model.view(), world.view, model.link(l1), model.link(l2));
          },
          "world"_a, "l1"_a, "l2"_a, "Clearance between two links' covering capsules.")
      .def(
          "fill_clearances",
          [](const LinkModel& model, const Segments& world, const Obstacles& obstacles, double cutoff) {
            model.check(world);
            double *obstacle, *own;
            Clearances out = model.new_clearances(obstacles.count(), &obstacle, &own);
            {
              nb::gil_scoped_release release;
              robot::fill_clearances(model.view(), world.view, obstacles.set(), cutoff, obstacle, own);
            }
            return out;
          },
          "world"_a, "obstacles"_a, "cutoff"_a = kInf,
          "Clearances from world segments; pairs whose bound is >= cutoff get a bound.")
      .def(
          "clearances",
          [](const LinkModel& model, const Rotations& rotations, const Rows<3>& origins, const Obstacles& obstacles) {
            const FrameArrays f = frame_arrays(rotations, origins);
            model.check_joints(f.joint_count);
            Segments world = model.new_segments();
            double *obstacle, *own;
            Clearances out = model.new_clearances(obstacles.count(), &obstacle, &own);
            {
              nb::gil_scoped_release release;
              robot::clearances(model.view(), f.frames, obstacles.set(), world.view, obstacle, own);
            }
            return out;
          },
          "rotations"_a, "origins"_a, "obstacles"_a, "Exact clearances at the joint frames.")
      .def(
          "clearances_at",
          [](const LinkModel& model, const Vector& q, const Ints& parents, const Rotations& place_rot,
             const Rows<3>& place_pos, const Rows<3>& axes, const Ints& kinds, const Obstacles& obstacles) {
            const robot::KinematicsView kinematics = kinematics_view(q, parents, place_rot, place_pos, axes, kinds);
            model.check_joints(kinematics.joint_count);
            double *obstacle, *own;
            Clearances out = model.new_clearances(obstacles.count(), &obstacle, &own);
            {
              nb::gil_scoped_release release;
              robot::clearances_at(kinematics, model.view(), q.data(), obstacles.set(), obstacle, own);
            }
            return out;
          },
          "q"_a, "parents"_a, "place_rot"_a, "place_pos"_a, "axes"_a, "kinds"_a, "obstacles"_a,
          "Exact clearances at configuration q (forward kinematics of the tree, then clearances).");
}

}  // namespace pfield::python
