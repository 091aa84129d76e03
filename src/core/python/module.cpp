// pfield._core: the compiled per-step kernels under pfield's Python API (DESIGN §8). One submodule per concept;
// each binding file is a thin list of defs over a core that knows nothing of Python.
#include <nanobind/nanobind.h>

#define PFIELD_IMPORT_NUMPY  // this file imports NumPy's C API (python/arrays.hpp) for every binding file
#include "python/arrays.hpp"

namespace nb = nanobind;

namespace pfield::python {
void bind_mobile(nb::module_& m);
void bind_costmap(nb::module_& m);
void bind_geometry(nb::module_& m);
void bind_field(nb::module_& m);
void bind_safety(nb::module_& m);
void bind_spatial(nb::module_& m);
void bind_planning(nb::module_& m);
void bind_qp(nb::module_& m);
void bind_cover(nb::module_& m);
void bind_robot(nb::module_& m);
void bind_robot_kinematics(nb::module_& m);
void bind_robot_distance(nb::module_& m);
void bind_whole_body(nb::module_& m);
void bind_rrt(nb::module_& m);
void bind_assistance(nb::module_& m);
}  // namespace pfield::python

NB_MODULE(_core, m) {
  m.doc() = "pfield's compiled core (C++17): the per-step kernels; inputs are validated by the Python layer.";
  using namespace pfield::python;
  if (_import_array() < 0) throw nb::python_error();
  struct Part {
    const char* name;
    void (*bind)(nb::module_&);
  };
  const Part parts[] = {{"mobile", bind_mobile},   {"costmap", bind_costmap}, {"geometry", bind_geometry},
                        {"field", bind_field},     {"safety", bind_safety},   {"spatial", bind_spatial},
                        {"planning", bind_planning}, {"qp", bind_qp},
                        {"cover", bind_cover}, {"robot", bind_robot}, {"robot_kinematics", bind_robot_kinematics},
                        {"robot_distance", bind_robot_distance}, {"whole_body", bind_whole_body}, {"rrt", bind_rrt},
                        {"assistance", bind_assistance}};
  for (const Part& part : parts) {
    nb::module_ sub = m.def_submodule(part.name);
    part.bind(sub);
  }
}
