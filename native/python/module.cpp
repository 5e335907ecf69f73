// _arap_native: the thin pybind11 layer over arap::Solver.
//
// It only converts data (arrays.h), releases the GIL around native work and
// maps arap::Error to the Python exception ArapError. No math lives here.
// The bindings, by subject, are bindings.h's functions.
#include "bindings.h"

PYBIND11_MODULE(_arap_native, m) {
  namespace py = pybind11;
  using namespace arap_python;
  m.doc() = "Thin bindings of the ARAP solver (arap::Solver) for the Blender add-on.";
  m.attr("__version__") = ARAP_MODULE_VERSION;
  // SOABI of the Python this module was compiled for, e.g. "cpython-311-x86_64-linux-gnu".
  m.attr("PYTHON_ABI") = ARAP_PYTHON_ABI;
  m.attr("PYTHON_VERSION") = py::make_tuple(PY_MAJOR_VERSION, PY_MINOR_VERSION);

  bind_errors(m);
  bind_solve_stats(m);
  bind_constraints(m);
  bind_mesh_report(m);
  py::class_<arap::Solver> solver = bind_solver(m);
  bind_worker(m);
  bind_option_properties(solver);
  bind_option_table(m);
  bind_method_conflicts(m);
}
