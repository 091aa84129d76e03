// pfield.spatial's value types as the bindings see them (values.hpp).
#include "python/values.hpp"

#include <structmember.h>

#include <cstddef>

#include "python/arrays.hpp"

namespace pfield::python::values {
namespace {

struct ValueType {
  PyTypeObject* type = nullptr;
  Py_ssize_t offsets[2] = {0, 0};  // of the fields' slots in an instance
  std::size_t sizes[2] = {3, 3};
};

ValueType registry[3];

const ValueType& of(Kind kind) { return registry[static_cast<int>(kind)]; }

PyObject*& slot(PyObject* object, Py_ssize_t offset) {
  return *reinterpret_cast<PyObject**>(reinterpret_cast<char*>(object) + offset);
}

// The offset of `name`'s slot in `type`'s instances: its member descriptor's (a slotted class's field), checked to
// be the class's own layout (a descriptor borrowed from another class would point elsewhere) and within it.
Py_ssize_t slot_offset(nb::handle type, const char* name) {
  auto* cls = reinterpret_cast<PyTypeObject*>(type.ptr());
  nb::object descriptor = nb::getattr(type, name);
  if (Py_TYPE(descriptor.ptr()) != &PyMemberDescr_Type || cls->tp_dictoffset != 0 ||
      PyType_HasFeature(cls, Py_TPFLAGS_MANAGED_DICT))
    throw nb::type_error("register_value_types: expected slotted classes (dataclass(slots=True))");
  auto* member_descriptor = reinterpret_cast<PyMemberDescrObject*>(descriptor.ptr());
  const PyMemberDef* member = member_descriptor->d_member;
  const Py_ssize_t offset = member->offset;
  if (!PyType_IsSubtype(cls, PyDescr_TYPE(member_descriptor)) || member->type != T_OBJECT_EX ||
      offset < static_cast<Py_ssize_t>(sizeof(PyObject)) ||
      offset + static_cast<Py_ssize_t>(sizeof(PyObject*)) > cls->tp_basicsize)
    throw nb::type_error("register_value_types: expected each field to be an object slot of its own class");
  return offset;
}

// A new instance of `entry`'s class with both slots set to `first` and `second` (new references it takes).
nb::object instance(const ValueType& entry, nb::object first, nb::object second) {
  if (entry.type == nullptr) throw std::logic_error("pfield.spatial has not registered its value types");
  PyObject* value = entry.type->tp_alloc(entry.type, 0);  // object.__new__: the slots start empty
  if (value == nullptr) throw nb::python_error();
  slot(value, entry.offsets[0]) = first.release().ptr();
  slot(value, entry.offsets[1]) = second.release().ptr();
  return nb::steal(value);
}

}  // namespace

void register_types(nb::handle pose, nb::handle twist, nb::handle wrench) {
  const nb::handle types[3] = {pose, twist, wrench};
  const char* const names[3][2] = {{"position", "orientation"}, {"linear", "angular"}, {"force", "torque"}};
  ValueType entries[3];  // all three checked before any is registered: a refused call changes nothing
  for (int k = 0; k < 3; ++k) {
    if (!PyType_Check(types[k].ptr())) throw nb::type_error("register_value_types: expected three classes");
    entries[k].offsets[0] = slot_offset(types[k], names[k][0]);
    entries[k].offsets[1] = slot_offset(types[k], names[k][1]);
    entries[k].sizes[1] = k == static_cast<int>(Kind::Pose) ? 4 : 3;
  }
  for (int k = 0; k < 3; ++k) {
    entries[k].type = reinterpret_cast<PyTypeObject*>(nb::handle(types[k]).inc_ref().ptr());
    PyTypeObject* replaced = registry[k].type;
    registry[k] = entries[k];
    Py_XDECREF(replaced);  // after the swap: its deallocation may run Python code that reaches the registry
  }
}

bool read(nb::handle object, Kind kind, const double*& first, const double*& second) noexcept {
  const ValueType& entry = of(kind);
  if (entry.type == nullptr || Py_TYPE(object.ptr()) != entry.type) return false;
  const double* parts[2];
  for (int f = 0; f < 2; ++f) {
    PyObject* field = slot(object.ptr(), entry.offsets[f]);  // null while unset
    PyArrayObject* array = field != nullptr ? flat_doubles(field, false) : nullptr;
    if (array == nullptr || static_cast<std::size_t>(PyArray_DIM(array, 0)) != entry.sizes[f]) return false;
    parts[f] = static_cast<const double*>(PyArray_DATA(array));
  }
  first = parts[0], second = parts[1];
  return true;
}

nb::object make(Kind kind, const double* first, const double* second) {
  const ValueType& entry = of(kind);
  return instance(entry, readonly_copy(first, entry.sizes[0]), readonly_copy(second, entry.sizes[1]));
}

nb::object adopt(Kind kind, nb::handle first, nb::handle second) {
  return instance(of(kind), nb::borrow(first), nb::borrow(second));
}

}  // namespace pfield::python::values
