// A robot, its obstacles and its scene at the Python boundary, bound once each (python/robot.cpp registers them in
// pfield._core.robot) and taken by every binding that needs them: the kinematics and IK, the clearances, the
// whole-body planner and stepper, the global search and tracking, the assistance.
//
// * RobotArrays (robot.Robot): pfield.planning._whole_body_layout.RobotArrays' 24 arrays (kinematics, link model,
//   limits) and its self pairs' tables (robot.PairTables, or None), or the kinematics and limits alone (a RobotModel
//   before its link model is fitted), read in place for the object's life, every length and index checked once (a
//   ValueError for an array that disagrees), and the robot::RobotView over them.
// * ObstacleArrays (robot.Obstacles): the packed obstacles (PackedObstacles' eight arrays) and their bounding
//   spheres (centres (M, 3), radii (M,)): robot::ObstacleSet.
// * SceneArrays (robot.Scene): a robot among obstacles with the start offsets of its pairs (<= 0, m; obstacle
//   offsets (caps, M), self offsets (pairs,)): planning::WholeBodyScene. It keeps its robot and obstacles alive.
//
// The C++ names are unique in pfield::python: nanobind tells bound types apart by name, and a class of the same
// name in two binding files' anonymous namespaces would be the same name to it.
#pragma once

#include <cstddef>
#include <cstdint>

#include "planning/whole_body.hpp"
#include "python/arrays.hpp"
#include "python/packed.hpp"
#include "robot/clearance.hpp"
#include "robot/robot.hpp"

namespace pfield::python {

class RobotArrays {
 public:
  // RobotArrays' fields in order.
  RobotArrays(const Ints& parents, const Rotations& place_rot, const Rows<3>& place_pos, const Rows<3>& axes,
              const Ints& kinds, const IntMatrix& support, std::int64_t ee_joint, const Matrix3& ee_rot,
              const Point& ee_pos, const Ints& cap_joint, const Rows<3>& cap_a, const Rows<3>& cap_b,
              const Vector& cap_r, const Pairs& self_pairs, const Vector& lower, const Vector& upper,
              const Vector& max_velocity, const Vector& max_acceleration, const Ints& link_start,
              const Ints& prim_joint, const Rows<3>& prim_a, const Rows<3>& prim_b, const Vector& prim_r,
              const Vector& self_r, nb::handle pair_tables = nb::none());
  // The kinematics (a RobotModel's KinematicArrays, in order) and the limits, without a link model.
  RobotArrays(const Ints& parents, const Rotations& place_rot, const Rows<3>& place_pos, const Rows<3>& axes,
              const Ints& kinds, const IntMatrix& support, std::int64_t ee_joint, const Matrix3& ee_rot,
              const Point& ee_pos, const Vector& lower, const Vector& upper, const Vector& max_velocity,
              const Vector& max_acceleration);
  RobotArrays(const RobotArrays&) = delete;
  RobotArrays& operator=(const RobotArrays&) = delete;

  const robot::RobotView& view() const { return view_; }
  std::size_t joints() const { return view_.kinematics.joint_count; }
  std::size_t capsules() const { return view_.links.capsule_count; }
  std::size_t pairs() const { return view_.links.pair_count; }
  std::size_t primitives() const { return view_.links.primitive_count; }

 private:
  // The view carries `tables` (a robot.PairTables made from this robot's arrays, else a ValueError), kept alive
  // with this object.
  void use_pair_tables(nb::handle tables);
  void bind_kinematics(std::int64_t ee_joint);
  void bind_links();

  Ints parents_;
  Rotations place_rot_;
  Rows<3> place_pos_, axes_;
  Ints kinds_;
  IntMatrix support_;
  Matrix3 ee_rot_;
  Point ee_pos_;
  Vector lower_, upper_, max_velocity_, max_acceleration_;
  // the link model (empty handles without one)
  Ints cap_joint_;
  Rows<3> cap_a_, cap_b_;
  Vector cap_r_, self_r_;
  Pairs self_pairs_;
  Ints link_start_, prim_joint_;
  Rows<3> prim_a_, prim_b_;
  Vector prim_r_;
  nb::object pair_tables_;  // the robot::PairTables view_ points to, or None
  robot::RobotView view_;
};

class ObstacleArrays {
 public:
  ObstacleArrays(const Kinds& kinds, const Rows<16>& rows, const Triangles& triangles,
                 const PseudoNormals& pseudo_normals, const Rows<3>& bvh_lower, const Rows<3>& bvh_upper,
                 const Nodes& bvh_nodes, const MeshTable& mesh_table, const Rows<3>& centres, const Vector& bounds);
  ObstacleArrays(const ObstacleArrays&) = delete;  // set_ points into this object
  ObstacleArrays& operator=(const ObstacleArrays&) = delete;

  const robot::ObstacleSet& set() const { return set_; }
  const geometry::PackedView& packed() const { return packed_.view(); }
  std::size_t count() const { return packed_.count(); }
  // i as an obstacle index, refused when out of range.
  std::size_t index(std::int64_t i) const;

 private:
  PackedArrays packed_;
  Rows<3> centres_;
  Vector bounds_;
  robot::ObstacleSet set_;
};

class SceneArrays {
 public:
  SceneArrays(nb::handle_t<RobotArrays> robot, nb::handle_t<ObstacleArrays> obstacles, const Matrix& obstacle_offsets,
              const Vector& self_offsets, bool fitted_self = false);

  const planning::WholeBodyScene& view() const { return view_; }
  const RobotArrays& robot() const { return *robot_; }
  const ObstacleArrays& obstacles() const { return *obstacles_; }
  const nb::object& robot_object() const { return robot_.object(); }
  const nb::object& obstacles_object() const { return obstacles_.object(); }

 private:
  Held<RobotArrays> robot_;
  Held<ObstacleArrays> obstacles_;
  Matrix obstacle_offsets_;
  Vector self_offsets_;
  planning::WholeBodyScene view_;
};

// ---- the whole-body inputs and outputs every consumer of a Scene takes (whole_body, rrt, assistance)

// _whole_body_layout.PARAMS's vector as the struct (copied); a ValueError unless it has its 20 numbers.
planning::WholeBodyParams whole_body_params(const Vector& params);

// The goal pose: position (3,), unit quaternion (4,) (x, y, z, w).
planning::Goal goal_pose(const Point& position, const Quaternion& orientation);

// A plan's or a tracking's outputs (max_iterations + 1 rows each; joints and velocities n columns), checked, as
// the core's path.
planning::WholeBodyPath path_outputs(std::int64_t max_iterations, std::size_t n, OutMatrix& joints,
                                     OutMatrix& velocities, OutRows<3>& positions, OutRows<4>& orientations,
                                     OutRows<6>& twists, OutVector& clearances);

// How a plan or a tracking ended (bound once, as pfield._core.whole_body.PlanResult).
struct PathOutcome {
  std::int64_t status;  // the PlanStatus value
  std::int64_t count;   // waypoints recorded, the start included
  planning::StepResult last;

  explicit PathOutcome(const planning::WholeBodyPlanResult& result)
      : status(static_cast<std::int64_t>(result.status)), count(result.count), last(result.last) {}
};

}  // namespace pfield::python
