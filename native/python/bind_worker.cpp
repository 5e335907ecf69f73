#include <memory>

#include "arap/solve_worker.h"
#include "arrays.h"
#include "bindings.h"

namespace arap_python {

namespace {

void bind_worker_result(py::module_& m) {
  using Result = arap::SolveWorker::Result;
  py::class_<Result>(m, "WorkerResult", "The newest solve a SolveWorker finished.")
      .def_readonly("stats", &Result::stats, "SolveStats of that solve")
      .def_readonly("serial", &Result::serial, "solves finished by the worker so far")
      .def_readonly("iterations", &Result::iterations, "iterations spent on the current targets, all solves together")
      .def_readonly("settled", &Result::settled,
                    "converged or out of iterations: the worker sleeps until new targets come");
}

void post(arap::SolveWorker& w, const py::array& targets, bool restart, const py::object& start) {
  PointsView t = view_points(targets, "targets");
  if (start.is_none()) {
    w.post(t.map(), restart);
    return;
  }
  if (!restart) throw py::value_error("post(): start= is a cold start, give restart=True with it");
  PointsView s = view_points(start.cast<py::array>(), "start");
  w.post_from(t.map(), s.map());
}

py::object take(arap::SolveWorker& w, py::array out) {
  const OutBuffer b = check_out(out, w.vertex_count(), "out");
  arap::SolveWorker::Result result;
  bool taken;
  {
    py::gil_scoped_release release;
    taken = w.take(result, [&b](const arap::Points& positions) { copy_out(positions, b); });
  }
  if (!taken) return py::none();
  return py::cast(std::move(result));
}

bool wait(const arap::SolveWorker& w, double timeout_ms) {
  py::gil_scoped_release release;
  return w.wait(timeout_ms);
}

py::tuple progress(const arap::SolveWorker& w) {
  const arap::SolveProgress p = w.progress();
  return py::make_tuple(p.iterations, p.energy);
}

void stop(arap::SolveWorker& w) {
  py::gil_scoped_release release;
  w.stop();
}

}  // namespace

void bind_worker(py::module_& m) {
  bind_worker_result(m);
  py::class_<arap::SolveWorker>(m, "SolveWorker",
                                "Solves on a native thread of its own (no GIL): post() the targets, take() the newest\n"
                                "finished solve. While it exists, the solver refuses every other call (ArapError,\n"
                                "code 'solver busy'); stop() gives it back.")
      .def(py::init([](arap::Solver& solver, int max_iterations) {
             return std::make_unique<arap::SolveWorker>(solver, max_iterations);
           }),
           py::arg("solver"), py::arg("max_iterations"), py::keep_alive<1, 2>(),
           "solver: bound, its options set (time_budget_ms and max_iterations make each solve a chunk);\n"
           "max_iterations: the most iterations spent on one set of targets, all solves together.")
      .def("post", &post, py::arg("targets"), py::arg("restart") = false, py::arg("start") = py::none(),
           "New targets (#constrained by 3); returns at once. restart: solve them from a cold start "
           "(the result then depends on the targets alone); with start (#V by 3), a cold start from that "
           "shape (Solver.start_from).")
      .def("take", &take, py::arg("out"),
           "The newest finished solve, written into `out`, as a WorkerResult; None when none finished since\n"
           "the last take(). A solve that failed raises its error here.")
      .def("wait", &wait, py::arg("timeout_ms"),
           "Wait at most timeout_ms for a finished solve not yet taken (or a failure): True when take() has one.")
      .def_property_readonly("progress", &progress, "(iterations, energy) of the solve in progress")
      .def_property_readonly("settled", &arap::SolveWorker::settled,
                             "every posted target set has settled (or failed) and nothing new came")
      .def("stop", &stop, "End the solve in progress after its current iteration and give the solver back.");
}

}  // namespace arap_python
