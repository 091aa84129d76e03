// The robot, its obstacles and its scene (python/robot_arrays.hpp), registered once as pfield._core.robot's Robot,
// Obstacles and Scene; every other submodule takes these types. No arithmetic here: arrays are checked and viewed.
#include <nanobind/nanobind.h>
#include <nanobind/stl/vector.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

#include "python/robot_arrays.hpp"
#include "robot/pair_tables.hpp"

namespace pfield::python {
namespace {

using namespace nb::literals;

void require_robot(bool condition, const char* message) { require(condition, std::string("robot: ") + message); }

bool joints_within(const std::int64_t* joints, std::size_t count, std::size_t n) {
  return std::all_of(joints, joints + count,
                     [n](std::int64_t j) { return j >= -1 && j < static_cast<std::int64_t>(n); });
}

void require_pair(const robot::PairTables& tables, std::size_t pair) {
  require(pair < tables.pair_count(), "pair: expected a self pair's index, 0 to " +
                                          std::to_string(tables.pair_count()) + " (excluded), got " +
                                          std::to_string(pair));
}

// link_start of a robot without a link model: its one entry, 0
constexpr std::int64_t kNoPrimitives[1] = {0};

}  // namespace

RobotArrays::RobotArrays(const Ints& parents, const Rotations& place_rot, const Rows<3>& place_pos,
                         const Rows<3>& axes, const Ints& kinds, const IntMatrix& support, std::int64_t ee_joint,
                         const Matrix3& ee_rot, const Point& ee_pos, const Ints& cap_joint, const Rows<3>& cap_a,
                         const Rows<3>& cap_b, const Vector& cap_r, const Pairs& self_pairs, const Vector& lower,
                         const Vector& upper, const Vector& max_velocity, const Vector& max_acceleration,
                         const Ints& link_start, const Ints& prim_joint, const Rows<3>& prim_a, const Rows<3>& prim_b,
                         const Vector& prim_r, const Vector& self_r, nb::handle pair_tables)
    : parents_(parents), place_rot_(place_rot), place_pos_(place_pos), axes_(axes), kinds_(kinds),
      support_(support), ee_rot_(ee_rot), ee_pos_(ee_pos), lower_(lower), upper_(upper),
      max_velocity_(max_velocity), max_acceleration_(max_acceleration), cap_joint_(cap_joint), cap_a_(cap_a),
      cap_b_(cap_b), cap_r_(cap_r), self_r_(self_r), self_pairs_(self_pairs), link_start_(link_start),
      prim_joint_(prim_joint), prim_a_(prim_a), prim_b_(prim_b), prim_r_(prim_r) {
  bind_kinematics(ee_joint);
  bind_links();
  if (!pair_tables.is_none()) use_pair_tables(pair_tables);
}

RobotArrays::RobotArrays(const Ints& parents, const Rotations& place_rot, const Rows<3>& place_pos,
                         const Rows<3>& axes, const Ints& kinds, const IntMatrix& support, std::int64_t ee_joint,
                         const Matrix3& ee_rot, const Point& ee_pos, const Vector& lower, const Vector& upper,
                         const Vector& max_velocity, const Vector& max_acceleration)
    : parents_(parents), place_rot_(place_rot), place_pos_(place_pos), axes_(axes), kinds_(kinds),
      support_(support), ee_rot_(ee_rot), ee_pos_(ee_pos), lower_(lower), upper_(upper),
      max_velocity_(max_velocity), max_acceleration_(max_acceleration) {
  bind_kinematics(ee_joint);
  view_.links = {};
  view_.links.link_start = kNoPrimitives;
}

void RobotArrays::bind_kinematics(std::int64_t ee_joint) {
  const std::size_t n = parents_.shape(0);
  require_robot(n > 0, "needs at least one joint");
  require_robot(place_rot_.shape(0) == n && place_pos_.shape(0) == n && axes_.shape(0) == n &&
                    kinds_.shape(0) == n && support_.shape(0) == n && support_.shape(1) == n &&
                    lower_.shape(0) == n && upper_.shape(0) == n && max_velocity_.shape(0) == n &&
                    max_acceleration_.shape(0) == n,
                "the kinematic arrays and limits need one entry per joint (support: n x n)");
  for (std::size_t i = 0; i < n; ++i) {
    require_robot(parents_.data()[i] >= -1 && parents_.data()[i] < static_cast<std::int64_t>(i),
                  "parents must list joints in tree order (-1 <= parent < child)");
    require_robot(kinds_.data()[i] == 0 || kinds_.data()[i] == 1, "kinds must be 0 (revolute) or 1 (prismatic)");
  }
  require_robot(ee_joint >= -1 && ee_joint < static_cast<std::int64_t>(n), "ee_joint out of range");
  view_.kinematics = {n,           parents_.data(), place_rot_.data(), place_pos_.data(), axes_.data(),
                      kinds_.data(), support_.data(), ee_joint,         ee_rot_.data(),    ee_pos_.data()};
  view_.limits = {lower_.data(), upper_.data(), max_velocity_.data(), max_acceleration_.data()};
}

void RobotArrays::bind_links() {
  const std::size_t n = joints(), caps = cap_joint_.shape(0), prims = prim_joint_.shape(0);
  require_robot(cap_a_.shape(0) == caps && cap_b_.shape(0) == caps && cap_r_.shape(0) == caps &&
                    self_r_.shape(0) == caps,
                "cap_a, cap_b (caps, 3), cap_r, self_r (caps,) must match cap_joint");
  require_robot(prim_a_.shape(0) == prims && prim_b_.shape(0) == prims && prim_r_.shape(0) == prims,
                "prim_a, prim_b (prims, 3), prim_r (prims,) must match prim_joint");
  require_robot(joints_within(cap_joint_.data(), caps, n) && joints_within(prim_joint_.data(), prims, n),
                "a capsule's or primitive's joint is out of range");
  require_robot(link_start_.shape(0) == caps + 1, "link_start must have caps + 1 entries");
  const std::int64_t* start = link_start_.data();
  require_robot(start[0] >= 0 && start[caps] <= static_cast<std::int64_t>(prims),
                "link_start must lie within the primitives");
  for (std::size_t l = 0; l < caps; ++l) require_robot(start[l] <= start[l + 1], "link_start must not decrease");
  const std::int64_t* pairs = self_pairs_.data();
  for (std::size_t k = 0; k < 2 * self_pairs_.shape(0); ++k)
    require_robot(pairs[k] >= 0 && pairs[k] < static_cast<std::int64_t>(caps), "self pair out of range");
  view_.links = {caps,           cap_joint_.data(),    cap_a_.data(), cap_b_.data(),  cap_r_.data(),
                 self_r_.data(), self_pairs_.shape(0), pairs,         prims,          start,
                 prim_joint_.data(), prim_a_.data(),   prim_b_.data(), prim_r_.data()};
}

void RobotArrays::use_pair_tables(nb::handle tables) {
  require(nb::isinstance<robot::PairTables>(tables),
          "pair_tables: expected a robot.PairTables made from this robot's arrays, or None");
  const auto& made = nb::cast<const robot::PairTables&>(tables);
  require(made.made_from(view_), "pair_tables: made from another robot (its kinematics, link model or limits differ "
                                 "from this one's); make them from this robot");
  pair_tables_ = nb::borrow(tables);
  view_.pair_tables = &made;
}

ObstacleArrays::ObstacleArrays(const Kinds& kinds, const Rows<16>& rows, const Triangles& triangles,
                               const PseudoNormals& pseudo_normals, const Rows<3>& bvh_lower,
                               const Rows<3>& bvh_upper, const Nodes& bvh_nodes, const MeshTable& mesh_table,
                               const Rows<3>& centres, const Vector& bounds)
    : packed_(kinds, rows, triangles, pseudo_normals, bvh_lower, bvh_upper, bvh_nodes, mesh_table),
      centres_(centres), bounds_(bounds) {
  require(centres.shape(0) == count() && bounds.shape(0) == count(),
          "obstacles: centres (M, 3) and bounds (M,) must have one row per obstacle");
  set_ = {&packed_.view(), centres.data(), bounds.data()};
}

std::size_t ObstacleArrays::index(std::int64_t i) const {
  require(i >= 0 && static_cast<std::size_t>(i) < count(), "obstacle: index out of range");
  return static_cast<std::size_t>(i);
}

SceneArrays::SceneArrays(nb::handle_t<RobotArrays> robot, nb::handle_t<ObstacleArrays> obstacles,
                         const Matrix& obstacle_offsets, const Vector& self_offsets, bool fitted_self)
    : robot_(robot), obstacles_(obstacles), obstacle_offsets_(obstacle_offsets), self_offsets_(self_offsets) {
  require(obstacle_offsets.shape(0) == robot_->capsules() && obstacle_offsets.shape(1) == obstacles_->count(),
          "scene: obstacle_offsets must be (caps, M)");
  require(self_offsets.shape(0) == robot_->pairs(), "scene: self_offsets must have one entry per self pair");
  view_ = {obstacles_->set(), obstacle_offsets.data(), self_offsets.data(), fitted_self};
}

planning::WholeBodyParams whole_body_params(const Vector& params) {
  constexpr std::size_t count = sizeof(planning::WholeBodyParams) / sizeof(double);
  static_assert(count == 20, "WholeBodyParams is _whole_body_layout.PARAMS's 20 doubles");
  require(params.shape(0) == count, "params: expected _whole_body_layout.PARAMS's 20 numbers");
  planning::WholeBodyParams p{};
  std::memcpy(&p, params.data(), sizeof p);
  return p;
}

planning::Goal goal_pose(const Point& position, const Quaternion& orientation) {
  const double* g = position.data();
  const double* o = orientation.data();
  return {{g[0], g[1], g[2]}, {o[0], o[1], o[2], o[3]}};
}

planning::WholeBodyPath path_outputs(std::int64_t max_iterations, std::size_t n, OutMatrix& joints,
                                     OutMatrix& velocities, OutRows<3>& positions, OutRows<4>& orientations,
                                     OutRows<6>& twists, OutVector& clearances) {
  require(max_iterations >= 0, "max_iterations: expected >= 0");
  const auto rows = static_cast<std::size_t>(max_iterations) + 1;
  require(joints.shape(0) >= rows && joints.shape(1) == n && velocities.shape(0) >= rows &&
              velocities.shape(1) == n && positions.shape(0) >= rows && orientations.shape(0) >= rows &&
              twists.shape(0) >= rows && clearances.shape(0) >= rows,
          "the outputs need max_iterations + 1 rows (joints, velocities: n columns)");
  return {joints.data(), velocities.data(), positions.data(), orientations.data(), twists.data(), clearances.data()};
}

void bind_robot(nb::module_& m) {
  m.doc() = "A robot, its obstacles and its scene, bound once and taken by every other submodule (kinematics, "
            "clearances, the whole body, the global search, the assistance).";
  nb::class_<RobotArrays>(m, "Robot", "A robot's arrays (pfield.planning._whole_body_layout.RobotArrays), read "
                                      "in place for the object's life.")
      .def(nb::init<const Ints&, const Rotations&, const Rows<3>&, const Rows<3>&, const Ints&, const IntMatrix&,
                    std::int64_t, const Matrix3&, const Point&, const Ints&, const Rows<3>&, const Rows<3>&,
                    const Vector&, const Pairs&, const Vector&, const Vector&, const Vector&, const Vector&,
                    const Ints&, const Ints&, const Rows<3>&, const Rows<3>&, const Vector&, const Vector&,
                    nb::handle>(),
           "parents"_a, "place_rot"_a, "place_pos"_a, "axes"_a, "kinds"_a, "support"_a, "ee_joint"_a, "ee_rot"_a,
           "ee_pos"_a, "cap_joint"_a, "cap_a"_a, "cap_b"_a, "cap_r"_a, "self_pairs"_a, "lower"_a, "upper"_a,
           "max_velocity"_a, "max_acceleration"_a, "link_start"_a, "prim_joint"_a, "prim_a"_a, "prim_b"_a,
           "prim_r"_a, "self_r"_a, "pair_tables"_a = nb::none(),
           "RobotArrays' fields in order (Robot(*arrays)); pair_tables: a PairTables made from these arrays, which "
           "the global search's state checks ask first, or None.")
      .def(nb::init<const Ints&, const Rotations&, const Rows<3>&, const Rows<3>&, const Ints&, const IntMatrix&,
                    std::int64_t, const Matrix3&, const Point&, const Vector&, const Vector&, const Vector&,
                    const Vector&>(),
           "parents"_a, "place_rot"_a, "place_pos"_a, "axes"_a, "kinds"_a, "support"_a, "ee_joint"_a, "ee_rot"_a,
           "ee_pos"_a, "lower"_a, "upper"_a, "max_velocity"_a, "max_acceleration"_a,
           "A robot without a link model: a RobotModel's KinematicArrays (in order) and its joint limits.")
      .def_prop_ro("joint_count", &RobotArrays::joints)
      .def_prop_ro("capsule_count", &RobotArrays::capsules, "links of the link model (0 without one)")
      .def_prop_ro("pair_count", &RobotArrays::pairs, "self pairs")
      .def_prop_ro("primitive_count", &RobotArrays::primitives, "fitted primitives");
  nb::enum_<robot::PairVerdict>(m, "PairVerdict", "What a self pair's table says (robot/pair_tables.hpp).")
      .value("Unknown", robot::PairVerdict::Unknown, "not decided: the primitives decide")
      .value("Clear", robot::PairVerdict::Clear, "the pair's fitted distance is at least the need")
      .value("Below", robot::PairVerdict::Below, "the pair's fitted distance is below the need");
  nb::class_<robot::TableAxis>(m, "TableAxis", "One tabulated joint of a self pair.")
      .def_ro("joint", &robot::TableAxis::joint)
      .def_ro("origin", &robot::TableAxis::origin, "the first cell's lower edge (rad or m)")
      .def_ro("width", &robot::TableAxis::width, "one cell (rad or m)")
      .def_ro("cells", &robot::TableAxis::cells)
      .def_ro("turns", &robot::TableAxis::turns, "tabulated over one turn")
      .def_ro("weight", &robot::TableAxis::weight, "w_pj (m/rad or m/m)");
  nb::class_<robot::PairTables>(m, "PairTables", "The self pairs that move apart by one or two joints, their fitted "
                                                 "distances tabulated over those joints (robot/pair_tables.hpp).")
      .def(
          "__init__",
          [](robot::PairTables* self, const RobotArrays& robot, const Matrix& weights) {
            require(weights.shape(0) == robot.pairs() && weights.shape(1) == robot.joints(),
                    "weights: expected shape (self pairs, joints) = (" + std::to_string(robot.pairs()) + ", " +
                        std::to_string(robot.joints()) + "), got (" + std::to_string(weights.shape(0)) + ", " +
                        std::to_string(weights.shape(1)) + ")");
            new (self) robot::PairTables(robot.view(), weights.data());
          },
          "robot"_a, "weights"_a,
          "PairTables(robot, weights): weights (pairs, n) w_pj, m/rad or m/m "
          "(pfield.robot.collision.self_pair_weights of the fitted primitives).")
      .def_prop_ro("pair_count", &robot::PairTables::pair_count)
      .def("axes", [](const robot::PairTables& t, std::size_t pair) {
            require_pair(t, pair);
            return t.axes(pair);
          }, "pair"_a, "The pair's tabulated joints (empty: no table).", nb::rv_policy::copy)
      .def("filled", [](const robot::PairTables& t, std::size_t pair) {
            require_pair(t, pair);
            return t.filled(pair);
          }, "pair"_a, "Cells of the pair's table filled so far.")
      .def("verdict", [](const robot::PairTables& t, std::size_t pair, const Vector& q, double need) {
            require_pair(t, pair);
            require(q.shape(0) == t.joint_count(), "q: expected one value per joint");
            return t.verdict(pair, q.data(), need);
          }, "pair"_a, "q"_a, "need"_a,
          "What the pair's table says of `fitted distance at q >= need` (Unknown without a table).");
  nb::class_<ObstacleArrays>(m, "Obstacles", "Packed obstacles (PackedObstacles' eight arrays) and their bounding "
                                             "spheres, read in place.")
      .def(nb::init<const Kinds&, const Rows<16>&, const Triangles&, const PseudoNormals&, const Rows<3>&,
                    const Rows<3>&, const Nodes&, const MeshTable&, const Rows<3>&, const Vector&>(),
           "kinds"_a, "rows"_a, "triangles"_a, "pseudo_normals"_a, "bvh_lower"_a, "bvh_upper"_a, "bvh_nodes"_a,
           "mesh_table"_a, "centres"_a, "bounds"_a,
           "Obstacles(*packed, centres, bounds): bounding spheres (M, 3) and (M,) (inf: never culled).")
      .def_prop_ro("count", &ObstacleArrays::count);
  nb::class_<SceneArrays>(m, "Scene", "A robot among obstacles with its pairs' start offsets (<= 0, m), read in "
                                      "place; keeps the robot and the obstacles alive.")
      .def(nb::init<nb::handle_t<RobotArrays>, nb::handle_t<ObstacleArrays>, const Matrix&, const Vector&, bool>(),
           "robot"_a, "obstacles"_a, "obstacle_offsets"_a, "self_offsets"_a, "fitted_self"_a = false,
           "Scene(robot, obstacles, obstacle_offsets (caps, M), self_offsets (pairs,), fitted_self): fitted_self "
           "puts the self pairs on the fitted primitives instead of the covering capsules (planning::WholeBodyScene).")
      .def_prop_ro("fitted_self", [](const SceneArrays& s) { return s.view().fitted_self; })
      .def_prop_ro("robot", [](const SceneArrays& s) { return s.robot_object(); })
      .def_prop_ro("obstacles", [](const SceneArrays& s) { return s.obstacles_object(); });
}

}  // namespace pfield::python
