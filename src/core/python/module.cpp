// pfield._core: the compiled per-step kernels under pfield's Python API (DESIGN §8). One submodule per concept;
// each binding file is a thin list of defs over a core that knows nothing of Python.
#include <nanobind/nanobind.h>

namespace nb = nanobind;

namespace pfield::python {
void bind_mobile(nb::module_& m);
void bind_costmap(nb::module_& m);
void bind_geometry(nb::module_& m);
void bind_field(nb::module_& m);
void bind_safety(nb::module_& m);
void bind_spatial(nb::module_& m);
void bind_planning(nb::module_& m);
}  // namespace pfield::python

NB_MODULE(_core, m) {
  m.doc() = "pfield's compiled core (C++17): the per-step kernels; inputs are validated by the Python layer.";
  nb::module_ mobile = m.def_submodule("mobile");
  pfield::python::bind_mobile(mobile);
  nb::module_ costmap = m.def_submodule("costmap");
  pfield::python::bind_costmap(costmap);
  nb::module_ geometry = m.def_submodule("geometry");
  pfield::python::bind_geometry(geometry);
  nb::module_ field = m.def_submodule("field");
  pfield::python::bind_field(field);
  nb::module_ safety = m.def_submodule("safety");
  pfield::python::bind_safety(safety);
  nb::module_ spatial = m.def_submodule("spatial");
  pfield::python::bind_spatial(spatial);
  nb::module_ planning = m.def_submodule("planning");
  pfield::python::bind_planning(planning);
}
