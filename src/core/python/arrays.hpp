// Array types at the Python boundary: inputs are read in place (C-contiguous, dtypes and shapes in the signature;
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
template <typename T>
using NumpyArrayOf = nb::ndarray<nb::numpy, T>;
using NumpyArray = NumpyArrayOf<double>;

// A new NumPy array of `shape` and a pointer to its (uninitialised) data.
template <typename T>
std::pair<NumpyArrayOf<T>, T*> new_array_of(std::initializer_list<std::size_t> shape) {
  std::size_t size = 1;
  for (std::size_t extent : shape) size *= extent;
  T* data = new T[size > 0 ? size : 1];
  nb::capsule owner(data, [](void* p) noexcept { delete[] static_cast<T*>(p); });
  return {NumpyArrayOf<T>(data, shape.size(), shape.begin(), owner), data};
}

inline std::pair<NumpyArray, double*> new_array(std::initializer_list<std::size_t> shape) {
  return new_array_of<double>(shape);
}

}  // namespace pfield::python
