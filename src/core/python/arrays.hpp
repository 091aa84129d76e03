// Array types at the Python boundary: inputs are read in place (C-contiguous, dtypes and shapes in the signature;
// pfield's Python layer has validated their values), outputs are new NumPy arrays that own their buffer (or the
// caller's arrays, Out*, written in place). Aliases used by more than one binding file live here, once.
#pragma once

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>

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

// The per-call fast path of the hot single-pose bindings (PotentialField.twist): a few doubles read from, or
// written into, a C-contiguous float64 array through the buffer protocol alone. nanobind's ndarray caster builds a
// managed tensor per argument (~0.1 us each); these check the same (dtype, one dimension of n, contiguity; writable
// for the output) and cost a buffer request. A value that does not fit raises TypeError, as the caster would.
class BufferView {
 public:
  BufferView(PyObject* object, std::size_t n, bool writable) {
    const int flags = PyBUF_FORMAT | PyBUF_C_CONTIGUOUS | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(object, &view_, flags) != 0) {
      PyErr_Clear();
      throw nb::type_error("expected a C-contiguous float64 NumPy array");
    }
    held_ = true;
    const char* format = view_.format;
    const bool doubles = format != nullptr && (format[0] == 'd' || ((format[0] == '<' || format[0] == '=' ||
                                                                    format[0] == '@') && format[1] == 'd' &&
                                                                   format[2] == '\0'));
    if (!doubles || view_.ndim != 1 || view_.itemsize != 8 || static_cast<std::size_t>(view_.shape[0]) != n)
      throw nb::type_error(("expected a float64 array of " + std::to_string(n) + " values").c_str());
  }
  ~BufferView() {
    if (held_) PyBuffer_Release(&view_);
  }
  BufferView(const BufferView&) = delete;
  BufferView& operator=(const BufferView&) = delete;

  const double* data() const { return static_cast<const double*>(view_.buf); }
  double* mutable_data() const { return static_cast<double*>(view_.buf); }

 private:
  Py_buffer view_{};
  bool held_ = false;
};

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
