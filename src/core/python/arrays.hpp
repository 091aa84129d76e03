// Array types at the Python boundary: inputs are read in place (C-contiguous float64, shapes in the signature;
// pfield's Python layer has validated their values), outputs are new NumPy arrays that own their buffer.
#pragma once

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>

#include <cstddef>
#include <initializer_list>
#include <utility>

namespace pfield::python {

namespace nb = nanobind;

using Vector = nb::ndarray<const double, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
template <int Columns>
using Rows = nb::ndarray<const double, nb::shape<-1, Columns>, nb::c_contig, nb::device::cpu>;
using Points2 = Rows<2>;
using NumpyArray = nb::ndarray<nb::numpy, double>;

// A new float64 NumPy array of `shape` and a pointer to its (uninitialised) data.
inline std::pair<NumpyArray, double*> new_array(std::initializer_list<std::size_t> shape) {
  std::size_t size = 1;
  for (std::size_t extent : shape) size *= extent;
  double* data = new double[size > 0 ? size : 1];
  nb::capsule owner(data, [](void* p) noexcept { delete[] static_cast<double*>(p); });
  return {NumpyArray(data, shape.size(), shape.begin(), owner), data};
}

}  // namespace pfield::python
