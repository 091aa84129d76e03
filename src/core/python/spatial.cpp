// Bindings of the SO(3) batches under pfield.spatial's vectorised functions: a thin list of defs over
// math/so3.hpp, each over N rows (C-contiguous float64, shapes checked by pfield.spatial).
#include <nanobind/nanobind.h>

#include <cstddef>
#include <stdexcept>

#include "math/so3.hpp"
#include "python/arrays.hpp"
#include "python/values.hpp"

namespace pfield::python {
namespace {

using namespace nb::literals;
using math::Quat;
using math::Vec3;

using Matrices = nb::ndarray<const double, nb::shape<-1, 3, 3>, nb::c_contig, nb::device::cpu>;

Quat quat_row(const Rows<4>& q, std::size_t i) {
  const double* d = q.data() + 4 * i;
  return {d[0], d[1], d[2], d[3]};
}

void same_rows(std::size_t a, std::size_t b) {
  if (a != b) throw std::invalid_argument("expected the same number of rows in both arrays");
}

void write(const Quat& q, double* out) { out[0] = q.x, out[1] = q.y, out[2] = q.z, out[3] = q.w; }
void write(const Vec3& v, double* out) { out[0] = v.x, out[1] = v.y, out[2] = v.z; }

}  // namespace

void bind_spatial(nb::module_& m) {
  m.doc() = "Quaternion and SO(3) maps over batches (pfield.spatial's compiled core; x, y, z, w order).";
  m.def("register_value_types", &values::register_types, "pose"_a, "twist"_a, "wrench"_a,
        "pfield.spatial's Pose, Twist and Wrench (slotted classes), registered once at import: the hot bindings "
        "read and answer them directly (python/values.hpp).");
  m.def(
      "adopt_pose", [](nb::handle a, nb::handle b) { return values::adopt(values::Kind::Pose, a, b); },
      "position"_a, "orientation"_a, "A new Pose holding both arrays as they are (pose_from_checked).");
  m.def(
      "adopt_twist", [](nb::handle a, nb::handle b) { return values::adopt(values::Kind::Twist, a, b); },
      "linear"_a, "angular"_a, "A new Twist holding both arrays as they are (twist_from_checked).");
  m.def(
      "adopt_wrench", [](nb::handle a, nb::handle b) { return values::adopt(values::Kind::Wrench, a, b); },
      "force"_a, "torque"_a, "A new Wrench holding both arrays as they are (wrench_from_checked).");
  m.def(
      "multiply",
      [](const Rows<4>& a, const Rows<4>& b) {
        same_rows(a.shape(0), b.shape(0));
        auto [out, data] = new_array({a.shape(0), 4});
        for (std::size_t i = 0; i < a.shape(0); ++i) write(math::hamilton(quat_row(a, i), quat_row(b, i)), data + 4 * i);
        return out;
      },
      "a"_a, "b"_a, "Hamilton products a (x) b, row by row.");
  m.def(
      "rotate",
      [](const Rows<4>& q, const Rows<3>& v) {
        same_rows(q.shape(0), v.shape(0));
        auto [out, data] = new_array({q.shape(0), 3});
        for (std::size_t i = 0; i < q.shape(0); ++i) {
          const double* w = v.data() + 3 * i;
          write(math::rotate(quat_row(q, i), {w[0], w[1], w[2]}), data + 3 * i);
        }
        return out;
      },
      "q"_a, "v"_a, "Vectors rotated by unit quaternions, row by row.");
  m.def(
      "exp",
      [](const Rows<3>& rotvec) {
        auto [out, data] = new_array({rotvec.shape(0), 4});
        for (std::size_t i = 0; i < rotvec.shape(0); ++i) {
          const double* a = rotvec.data() + 3 * i;
          write(math::so3_exp({a[0], a[1], a[2]}), data + 4 * i);
        }
        return out;
      },
      "rotvec"_a, "The exponential map of rotation vectors (axis * angle).");
  m.def(
      "log",
      [](const Rows<4>& q) {
        auto [out, data] = new_array({q.shape(0), 3});
        for (std::size_t i = 0; i < q.shape(0); ++i) write(math::so3_log(quat_row(q, i)), data + 3 * i);
        return out;
      },
      "q"_a, "The logarithm map of unit quaternions (short arc, angle in [0, pi]).");
  m.def(
      "angle",
      [](const Rows<4>& a, const Rows<4>& b) {
        same_rows(a.shape(0), b.shape(0));
        auto [out, data] = new_array({a.shape(0)});
        for (std::size_t i = 0; i < a.shape(0); ++i) data[i] = math::angle(quat_row(a, i), quat_row(b, i));
        return out;
      },
      "a"_a, "b"_a, "Geodesic angles between unit quaternions, row by row.");
  m.def(
      "to_matrix",
      [](const Rows<4>& q) {
        auto [out, data] = new_array({q.shape(0), 3, 3});
        for (std::size_t i = 0; i < q.shape(0); ++i) math::to_matrix(quat_row(q, i), data + 9 * i);
        return out;
      },
      "q"_a, "Rotation matrices (N, 3, 3) of unit quaternions.");
  m.def(
      "from_matrix",
      [](const Matrices& r) {
        auto [out, data] = new_array({r.shape(0), 4});
        for (std::size_t i = 0; i < r.shape(0); ++i) write(math::from_matrix(r.data() + 9 * i), data + 4 * i);
        return out;
      },
      "r"_a, "Unit quaternions (w >= 0) of rotation matrices, Shepperd's method.");
}

}  // namespace pfield::python
