#include <string>
#include <vector>

#include "arap/errors.h"
#include "arap/solver.h"
#include "arrays.h"
#include "bindings.h"

namespace arap_python {

arap::Solver& idle(arap::Solver& s) {
  if (s.busy())
    throw arap::Error(arap::ErrorCode::Busy,
                      "the solver is in use by a SolveWorker: call the worker's stop() before using the solver");
  return s;
}

const arap::Solver& idle(const arap::Solver& s) { return idle(const_cast<arap::Solver&>(s)); }

namespace {

void bind(arap::Solver& s, const py::array& rest, const py::array& triangles, const py::array& constrained,
          py::object stiffness, const py::kwargs& options) {
  PointsView r = view_points(rest, "rest");
  arap::Triangles tri = to_triangles(triangles);
  std::vector<int> con = to_indices(constrained, "constrained");
  std::vector<double> stiff;
  if (!stiffness.is_none()) {
    py::array_t<double, py::array::c_style | py::array::forcecast> a(stiffness);
    if (a.ndim() != 1) throw py::value_error("stiffness: expected a flat array, one value per vertex");
    stiff.assign(a.data(), a.data() + a.size());
  }
  const arap::Options o = bind_options(options);
  idle(s);
  py::gil_scoped_release release;
  s.bind(r.map(), tri, con, o, stiff);
}

void configure(arap::Solver& s, const py::kwargs& options) {
  idle(s);
  s.options() = with_unbound_options(s.options(), options);
}

arap::SolveStats solve(arap::Solver& s, const py::array& targets, py::object out) {
  idle(s);
  PointsView t = view_points(targets, "targets");
  OutBuffer b;
  py::array out_arr;
  const bool has_out = !out.is_none();
  if (has_out) {
    // Not ensure(): a list would be copied into a temporary that nobody reads.
    if (!py::isinstance<py::array>(out)) throw py::type_error("out: expected a numpy array");
    out_arr = py::reinterpret_borrow<py::array>(out);
    b = check_out(out_arr, s.vertex_count(), "out");
  }
  py::gil_scoped_release release;
  arap::SolveStats st = s.solve(t.map());
  if (has_out) copy_out(s.positions(), b);
  return st;
}

py::object positions(const arap::Solver& s, py::object out) {
  idle(s);
  if (out.is_none()) return py::object(new_points_array(s.positions()));
  if (!py::isinstance<py::array>(out)) throw py::type_error("out: expected a numpy array");
  py::array out_arr = py::reinterpret_borrow<py::array>(out);
  OutBuffer b = check_out(out_arr, s.positions().rows(), "out");
  {
    py::gil_scoped_release release;
    copy_out(s.positions(), b);
  }
  return out;
}

void set_positions(arap::Solver& s, const py::array& p) {
  PointsView v = view_points(p, "positions");
  idle(s).set_positions(v.map());
}

void start_from(arap::Solver& s, const py::array& p) {
  PointsView v = view_points(p, "positions");
  idle(s).start_from(v.map());
}

double energy(const arap::Solver& s, const py::array& p) {
  PointsView v = view_points(p, "positions");
  idle(s);
  py::gil_scoped_release release;
  return s.energy(v.map());
}

py::array_t<double> energy_gradient(const arap::Solver& s, const py::array& p) {
  PointsView v = view_points(p, "positions");
  idle(s);
  arap::Points g;
  {
    py::gil_scoped_release release;
    g = s.energy_gradient(v.map());
  }
  return new_points_array(g);
}

}  // namespace

py::class_<arap::Solver> bind_solver(py::module_& m) {
  py::class_<arap::Solver> solver(m, "Solver", "Bind once per mesh and constraint set, then solve many times.");
  solver.def(py::init<>())
      .def("bind", &bind, py::arg("rest"), py::arg("triangles"), py::arg("constrained"),
           py::arg("stiffness") = py::none(),
           "rest: #V by 3 positions; triangles: #F by 3 indices; constrained: vertex indices (no duplicates);\n"
           "stiffness: optional, one value > 0 per vertex scaling its cell's energy (default all 1);\n"
           "options: any of OPTIONS by name (the others take their defaults).")
      .def("configure", &configure,
           "Set options by name (OPTIONS) that need no new bind; all are checked before any is kept.")
      .def("solve", &solve, py::arg("targets"), py::arg("out") = py::none(),
           "targets: #constrained by 3 in bind order. Writes the result into `out` when given.")
      .def("positions", &positions, py::arg("out") = py::none(), "The current solution (also the warm-start state).")
      .def(
          "forget_solution", [](arap::Solver& s) { idle(s).forget_solution(); },
          "The next solve starts cold, as the first after bind(): its result depends on its targets alone.")
      .def("set_positions", &set_positions, py::arg("positions"))
      .def("start_from", &start_from, py::arg("positions"),
           "forget_solution(), and the next solve starts from these positions (#V by 3; the constrained\n"
           "vertices at their targets): a cold start from a given shape (a rig's skinned pose).")
      .def("energy", &energy, py::arg("positions"))
      .def("energy_gradient", &energy_gradient, py::arg("positions"), "dE/dp for every vertex, #V by 3 float64.")
      .def("mesh_report", &arap::Solver::mesh_report, py::return_value_policy::copy)
      .def_property_readonly("is_bound", &arap::Solver::is_bound)
      .def_property_readonly("vertex_count", &arap::Solver::vertex_count)
      .def_property_readonly("bind_ms", [](const arap::Solver& s) { return s.bind_stats().total_ms; })
      .def_property_readonly("factor_nonzeros", &arap::Solver::factor_nonzeros)
      .def_property_readonly("constrained", &arap::Solver::constrained)
      .def_property_readonly("busy", &arap::Solver::busy, "True while a SolveWorker owns the solver");
  return solver;
}

}  // namespace arap_python
