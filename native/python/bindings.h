// The module's parts, one function each; module.cpp calls them in order. A
// class is bound before the functions that take or return it, so that their
// signatures name it. Every file of the module includes this header, so that
// all of them convert the same standard containers (pybind11/stl.h).
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "arap/options.h"
#include "arap/solver.h"

namespace arap_python {

namespace py = pybind11;

// ArapError, and arap::Error raised as it (bind_errors.cpp).
void bind_errors(py::module_& m);
// SolveStats and MeshReport: what a solve and a bind report (bind_reports.cpp).
void bind_solve_stats(py::module_& m);
void bind_mesh_report(py::module_& m);
// ConstraintSet and constraint_set(): the rules of arap/constraints.h (bind_constraints.cpp).
void bind_constraints(py::module_& m);
// Solver (bind_solver.cpp).
py::class_<arap::Solver> bind_solver(py::module_& m);
// WorkerResult and SolveWorker (bind_worker.cpp).
void bind_worker(py::module_& m);
// One Solver property per option, and the OPTIONS table (bind_options.cpp).
void bind_option_properties(py::class_<arap::Solver>& solver);
void bind_option_table(py::module_& m);
// method_conflicts(): the settings the method cannot be combined with, by the core's rule (bind_options.cpp).
void bind_method_conflicts(py::module_& m);

// `options` with `kwargs` (option names) applied, checked as a whole: the
// solver keeps its options unless every one is valid (bind_options.cpp).
arap::Options with_options(arap::Options options, const py::kwargs& kwargs);
// The options of bind(**kwargs): the defaults, `kwargs` set, and Surface Only for a method anderson given
// without a volume mode (arap::surface_only_for_anderson); checked.
arap::Options bind_options(const py::kwargs& kwargs);
// The same for options bound with `bound`: refuses a change to one fixed at bind() (bind_options.cpp).
arap::Options with_unbound_options(const arap::Options& bound, const py::kwargs& kwargs);

// The solver, unless a SolveWorker owns it (its thread may be solving right now) (bind_solver.cpp).
arap::Solver& idle(arap::Solver& s);
const arap::Solver& idle(const arap::Solver& s);

}  // namespace arap_python
