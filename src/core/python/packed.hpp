// The packed obstacle set at the Python boundary: its eight arrays (PackedObstacles' field order), read in place,
// and the view over them, refused with a ValueError when their lengths or indices disagree (a hand-built set).
// PackedArrays holds the eight for as long as a bound object views them (pfield._core.robot.Obstacles, field.Field).
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

#include "geometry/packed.hpp"
#include "python/arrays.hpp"

namespace pfield::python {

using Kinds = nb::ndarray<const std::int64_t, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
using Triangles = nb::ndarray<const double, nb::shape<-1, 3, 3>, nb::c_contig, nb::device::cpu>;
using PseudoNormals = nb::ndarray<const double, nb::shape<-1, 7, 3>, nb::c_contig, nb::device::cpu>;
using Nodes = nb::ndarray<const std::int64_t, nb::shape<-1, 3>, nb::c_contig, nb::device::cpu>;
using MeshTable = nb::ndarray<const std::int64_t, nb::shape<-1, 5>, nb::c_contig, nb::device::cpu>;

inline geometry::PackedView packed_view(const Kinds& kinds, const Rows<16>& rows, const Triangles& triangles,
                                        const PseudoNormals& pseudo_normals, const Rows<3>& lower,
                                        const Rows<3>& upper, const Nodes& nodes, const MeshTable& table) {
  if (rows.shape(0) != kinds.shape(0)) throw std::invalid_argument("packed: kinds and rows differ in length");
  if (pseudo_normals.shape(0) != triangles.shape(0))
    throw std::invalid_argument("packed: triangles and pseudo_normals differ in length");
  if (lower.shape(0) != nodes.shape(0) || upper.shape(0) != nodes.shape(0))
    throw std::invalid_argument("packed: bvh_lower, bvh_upper and bvh_nodes differ in length");
  const geometry::PackedView view{kinds.data(),       rows.data(),  kinds.shape(0), triangles.data(),
                                  pseudo_normals.data(), triangles.shape(0), lower.data(), upper.data(),
                                  nodes.data(),       nodes.shape(0), table.data(),   table.shape(0)};
  const std::string problem = geometry::check_packed(view);
  if (!problem.empty()) throw std::invalid_argument(problem);
  return view;
}

// The eight arrays, held (their buffers stay alive and in place) and checked once; view() points into them.
class PackedArrays {
 public:
  PackedArrays(const Kinds& kinds, const Rows<16>& rows, const Triangles& triangles,
               const PseudoNormals& pseudo_normals, const Rows<3>& bvh_lower, const Rows<3>& bvh_upper,
               const Nodes& bvh_nodes, const MeshTable& mesh_table)
      : kinds_(kinds), rows_(rows), triangles_(triangles), pseudo_normals_(pseudo_normals), bvh_lower_(bvh_lower),
        bvh_upper_(bvh_upper), bvh_nodes_(bvh_nodes), mesh_table_(mesh_table),
        view_(packed_view(kinds, rows, triangles, pseudo_normals, bvh_lower, bvh_upper, bvh_nodes, mesh_table)) {}

  const geometry::PackedView& view() const { return view_; }
  std::size_t count() const { return view_.obstacle_count; }

 private:
  Kinds kinds_;
  Rows<16> rows_;
  Triangles triangles_;
  PseudoNormals pseudo_normals_;
  Rows<3> bvh_lower_, bvh_upper_;
  Nodes bvh_nodes_;
  MeshTable mesh_table_;
  geometry::PackedView view_;
};

}  // namespace pfield::python
