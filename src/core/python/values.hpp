// pfield.spatial's value types (Pose, Twist, Wrench) as the per-call hot paths see them. A Pose or a Twist was
// validated when it was built (finite, a unit quaternion; read-only float64 arrays it alone holds), so a binding
// that is handed one may read its arrays as they are, and may answer in a new one as pfield.spatial's
// *_from_checked functions build them (new read-only arrays, adopted without checks). The classes are slotted
// dataclasses: each field is a slot at a fixed offset in the object (its member descriptor's), which pfield.spatial
// registers here once, at import; anything that is not exactly one of these classes is the Python layer's to check.
#pragma once

#include <nanobind/nanobind.h>

namespace pfield::python::values {

namespace nb = nanobind;

// Fields: Pose position (3), orientation (4); Twist linear, angular (3 each); Wrench force, torque (3 each).
enum class Kind : int { Pose = 0, Twist = 1, Wrench = 2 };

// pfield.spatial's classes, kept for the module's life (pfield._core.spatial.register_value_types).
void register_types(nb::handle pose, nb::handle twist, nb::handle wrench);

// The arrays of `object` when its class is exactly `kind`'s and its fields are float64 arrays of their lengths;
// else false (a subclass, another type, None): the caller hands it to the Python layer.
bool read(nb::handle object, Kind kind, const double*& first, const double*& second) noexcept;

// A new `kind` holding copies of `first` and `second` in new read-only arrays.
nb::object make(Kind kind, const double* first, const double* second);

// A new `kind` holding `first` and `second` themselves (pfield.spatial's *_from_checked: arrays its caller checked).
nb::object adopt(Kind kind, nb::handle first, nb::handle second);

}  // namespace pfield::python::values
