// Bindings of the joint-path retiming (pfield.planning.retime): a thin list of defs over planning/retime.hpp.
#include <nanobind/nanobind.h>
#include <nanobind/stl/tuple.h>

#include <algorithm>
#include <cstdint>
#include <stdexcept>
#include <tuple>

#include "planning/retime.hpp"
#include "python/arrays.hpp"

namespace pfield::python {
namespace {

using namespace nb::literals;

}  // namespace

void bind_planning(nb::module_& m) {
  m.doc() = "Joint-path retiming (pfield.planning.retime's compiled core).";
  m.def(
      "stretch_intervals",
      [](const Matrix& q, const Vector& h0, const Vector& v_max, const Vector& a_max, int rounds) {
        const std::size_t count = q.shape(0), n = q.shape(1);
        if (count < 2 || h0.shape(0) != count - 1 || v_max.shape(0) != n || a_max.shape(0) != n)
          throw std::invalid_argument("expected q (N >= 2, n), h0 (N - 1,), v_max and a_max (n,)");
        planning::Timing timing;
        {
          nb::gil_scoped_release release;
          timing = planning::stretch_intervals({q.data(), count, n}, h0.data(), v_max.data(), a_max.data(), rounds);
        }
        auto [h, hd] = new_array({count - 1});
        auto [v, vd] = new_array({count, n});
        auto [a, ad] = new_array({count, n});
        std::copy(timing.h.begin(), timing.h.end(), hd);
        std::copy(timing.velocities.begin(), timing.velocities.end(), vd);
        std::copy(timing.accelerations.begin(), timing.accelerations.end(), ad);
        return std::make_tuple(h, v, a);
      },
      "q"_a, "h0"_a, "v_max"_a, "a_max"_a, "rounds"_a,
      "(interval durations h >= h0 under which the samples keep the limits, their velocities, accelerations).");
  m.def(
      "knot_indices",
      [](const Vector& arc, double spacing) {
        if (arc.shape(0) == 0) throw std::invalid_argument("arc: expected at least one sample");
        const std::vector<std::int64_t> keep = planning::knot_indices(arc.data(), arc.shape(0), spacing);
        auto [out, data] = new_array_of<std::int64_t>({keep.size()});
        std::copy(keep.begin(), keep.end(), data);
        return out;
      },
      "arc"_a, "spacing"_a, "The samples that carry the timing (first, every spacing of arc length, last).");
  m.def(
      "strictly_increasing",
      [](OutVector& times) { planning::strictly_increasing(times.data(), times.shape(0)); }, "times"_a,
      "Nudge each repeated time one representable step later, in place.");
}

}  // namespace pfield::python
