// Bindings of the output contract (pfield.safety): a thin list of defs over safety/limits.hpp. Commands are
// writable C-contiguous float64 arrays, limited in place; the outcome comes back as its value (0 within,
// 1 scaled, 2 halted).
#include <nanobind/nanobind.h>

#include <cstddef>
#include <stdexcept>

#include "python/arrays.hpp"
#include "safety/limits.hpp"

namespace pfield::python {
namespace {

using namespace nb::literals;

using Twist6 = nb::ndarray<const double, nb::shape<6>, nb::c_contig, nb::device::cpu>;
using OutTwist6 = nb::ndarray<double, nb::shape<6>, nb::c_contig, nb::device::cpu>;
using OutTwists = nb::ndarray<double, nb::shape<-1, 6>, nb::c_contig, nb::device::cpu>;

}  // namespace

void bind_safety(nb::module_& m) {
  m.doc() = "The output contract: commands finite and within their velocity limits (pfield.safety's core).";
  m.def("part_scale", &safety::part_scale, "x"_a, "y"_a, "z"_a, "limit"_a,
        "The largest s <= 1 with s |(x, y, z)| <= limit (finite components; no overflow).");
  m.def(
      "twist_scale",
      [](const Twist6& v, double max_linear, double max_angular) {
        return safety::twist_scale(v.data(), max_linear, max_angular);
      },
      "values"_a, "max_linear"_a, "max_angular"_a, "The factor in [0, 1] that brings a twist within; NaN if not finite.");
  m.def(
      "limit_twist",
      [](OutTwist6& v, double max_linear, double max_angular) {
        return static_cast<int>(safety::limit_twist(v.data(), max_linear, max_angular));
      },
      "values"_a, "max_linear"_a, "max_angular"_a, "Rules 1 and 2 on a twist (6,) in place; the outcome.");
  m.def(
      "limit_twists",
      [](OutTwists& values, double max_linear, double max_angular) {
        std::size_t changed = 0;
        for (std::size_t k = 0; k < values.shape(0); ++k)
          changed += safety::limit_twist(values.data() + 6 * k, max_linear, max_angular) != safety::Outcome::Within;
        return changed;
      },
      "values"_a, "max_linear"_a, "max_angular"_a, "Rules 1 and 2 on each row of (N, 6) in place; rows changed.");
  m.def(
      "limit_joint_command",
      [](OutVector& joint_velocities, OutTwist6& twist, const Vector& joint_limits, double max_linear,
         double max_angular) {
        if (joint_limits.shape(0) != joint_velocities.shape(0))
          throw std::invalid_argument("joint_limits: expected one limit per joint velocity");
        return static_cast<int>(safety::limit_joint_command(joint_velocities.data(), joint_velocities.shape(0),
                                                            twist.data(), joint_limits.data(), max_linear,
                                                            max_angular));
      },
      "joint_velocities"_a, "twist"_a, "joint_limits"_a, "max_linear"_a, "max_angular"_a,
      "Rules 1 and 2 on a whole-body command in place (one factor for joints and twist); the outcome.");
}

}  // namespace pfield::python
