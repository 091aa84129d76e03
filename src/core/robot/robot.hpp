// A robot as the core reads it: its kinematic tree, its link model (bounding capsules and the fitted primitives
// inside each) and its limits, viewed in place over the arrays pfield.planning.whole_body packs
// (pfield.planning._whole_body_layout.RobotArrays documents each array; this struct and that docstring describe
// the same data). Every concept under src/core/robot and src/core/planning that needs a robot takes this view.
//
// Joint frames at a configuration (Frames) are the one intermediate the kinematics hands the distances: rotation
// i is row-major 3x3, origin i a world point; a "joint" index of -1 is the fixed base (identity frame).
#pragma once

#include <cstddef>
#include <cstdint>

#include "math/vec3.hpp"

namespace pfield::robot {

using math::Vec3;

enum class JointKind : std::int64_t { Revolute = 0, Prismatic = 1 };

// The tree: joints in tree order (parent < child), 1 DoF each.
struct KinematicsView {
  std::size_t joint_count = 0;             // n
  const std::int64_t* parents = nullptr;   // (n,) parent joint, -1 for the base
  const double* place_rot = nullptr;       // (n, 3, 3) joint frame in its parent's at q = 0
  const double* place_pos = nullptr;       // (n, 3)
  const double* axes = nullptr;            // (n, 3) unit axis in the joint's own frame
  const std::int64_t* kinds = nullptr;     // (n,) JointKind
  const std::int64_t* support = nullptr;   // (n, n) support[k * n + j] = 1 when joint j moves joint k
  std::int64_t ee_joint = -1;              // the end effector's parent joint (-1: the base)
  const double* ee_rot = nullptr;          // (3, 3) end-effector frame in that joint's frame
  const double* ee_pos = nullptr;          // (3,)

  JointKind kind(std::size_t i) const { return static_cast<JointKind>(kinds[i]); }
  bool supports(std::int64_t k, std::size_t j) const { return support[k * joint_count + j] != 0; }
};

// The link model: link l's bounding capsule and the fitted primitives it contains
// (prim_* rows link_start[l] .. link_start[l + 1]), capsules as segments a-b (in their joint's frame) and radius.
struct LinkModelView {
  std::size_t capsule_count = 0;           // caps (= links)
  const std::int64_t* cap_joint = nullptr; // (caps,)
  const double* cap_a = nullptr;           // (caps, 3)
  const double* cap_b = nullptr;           // (caps, 3)
  const double* cap_r = nullptr;           // (caps,) grown bounding radii
  const double* self_r = nullptr;          // (caps,) ungrown covering radii, for self pairs
  std::size_t pair_count = 0;              // self pairs
  const std::int64_t* self_pairs = nullptr;  // (pairs, 2) link indices
  std::size_t primitive_count = 0;         // prims
  const std::int64_t* link_start = nullptr;  // (caps + 1,)
  const std::int64_t* prim_joint = nullptr;  // (prims,)
  const double* prim_a = nullptr;          // (prims, 3)
  const double* prim_b = nullptr;          // (prims, 3)
  const double* prim_r = nullptr;          // (prims,)
};

struct JointLimitsView {
  const double* lower = nullptr;           // (n,) rad or m
  const double* upper = nullptr;           // (n,)
  const double* max_velocity = nullptr;    // (n,)
  const double* max_acceleration = nullptr;  // (n,)
};

class PairTables;  // robot/pair_tables.hpp

struct RobotView {
  KinematicsView kinematics;
  LinkModelView links;
  JointLimitsView limits;
  // The self pairs tabulated over the joints between their links (null: none), made from this robot: the global
  // search's state check asks them first (planning/rrt.cpp).
  const PairTables* pair_tables = nullptr;
};

// World frames of every joint at one configuration; the caller owns the storage (n * 9 and n * 3 doubles).
struct Frames {
  double* rotations = nullptr;  // (n, 3, 3) row-major
  double* origins = nullptr;    // (n, 3)

  const double* rotation(std::int64_t joint) const { return rotations + 9 * joint; }
  Vec3 origin(std::int64_t joint) const { return {origins[3 * joint], origins[3 * joint + 1], origins[3 * joint + 2]}; }
};

}  // namespace pfield::robot
