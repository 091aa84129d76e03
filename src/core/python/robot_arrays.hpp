// A robot's RobotArrays (pfield.planning._whole_body_layout: kinematics, link model, limits) at the Python boundary:
// the 24 arrays read in place for the holder's life, every length and index checked once (a ValueError for an
// array that disagrees), and the robot::RobotView over them. Any binding that takes a whole robot can hold one
// (python/assistance.cpp does; python/whole_body.cpp's Robot checks the same things).
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "python/arrays.hpp"
#include "robot/robot.hpp"

namespace pfield::python {

class RobotArrays {
 public:
  using Ints = nb::ndarray<const std::int64_t, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
  using IntMatrix = nb::ndarray<const std::int64_t, nb::ndim<2>, nb::c_contig, nb::device::cpu>;
  using Pairs = nb::ndarray<const std::int64_t, nb::shape<-1, 2>, nb::c_contig, nb::device::cpu>;
  using Rotations = nb::ndarray<const double, nb::shape<-1, 3, 3>, nb::c_contig, nb::device::cpu>;
  using Matrix3 = nb::ndarray<const double, nb::shape<3, 3>, nb::c_contig, nb::device::cpu>;
  using Point = nb::ndarray<const double, nb::shape<3>, nb::c_contig, nb::device::cpu>;

  // RobotArrays' fields in order.
  RobotArrays(const Ints& parents, const Rotations& place_rot, const Rows<3>& place_pos, const Rows<3>& axes,
              const Ints& kinds, const IntMatrix& support, std::int64_t ee_joint, const Matrix3& ee_rot,
              const Point& ee_pos, const Ints& cap_joint, const Rows<3>& cap_a, const Rows<3>& cap_b,
              const Vector& cap_r, const Pairs& self_pairs, const Vector& lower, const Vector& upper,
              const Vector& max_velocity, const Vector& max_acceleration, const Ints& link_start,
              const Ints& prim_joint, const Rows<3>& prim_a, const Rows<3>& prim_b, const Vector& prim_r,
              const Vector& self_r)
      : parents_(parents), place_rot_(place_rot), place_pos_(place_pos), axes_(axes), kinds_(kinds),
        support_(support), ee_rot_(ee_rot), ee_pos_(ee_pos), cap_joint_(cap_joint), cap_a_(cap_a), cap_b_(cap_b),
        cap_r_(cap_r), self_pairs_(self_pairs), lower_(lower), upper_(upper), max_velocity_(max_velocity),
        max_acceleration_(max_acceleration), link_start_(link_start), prim_joint_(prim_joint), prim_a_(prim_a),
        prim_b_(prim_b), prim_r_(prim_r), self_r_(self_r) {
    const std::size_t n = parents.shape(0), caps = cap_joint.shape(0), prims = prim_joint.shape(0);
    require(n > 0, "needs at least one joint");
    require(place_rot.shape(0) == n && place_pos.shape(0) == n && axes.shape(0) == n && kinds.shape(0) == n &&
                support.shape(0) == n && support.shape(1) == n && lower.shape(0) == n && upper.shape(0) == n &&
                max_velocity.shape(0) == n && max_acceleration.shape(0) == n,
            "the kinematic arrays and limits need one entry per joint (support: n x n)");
    for (std::size_t i = 0; i < n; ++i) {
      require(parents.data()[i] >= -1 && parents.data()[i] < static_cast<std::int64_t>(i),
              "parents must list joints in tree order (-1 <= parent < child)");
      require(kinds.data()[i] == 0 || kinds.data()[i] == 1, "kinds must be 0 (revolute) or 1 (prismatic)");
    }
    require(ee_joint >= -1 && ee_joint < static_cast<std::int64_t>(n), "ee_joint out of range");
    require(cap_a.shape(0) == caps && cap_b.shape(0) == caps && cap_r.shape(0) == caps && self_r.shape(0) == caps,
            "cap_a, cap_b (caps, 3), cap_r, self_r (caps,) must match cap_joint");
    require(prim_a.shape(0) == prims && prim_b.shape(0) == prims && prim_r.shape(0) == prims,
            "prim_a, prim_b (prims, 3), prim_r (prims,) must match prim_joint");
    require(joints_within(cap_joint.data(), caps, n) && joints_within(prim_joint.data(), prims, n),
            "a capsule's or primitive's joint is out of range");
    require(link_start.shape(0) == caps + 1, "link_start must have caps + 1 entries");
    const std::int64_t* start = link_start.data();
    require(start[0] >= 0 && start[caps] <= static_cast<std::int64_t>(prims),
            "link_start must lie within the primitives");
    for (std::size_t l = 0; l < caps; ++l) require(start[l] <= start[l + 1], "link_start must not decrease");
    const std::int64_t* pairs = self_pairs.data();
    for (std::size_t k = 0; k < 2 * self_pairs.shape(0); ++k)
      require(pairs[k] >= 0 && pairs[k] < static_cast<std::int64_t>(caps), "self pair out of range");
    view_.kinematics = {n,           parents.data(), place_rot.data(), place_pos.data(), axes.data(), kinds.data(),
                        support.data(), ee_joint,     ee_rot.data(),    ee_pos.data()};
    view_.links = {caps,          cap_joint.data(),    cap_a.data(),     cap_b.data(),   cap_r.data(),
                   self_r.data(), self_pairs.shape(0), pairs,            prims,          link_start.data(),
                   prim_joint.data(), prim_a.data(),   prim_b.data(),    prim_r.data()};
    view_.limits = {lower.data(), upper.data(), max_velocity.data(), max_acceleration.data()};
  }

  const robot::RobotView& view() const { return view_; }
  std::size_t joints() const { return view_.kinematics.joint_count; }

 private:
  static void require(bool condition, const char* message) {
    if (!condition) throw std::invalid_argument(std::string("robot: ") + message);
  }
  static bool joints_within(const std::int64_t* joints, std::size_t count, std::size_t n) {
    return std::all_of(joints, joints + count,
                       [n](std::int64_t j) { return j >= -1 && j < static_cast<std::int64_t>(n); });
  }

  Ints parents_;
  Rotations place_rot_;
  Rows<3> place_pos_, axes_;
  Ints kinds_;
  IntMatrix support_;
  Matrix3 ee_rot_;
  Point ee_pos_;
  Ints cap_joint_;
  Rows<3> cap_a_, cap_b_;
  Vector cap_r_;
  Pairs self_pairs_;
  Vector lower_, upper_, max_velocity_, max_acceleration_;
  Ints link_start_, prim_joint_;
  Rows<3> prim_a_, prim_b_;
  Vector prim_r_, self_r_;
  robot::RobotView view_;
};

}  // namespace pfield::python
