// Bindings of the costmap's kernels (pfield.costmap): a thin list of defs over costmap/*.hpp.
#include <nanobind/nanobind.h>

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "costmap/find_valid_pose.hpp"
#include "costmap/grid.hpp"
#include "costmap/pose_state.hpp"
#include "costmap/raster.hpp"
#include "costmap/resample.hpp"
#include "python/arrays.hpp"

namespace pfield::python {
namespace {

using namespace nb::literals;
using costmap::PoseState;

template <typename T>
using Grid = nb::ndarray<const T, nb::ndim<2>, nb::c_contig, nb::device::cpu>;
using Indices = nb::ndarray<const std::int64_t, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
using CellRows = nb::ndarray<const std::int64_t, nb::shape<-1, 2>, nb::c_contig, nb::device::cpu>;
using States = nb::ndarray<std::uint8_t, nb::ndim<2>, nb::c_contig, nb::device::cpu>;

constexpr std::int64_t kMaxOffset = std::int64_t{1} << 52;  // cells: sums of a few stay far from overflow
constexpr std::size_t kMaxWindowCells = std::size_t{1} << 30;

costmap::CostGrid cost_grid(const Grid<std::uint8_t>& costs) {
  return {costs.data(), static_cast<std::int64_t>(costs.shape(1)), static_cast<std::int64_t>(costs.shape(0))};
}

void check_offsets(const char* name, const std::int64_t* values, std::size_t count) {
  for (std::size_t k = 0; k < count; ++k) {
    if (values[k] > kMaxOffset || values[k] < -kMaxOffset)
      throw std::invalid_argument(std::string(name) + ": offsets beyond 2^52 cells");
  }
}

// The lattice offsets and rings of a search, checked so that the search reads only what it was given.
costmap::Candidates candidates_of(const Indices& pos_i, const Indices& pos_j, const Indices& ring_ptr) {
  const std::size_t count = pos_i.shape(0);
  if (pos_j.shape(0) != count) throw std::invalid_argument("pos_j: expected as many entries as pos_i");
  if (ring_ptr.shape(0) == 0) throw std::invalid_argument("ring_ptr: expected at least one entry");
  check_offsets("pos_i", pos_i.data(), count);
  check_offsets("pos_j", pos_j.data(), count);
  const std::int64_t* starts = ring_ptr.data();
  for (std::size_t r = 0; r < ring_ptr.shape(0); ++r) {
    if (starts[r] < 0 || starts[r] > static_cast<std::int64_t>(count) || (r > 0 && starts[r] < starts[r - 1]))
      throw std::invalid_argument("ring_ptr: expected ascending starts within [0, len(pos_i)]");
  }
  return {pos_i.data(), pos_j.data(), count, starts, ring_ptr.shape(0) - 1};
}

}  // namespace

void bind_costmap(nb::module_& m) {
  m.doc() = "Exact footprint rasterisation, FindValidPose's search, local windows (pfield.costmap's compiled core).";

  m.attr("FREE_SPACE") = costmap::kFreeSpace;
  m.attr("INSCRIBED_INFLATED_OBSTACLE") = costmap::kInscribedInflatedObstacle;
  m.attr("LETHAL_OBSTACLE") = costmap::kLethalObstacle;
  m.attr("NO_INFORMATION") = costmap::kNoInformation;
  m.attr("MAX_RASTER_CELLS") = costmap::kMaxRasterCells;

  nb::enum_<PoseState>(m, "PoseState")
      .value("FREE", PoseState::Free)
      .value("INSCRIBED", PoseState::Inscribed)
      .value("LETHAL", PoseState::Lethal)
      .value("UNKNOWN", PoseState::Unknown)
      .value("OUTSIDE", PoseState::Outside)
      .value("REJECTED", PoseState::Rejected)
      .value("NOT_EVALUATED", PoseState::NotEvaluated);

  nb::class_<costmap::Placement>(m, "Placement")
      .def_ro("state", &costmap::Placement::state)
      .def_ro("cost", &costmap::Placement::cost);

  nb::class_<costmap::YawKernels>(m, "YawKernels")
      .def_prop_ro("yaw_count", &costmap::YawKernels::yaw_count)
      .def_prop_ro("reach", &costmap::YawKernels::reach, "Largest |cell offset| over every yaw.")
      .def_prop_ro("cell_count", [](const costmap::YawKernels& k) { return k.dm.size(); });

  nb::class_<costmap::SearchResult>(m, "SearchResult")
      .def_ro("state", &costmap::SearchResult::state)
      .def_ro("cost", &costmap::SearchResult::cost)
      .def_ro("found", &costmap::SearchResult::found)
      .def_ro("position", &costmap::SearchResult::position)
      .def_ro("yaw", &costmap::SearchResult::yaw);

  m.def(
      "rasterize_polygon",
      [](const Vector& us, const Vector& vs) {
        if (vs.shape(0) != us.shape(0)) throw std::invalid_argument("vs: expected as many entries as us");
        costmap::Cells cells;
        {
          nb::gil_scoped_release release;
          cells = costmap::rasterize_polygon(us.data(), vs.data(), us.shape(0));
        }
        const std::size_t count = cells.m.size();
        auto [out, data] = new_array_of<std::int64_t>({count, 2});
        for (std::size_t k = 0; k < count; ++k) {
          data[2 * k] = cells.m[k];
          data[2 * k + 1] = cells.n[k];
        }
        return out;
      },
      "us"_a, "vs"_a, "Cells (K, 2) rows (m, n) covered by the closed polygon (us, vs) in cell coordinates.");

  m.def(
      "rasterize_yaws",
      [](const Vector& px, const Vector& py, double frac_u, double frac_v, const Vector& yaws, double inv_resolution) {
        if (py.shape(0) != px.shape(0)) throw std::invalid_argument("py: expected as many entries as px");
        const costmap::FootprintPlacement footprint{px.data(), py.data(), px.shape(0), frac_u, frac_v, inv_resolution};
        nb::gil_scoped_release release;
        return costmap::rasterize_yaws(footprint, yaws.data(), yaws.shape(0));
      },
      "px"_a, "py"_a, "frac_u"_a, "frac_v"_a, "yaws"_a, "inv_resolution"_a,
      "The footprint (px, py) (m) turned by each yaw, placed at the sub-cell offset (frac_u, frac_v) and rasterised.");

  m.def(
      "evaluate_cells",
      [](const Grid<std::uint8_t>& costs, const CellRows& cells) {
        const std::size_t count = cells.shape(0);
        check_offsets("cells", cells.data(), 2 * count);
        std::vector<std::int64_t> dm(count), dn(count);
        for (std::size_t k = 0; k < count; ++k) {
          dm[k] = cells.data()[2 * k];
          dn[k] = cells.data()[2 * k + 1];
        }
        const costmap::CellBox box = costmap::bounds_of(dm.data(), dn.data(), count);
        const costmap::FootprintCells footprint{dm.data(), dn.data(), count, box};
        nb::gil_scoped_release release;
        return costmap::evaluate_placement(cost_grid(costs), 0, 0, footprint, costmap::Scan::Full);
      },
      "costs"_a, "cells"_a, "State and cost (sum of the in-map cells' costs) of the cells (K, 2) rows (m, n).");

  m.def(
      "find_valid_pose",
      [](const Grid<std::uint8_t>& costs, const Grid<double>& lethal_distance, std::int64_t base_m, std::int64_t base_n,
         const costmap::YawKernels& kernels, const Indices& pos_i, const Indices& pos_j, const Indices& ring_ptr,
         double prefilter_limit, const States& states) {
        if (lethal_distance.shape(0) != costs.shape(0) || lethal_distance.shape(1) != costs.shape(1))
          throw std::invalid_argument("lethal_distance: expected the shape of costs");
        check_offsets("base cell", &base_m, 1);
        check_offsets("base cell", &base_n, 1);
        const costmap::Candidates candidates = candidates_of(pos_i, pos_j, ring_ptr);
        if (states.shape(0) != candidates.count || states.shape(1) != kernels.yaw_count())
          throw std::invalid_argument("states: expected (len(pos_i), kernels.yaw_count)");
        const costmap::SearchRequest request{cost_grid(costs), lethal_distance.data(), base_m, base_n, prefilter_limit};
        nb::gil_scoped_release release;
        return costmap::find_valid_pose(request, kernels, candidates, states.data());
      },
      "costs"_a, "lethal_distance"_a, "base_m"_a, "base_n"_a, "kernels"_a, "pos_i"_a, "pos_j"_a, "ring_ptr"_a,
      "prefilter_limit"_a, "states"_a,
      "FindValidPose's search from the base cell over the rings of lattice offsets; fills the trace `states`.");

  m.def(
      "resample_occupancy",
      [](const Grid<std::int8_t>& data, double origin_u, double origin_v, double scale, std::size_t size_x,
         std::size_t size_y) {
        if (!(scale > 0.0) || !std::isfinite(origin_u) || !std::isfinite(origin_v) || !std::isfinite(scale))
          throw std::invalid_argument("resample_occupancy: expected finite origins and a finite scale > 0");
        if (size_y > 0 && size_x > kMaxWindowCells / size_y)
          throw std::invalid_argument("resample_occupancy: a window of more than 2^30 cells");
        auto [out, cells] = new_array_of<std::int8_t>({size_y, size_x});
        const costmap::OccupancyView source{data.data(), static_cast<std::int64_t>(data.shape(1)),
                                            static_cast<std::int64_t>(data.shape(0))};
        {
          nb::gil_scoped_release release;
          costmap::resample_occupancy(source, {origin_u, origin_v, scale, size_x, size_y}, cells);
        }
        return out;
      },
      "data"_a, "origin_u"_a, "origin_v"_a, "scale"_a, "size_x"_a, "size_y"_a,
      "Window (size_y, size_x) of an occupancy grid, each cell the worst source cell it overlaps (-1 beyond the map).");
}

}  // namespace pfield::python
