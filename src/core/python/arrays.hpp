// Array types at the Python boundary: inputs are read in place (C-contiguous, dtypes and shapes in the signature;
// pfield's Python layer has validated their values), outputs are new NumPy arrays that own their buffer (or the
// caller's arrays, Out*, written in place). Aliases used by more than one binding file live here, once.
#pragma once

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>

// NumPy's C API for Doubles and readonly_doubles below; module.cpp defines PFIELD_IMPORT_NUMPY and imports it.
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#define PY_ARRAY_UNIQUE_SYMBOL pfield_core_ARRAY_API
#ifndef PFIELD_IMPORT_NUMPY
#define NO_IMPORT_ARRAY
#endif
#include <numpy/arrayobject.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <stdexcept>
#include <string>
#include <utility>

namespace pfield::python {

namespace nb = nanobind;

using Vector = nb::ndarray<const double, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
using Matrix = nb::ndarray<const double, nb::ndim<2>, nb::c_contig, nb::device::cpu>;
template <int Columns>
using Rows = nb::ndarray<const double, nb::shape<-1, Columns>, nb::c_contig, nb::device::cpu>;
using Points2 = Rows<2>;
using Point = nb::ndarray<const double, nb::shape<3>, nb::c_contig, nb::device::cpu>;
using Quaternion = nb::ndarray<const double, nb::shape<4>, nb::c_contig, nb::device::cpu>;  // x, y, z, w
using Matrix3 = nb::ndarray<const double, nb::shape<3, 3>, nb::c_contig, nb::device::cpu>;
using Rotations = nb::ndarray<const double, nb::shape<-1, 3, 3>, nb::c_contig, nb::device::cpu>;
using Ints = nb::ndarray<const std::int64_t, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
using IntMatrix = nb::ndarray<const std::int64_t, nb::ndim<2>, nb::c_contig, nb::device::cpu>;
using Pairs = nb::ndarray<const std::int64_t, nb::shape<-1, 2>, nb::c_contig, nb::device::cpu>;
// A cancel flag (pfield.planning.cancel_flag): read atomically by the loops that release the GIL.
using Cancel = nb::ndarray<const std::uint8_t, nb::shape<1>, nb::c_contig, nb::device::cpu>;
// A count another thread may lower while a loop runs (pfield.planning.global_search's race of seeds): read atomically.
using Bound = nb::ndarray<const std::int64_t, nb::shape<1>, nb::c_contig, nb::device::cpu>;
// Outputs the caller allocates (np.empty), written in place.
using OutVector = nb::ndarray<double, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
using OutMatrix = nb::ndarray<double, nb::ndim<2>, nb::c_contig, nb::device::cpu>;
template <int Columns>
using OutRows = nb::ndarray<double, nb::shape<-1, Columns>, nb::c_contig, nb::device::cpu>;
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

// A new NumPy array of `shape` that fill(data) writes with the GIL released (the loops of a batch call).
template <typename T = double, typename Fill>
NumpyArrayOf<T> filled_array(std::initializer_list<std::size_t> shape, Fill fill) {
  auto [array, data] = new_array_of<T>(shape);
  {
    nb::gil_scoped_release release;
    fill(data);
  }
  return array;
}

// The per-call hot paths (PotentialField.twist, WholeBodyStepper, forward_kinematics; thousands of calls a second
// from a control loop) take their few arrays as Doubles / OutDoubles: a one-dimensional, C-contiguous, aligned
// float64 NumPy array in native byte order, read or written in place. Converting one is a type check and a few
// reads of the array's fields through NumPy's C API (its headers are a build requirement), about 10 ns, where
// nanobind's ndarray caster builds a managed tensor (0.1-0.15 us an argument) and the buffer protocol a Py_buffer
// (0.07 us). Anything else does not convert (nanobind's TypeError, which names the signature), as an ndarray
// argument with noconvert.
struct Doubles {
  const double* data;
  std::size_t size;
};
struct OutDoubles {
  double* data;
  std::size_t size;
};

// The array `object` as Doubles' rules require (writable as well, for OutDoubles), else null.
inline PyArrayObject* flat_doubles(PyObject* object, bool writable) noexcept {
  if (!PyArray_Check(object)) return nullptr;
  auto* array = reinterpret_cast<PyArrayObject*>(object);
  const bool fits = PyArray_TYPE(array) == NPY_DOUBLE && PyArray_NDIM(array) == 1 && PyArray_ISCARRAY_RO(array) &&
                    (!writable || PyArray_ISWRITEABLE(array));
  return fits ? array : nullptr;
}

// The n values of `object` under Doubles' rules (writable for out_doubles), else TypeError: for arguments of a
// fixed length, or that may be None, taken as nb::handle.
inline double* checked_doubles(nb::handle object, std::size_t n, bool writable) {
  PyArrayObject* array = flat_doubles(object.ptr(), writable);
  if (array == nullptr || static_cast<std::size_t>(PyArray_DIM(array, 0)) != n)
    throw nb::type_error(("expected a C-contiguous float64 NumPy array of " + std::to_string(n) + " values" +
                          (writable ? ", writable" : ""))
                             .c_str());
  return static_cast<double*>(PyArray_DATA(array));
}
inline const double* doubles(nb::handle object, std::size_t n) { return checked_doubles(object, n, false); }
inline double* out_doubles(nb::handle object, std::size_t n) { return checked_doubles(object, n, true); }

// A new, read-only float64 NumPy array of n values that the caller fills through `data` before handing it to
// Python: a kernel's fresh answer, which pfield's value types adopt without copying (pfield.spatial's
// *_from_checked) and nobody may change.
inline std::pair<nb::object, double*> readonly_doubles(std::size_t n) {
  npy_intp extent = static_cast<npy_intp>(n);
  PyObject* array = PyArray_SimpleNew(1, &extent, NPY_DOUBLE);
  if (array == nullptr) throw nb::python_error();
  double* data = static_cast<double*>(PyArray_DATA(reinterpret_cast<PyArrayObject*>(array)));
  PyArray_CLEARFLAGS(reinterpret_cast<PyArrayObject*>(array), NPY_ARRAY_WRITEABLE);
  return {nb::steal(array), data};
}

// A new read-only float64 NumPy array holding a copy of the n values at `values` (readonly_doubles): the parts of
// a kernel's answer that a Twist, a Wrench or a Pose adopts.
inline nb::object readonly_copy(const double* values, std::size_t n) {
  auto [array, data] = readonly_doubles(n);
  std::copy_n(values, n, data);
  return array;
}

// A bound object that another one views: its Python object, kept alive (the views point into the arrays it holds),
// and its C++ instance. Constructed from nb::handle_t<T>, so nanobind checks the type at the call.
template <typename T>
class Held {
 public:
  explicit Held(nb::handle_t<T> object) : owner_(nb::borrow(object)), value_(&nb::cast<const T&>(object)) {}

  const T& operator*() const { return *value_; }
  const T* operator->() const { return value_; }
  const nb::object& object() const { return owner_; }

 private:
  nb::object owner_;
  const T* value_;
};

// A ValueError with `message` unless `condition` (an input that slipped past the Python layer's checks).
inline void require(bool condition, const std::string& message) {
  if (!condition) throw std::invalid_argument(message);
}

}  // namespace pfield::python

namespace nanobind::detail {

// Arguments only: a binding never returns Doubles (it answers in new arrays, readonly_copy).
template <typename Flat, bool Writable>
struct flat_doubles_caster {
  NB_TYPE_CASTER(Flat, const_name("numpy.ndarray[dtype=float64, shape=(*), order='C']"))

  bool from_python(handle source, uint32_t, cleanup_list*) noexcept {
    PyArrayObject* array = pfield::python::flat_doubles(source.ptr(), Writable);
    if (array == nullptr) return false;
    value = {static_cast<decltype(value.data)>(PyArray_DATA(array)), static_cast<std::size_t>(PyArray_DIM(array, 0))};
    return true;
  }
};

template <>
struct type_caster<pfield::python::Doubles> : flat_doubles_caster<pfield::python::Doubles, false> {};
template <>
struct type_caster<pfield::python::OutDoubles> : flat_doubles_caster<pfield::python::OutDoubles, true> {};

}  // namespace nanobind::detail
