// _arap_native: the thin pybind11 layer over arap::Solver.
//
// It only converts data, releases the GIL around native work and maps
// arap::Error to the Python exception ArapError. No math lives here.
//
// Arrays: positions are (n, 3) or flat (3n,) C-contiguous float64 (mapped
// without a copy) or float32 (converted to double once). Results are written
// into a buffer the caller owns (float32 or float64, (n, 3) or flat).
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/numpy.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "arap/constraints.h"
#include "arap/errors.h"
#include "arap/mesh_check.h"
#include "arap/options.h"
#include "arap/solve_worker.h"
#include "arap/solver.h"

namespace py = pybind11;

namespace {

using RowPoints = arap::Points;
using MapPoints = Eigen::Map<const RowPoints>;

// A read-only (rows x 3) view of a numpy array: mapped in place when it is
// C-contiguous float64, otherwise converted once into `storage`.
struct PointsView {
  RowPoints storage;
  const double* data = nullptr;
  Eigen::Index rows = 0;
  MapPoints map() const { return MapPoints(data, rows, 3); }
};

Eigen::Index rows_of_xyz(const py::array& a, const char* what) {
  if (a.ndim() == 2 && a.shape(1) == 3) return a.shape(0);
  if (a.ndim() == 1 && a.shape(0) % 3 == 0) return a.shape(0) / 3;
  std::string shape;
  for (py::ssize_t i = 0; i < a.ndim(); ++i) shape += (i ? ", " : "") + std::to_string(a.shape(i));
  throw py::value_error(std::string(what) + ": expected an (n, 3) or flat (3n,) array, got shape (" + shape + ")");
}

void require_c_contiguous(const py::array& a, const char* what) {
  if (!(a.flags() & py::array::c_style))
    throw py::value_error(std::string(what) + ": the array must be C-contiguous (use numpy.ascontiguousarray)");
}

PointsView view_points(const py::array& a, const char* what) {
  PointsView v;
  v.rows = rows_of_xyz(a, what);
  require_c_contiguous(a, what);
  if (py::isinstance<py::array_t<double>>(a)) {
    v.data = static_cast<const double*>(a.data());
  } else if (py::isinstance<py::array_t<float>>(a)) {
    v.storage = Eigen::Map<const Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor>>(
                    static_cast<const float*>(a.data()), v.rows, 3)
                    .cast<double>();
    v.data = v.storage.data();
  } else {
    throw py::type_error(std::string(what) + ": expected a float32 or float64 array, got dtype " +
                         std::string(py::str(a.dtype())));
  }
  return v;
}

// Copies `src` (#V by 3) into the caller's buffer `out` (float32/float64,
// (n, 3) or flat, C-contiguous, writeable). Checks happen with the GIL held;
// the copy itself may run without it.
struct OutBuffer {
  void* data = nullptr;
  bool is_double = true;
};

OutBuffer check_out(py::array& out, Eigen::Index rows, const char* what) {
  if (rows_of_xyz(out, what) != rows)
    throw py::value_error(std::string(what) + ": has " + std::to_string(rows_of_xyz(out, what)) +
                          " rows, the mesh has " + std::to_string(rows) + " vertices");
  require_c_contiguous(out, what);
  if (!out.writeable()) throw py::value_error(std::string(what) + ": the array is read-only");
  OutBuffer b;
  if (py::isinstance<py::array_t<double>>(out)) {
    b.is_double = true;
  } else if (py::isinstance<py::array_t<float>>(out)) {
    b.is_double = false;
  } else {
    throw py::type_error(std::string(what) + ": expected a float32 or float64 array, got dtype " +
                         std::string(py::str(out.dtype())));
  }
  b.data = out.mutable_data();
  return b;
}

// A float32 buffer receives nothing unless every value fits: a finite double
// beyond 3.4e38 would become +-inf in the caller's mesh (and the cast is
// undefined behaviour).
void copy_out(const RowPoints& src, const OutBuffer& b) {
  const Eigen::Index n = src.size();
  if (b.is_double) {
    std::memcpy(b.data, src.data(), sizeof(double) * static_cast<size_t>(n));
    return;
  }
  const double* s = src.data();
  constexpr double kFloatMax = std::numeric_limits<float>::max();
  for (Eigen::Index i = 0; i < n; ++i)
    if (!(std::abs(s[i]) <= kFloatMax))
      throw arap::Error(arap::ErrorCode::NonFinite,
                        "vertex " + std::to_string(i / 3) + " lands at " + std::to_string(s[i]) +
                            ", beyond the float32 range (3.4e38) of the output buffer; nothing was written");
  float* dst = static_cast<float*>(b.data);
  for (Eigen::Index i = 0; i < n; ++i) dst[i] = static_cast<float>(s[i]);
}

arap::Triangles to_triangles(const py::array& a) {
  const Eigen::Index rows = rows_of_xyz(a, "triangles");
  // int32 and int64 (numpy's default) are both accepted; the copy is small
  // next to the factorization that follows.
  py::array_t<int64_t, py::array::c_style | py::array::forcecast> t(a);
  arap::Triangles tri(rows, 3);
  const int64_t* s = t.data();
  for (Eigen::Index i = 0; i < rows * 3; ++i) {
    if (s[i] < 0 || s[i] > INT32_MAX)
      throw py::value_error("triangles: index " + std::to_string(s[i]) + " is negative or too large");
    tri.data()[i] = static_cast<int>(s[i]);
  }
  return tri;
}

// Vertex indices from a 1-D array or sequence of integers (int32 and int64,
// numpy's default, are both accepted). Indices beyond the mesh are the core's
// to refuse (its messages name the group).
std::vector<int> to_indices(const py::handle& a, const std::string& what) {
  py::array_t<int64_t, py::array::c_style | py::array::forcecast> t =
      py::array_t<int64_t, py::array::c_style | py::array::forcecast>::ensure(a);
  if (!t || t.ndim() != 1) throw py::value_error(what + ": expected a 1-D array of vertex indices");
  std::vector<int> out(static_cast<size_t>(t.shape(0)));
  for (size_t i = 0; i < out.size(); ++i) {
    const int64_t v = t.data()[i];
    if (v < 0 || v > INT32_MAX)
      throw py::value_error(what + ": index " + std::to_string(v) + " is negative or too large");
    out[i] = static_cast<int>(v);
  }
  return out;
}

// An option's value as Python sees it: str for a choice, int or float for a number.
py::object option_value(const arap::OptionSpec& spec, const arap::Options& o) {
  if (spec.kind == arap::OptionKind::Choice) return py::str(spec.get_choice(o));
  if (spec.kind == arap::OptionKind::Integer) return py::int_(static_cast<long long>(spec.get_number(o)));
  return py::float_(spec.get_number(o));
}

// Sets one option from a Python value; its limits are checked by arap::check_options() afterwards.
void set_option(arap::Options& o, const std::string& name, const py::handle& value) {
  const arap::OptionSpec& spec = arap::option_spec(name);
  if (spec.kind == arap::OptionKind::Choice) {
    if (!py::isinstance<py::str>(value)) throw py::type_error(name + ": expected one of " + arap::option_limits(spec));
    spec.set_choice(o, py::cast<std::string>(value));
    return;
  }
  const bool is_int = py::isinstance<py::int_>(value) && !py::isinstance<py::bool_>(value);
  if (spec.kind == arap::OptionKind::Integer && !is_int) throw py::type_error(name + ": expected an int");
  if (!is_int && !py::isinstance<py::float_>(value)) throw py::type_error(name + ": expected a number");
  const double v = py::cast<double>(value);
  // An int beyond the option's range must not wrap when it is stored.
  if (!(v >= spec.min && v <= spec.max))
    throw arap::Error(arap::ErrorCode::InvalidInput,
                      name + " must be " + arap::option_limits(spec) + ", got " + std::string(py::str(value)));
  spec.set_number(o, v);
}

// `options` with `kwargs` (option names) applied, checked as a whole: the
// solver keeps its options unless every one is valid.
arap::Options with_options(arap::Options o, const py::kwargs& kwargs) {
  for (const auto& [key, value] : kwargs) set_option(o, py::cast<std::string>(key), value);
  arap::check_options(o);
  return o;
}

// The solver, unless a SolveWorker owns it (its thread may be solving right now).
arap::Solver& idle(arap::Solver& s) {
  if (s.busy())
    throw arap::Error(arap::ErrorCode::Busy,
                      "the solver is in use by a SolveWorker: call the worker's stop() before using the solver");
  return s;
}
const arap::Solver& idle(const arap::Solver& s) { return idle(const_cast<arap::Solver&>(s)); }

}  // namespace

PYBIND11_MODULE(_arap_native, m) {
  m.doc() = "Thin bindings of the ARAP solver (arap::Solver) for the Blender add-on.";
  m.attr("__version__") = ARAP_MODULE_VERSION;
  // SOABI of the Python this module was compiled for, e.g. "cpython-311-x86_64-linux-gnu".
  m.attr("PYTHON_ABI") = ARAP_PYTHON_ABI;
  m.attr("PYTHON_VERSION") = py::make_tuple(PY_MAJOR_VERSION, PY_MINOR_VERSION);

  // ArapError(message).code is the kind of error as arap::error_code_name() names it
  // ("non-finite value", "index out of range", "invalid input", ...).
  static py::exception<arap::Error> arap_error(m, "ArapError", PyExc_RuntimeError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const arap::Error& e) {
      py::object exc = py::handle(arap_error.ptr())(e.what());
      exc.attr("code") = arap::error_code_name(e.code());
      PyErr_SetObject(arap_error.ptr(), exc.ptr());
    }
  });

  py::class_<arap::SolveStats>(m, "SolveStats", "Statistics of one solve() call (times in milliseconds).")
      .def_readonly("initial_energy", &arap::SolveStats::initial_energy)
      .def_readonly("energy", &arap::SolveStats::energy, "energy after each iteration")
      .def_readonly("iteration_ms", &arap::SolveStats::iteration_ms)
      .def_readonly("init_ms", &arap::SolveStats::init_ms)
      .def_readonly("rotation_ms", &arap::SolveStats::rotation_ms)
      .def_readonly("rhs_ms", &arap::SolveStats::rhs_ms)
      .def_readonly("linear_solve_ms", &arap::SolveStats::linear_solve_ms)
      .def_readonly("iterations", &arap::SolveStats::iterations)
      .def_readonly("converged", &arap::SolveStats::converged)
      .def_readonly("rotation_fallbacks", &arap::SolveStats::rotation_fallbacks)
      .def_readonly("anderson_rejections", &arap::SolveStats::anderson_rejections)
      .def_readonly("direction_ms", &arap::SolveStats::direction_ms)
      .def_readonly("line_search_steps", &arap::SolveStats::line_search_steps)
      .def_readonly("quasi_newton_resets", &arap::SolveStats::quasi_newton_resets)
      .def_readonly("volume_ms", &arap::SolveStats::volume_ms)
      .def_readonly("volume_drift", &arap::SolveStats::volume_drift,
                    "volume global: largest |V / V_rest - 1| of a kept part at the end")
      .def_readonly("contact_ms", &arap::SolveStats::contact_ms)
      .def_readonly("contact_pairs", &arap::SolveStats::contact_pairs,
                    "contact self: pairs within the barrier's reach at the end")
      .def_readonly("contact_steps_cut", &arap::SolveStats::contact_steps_cut)
      .def_readonly("contact_checks_stopped", &arap::SolveStats::contact_checks_stopped,
                    "contact self: trial steps cut to the share checked within the time budget (warm starts)")
      .def_readonly("contact_lists", &arap::SolveStats::contact_lists)
      .def_readonly("contact_rounds", &arap::SolveStats::contact_rounds)
      .def_readonly("contact_free_iterations", &arap::SolveStats::contact_free_iterations)
      .def_readonly("contact_reached", &arap::SolveStats::contact_reached,
                    "contact self: the share of their moves the constrained vertices made (1: targets met)")
      .def_readonly("contact_stopped_vertex", &arap::SolveStats::contact_stopped_vertex,
                    "contact self: a constrained vertex of the pair that stopped the pose short, or -1")
      .def("__repr__", [](const arap::SolveStats& s) {
        return "<SolveStats iterations=" + std::to_string(s.iterations) +
               " energy=" + (s.energy.empty() ? std::to_string(s.initial_energy) : std::to_string(s.energy.back())) +
               (s.converged ? " converged>" : ">");
      });

  py::class_<arap::ConstraintSet>(m, "ConstraintSet",
                                  "Constrained vertices by the rules of arap/constraints.h (docs/design.md, 'Constraints: the rules').")
      .def_property_readonly(
          "constrained",
          [](const arap::ConstraintSet& s) {
            py::array_t<int64_t> a(static_cast<py::ssize_t>(s.constrained.size()));
            std::copy(s.constrained.begin(), s.constrained.end(), a.mutable_data());
            return a;
          },
          "int64 vertex indices for Solver.bind(): the fixed ones first, then each kept handle's block")
      .def_readonly("fixed_count", &arap::ConstraintSet::fixed_count)
      .def_property_readonly(
          "handles",
          [](const arap::ConstraintSet& s) {
            py::list out;
            for (const arap::HandleBlock& b : s.handles) out.append(py::make_tuple(b.handle, b.start, b.stop));
            return out;
          },
          "(handle, start, stop) per kept handle: rows [start, stop) of `constrained` follow input handle `handle`")
      .def_readonly("warnings", &arap::ConstraintSet::warnings);

  m.def(
      "constraint_set",
      [](int vertex_count, const py::object& fixed, const std::string& fixed_label, const py::list& handles) {
        arap::ConstraintGroup fixed_group{fixed_label, {}};
        if (!fixed.is_none()) fixed_group.vertices = to_indices(fixed, fixed_label);
        std::vector<arap::ConstraintGroup> groups;
        for (const py::handle h : handles) {
          const py::tuple pair = py::reinterpret_borrow<py::tuple>(h);
          if (!py::isinstance<py::tuple>(h) || pair.size() != 2)
            throw py::type_error("handles: expected (label, vertex indices) pairs");
          const std::string label = py::cast<std::string>(pair[0]);
          groups.push_back({label, to_indices(pair[1], label)});
        }
        py::gil_scoped_release release;
        return arap::make_constraint_set(vertex_count, fixed_group, groups);
      },
      py::arg("vertex_count"), py::arg("fixed"), py::arg("fixed_label"), py::arg("handles"),
      "Fixed first, then each handle's vertices; fixed wins, the first handle wins; warnings name the group\n"
      "that took the vertices. handles: a list of (label, vertex indices); labels name the groups in messages\n"
      "(\"handle 'Arm'\", \"the fixed group 'Feet'\").");

  py::class_<arap::MeshReport> report(m, "MeshReport",
                                      "What bind() found in the mesh and did about it (arap/mesh_check.h); "
                                      "report['name'] reads a field too.");
  for (const arap::MeshReportField& f : arap::kMeshReportFields) report.def_readonly(f.name, f.member);
  report.def("__getitem__", [](const arap::MeshReport& r, const std::string& name) {
    for (const arap::MeshReportField& f : arap::kMeshReportFields)
      if (name == f.name) return r.*f.member;
    throw py::key_error(name);
  });
  report.def("__repr__", [](const arap::MeshReport& r) {
    std::string text = "<MeshReport";
    for (const arap::MeshReportField& f : arap::kMeshReportFields) text += " " + std::string(f.name) + "=" + std::to_string(r.*f.member);
    return text + ">";
  });

  py::class_<arap::Solver> solver(m, "Solver", "Bind once per mesh and constraint set, then solve many times.");
  solver.def(py::init<>())
      .def(
          "bind",
          [](arap::Solver& s, const py::array& rest, const py::array& triangles, const py::array& constrained,
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
            const arap::Options o = with_options(arap::Options(), options);
            idle(s);
            py::gil_scoped_release release;
            s.bind(r.map(), tri, con, o, stiff);
          },
          py::arg("rest"), py::arg("triangles"), py::arg("constrained"), py::arg("stiffness") = py::none(),
          "rest: #V by 3 positions; triangles: #F by 3 indices; constrained: vertex indices (no duplicates);\n"
          "stiffness: optional, one value > 0 per vertex scaling its cell's energy (default all 1);\n"
          "options: any of OPTIONS by name (the others take their defaults).")
      .def(
          "configure",
          [](arap::Solver& s, const py::kwargs& options) {
            idle(s);
            const arap::Options o = with_options(s.options(), options);
            for (const arap::OptionSpec& spec : arap::option_specs())
              if (spec.needs_bind && option_value(spec, o).not_equal(option_value(spec, s.options())))
                throw arap::Error(arap::ErrorCode::InvalidInput, std::string("the option ") + spec.name +
                                                                     " is fixed at bind(): bind again to change it");
            s.options() = o;
          },
          "Set options by name (OPTIONS) that need no new bind; all are checked before any is kept.")
      .def(
          "solve",
          [](arap::Solver& s, const py::array& targets, py::object out) {
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
          },
          py::arg("targets"), py::arg("out") = py::none(),
          "targets: #constrained by 3 in bind order. Writes the result into `out` when given.")
      .def(
          "positions",
          [](const arap::Solver& s, py::object out) -> py::object {
            idle(s);
            if (out.is_none()) {
              py::array_t<double> a({static_cast<py::ssize_t>(s.positions().rows()), py::ssize_t(3)});
              std::memcpy(a.mutable_data(), s.positions().data(), sizeof(double) * s.positions().size());
              return py::object(std::move(a));
            }
            if (!py::isinstance<py::array>(out)) throw py::type_error("out: expected a numpy array");
            py::array out_arr = py::reinterpret_borrow<py::array>(out);
            OutBuffer b = check_out(out_arr, s.positions().rows(), "out");
            {
              py::gil_scoped_release release;
              copy_out(s.positions(), b);
            }
            return out;
          },
          py::arg("out") = py::none(), "The current solution (also the warm-start state).")
      .def(
          "forget_solution", [](arap::Solver& s) { idle(s).forget_solution(); },
          "The next solve starts cold, as the first after bind(): its result depends on its targets alone.")
      .def(
          "set_positions",
          [](arap::Solver& s, const py::array& p) {
            PointsView v = view_points(p, "positions");
            idle(s).set_positions(v.map());
          },
          py::arg("positions"))
      .def(
          "energy",
          [](const arap::Solver& s, const py::array& p) {
            PointsView v = view_points(p, "positions");
            idle(s);
            py::gil_scoped_release release;
            return s.energy(v.map());
          },
          py::arg("positions"))
      .def(
          "energy_gradient",
          [](const arap::Solver& s, const py::array& p) {
            PointsView v = view_points(p, "positions");
            idle(s);
            RowPoints g;
            {
              py::gil_scoped_release release;
              g = s.energy_gradient(v.map());
            }
            py::array_t<double> a({static_cast<py::ssize_t>(g.rows()), py::ssize_t(3)});
            std::memcpy(a.mutable_data(), g.data(), sizeof(double) * g.size());
            return a;
          },
          py::arg("positions"), "dE/dp for every vertex, #V by 3 float64.")
      .def("mesh_report", &arap::Solver::mesh_report, py::return_value_policy::copy)
      .def_property_readonly("is_bound", &arap::Solver::is_bound)
      .def_property_readonly("vertex_count", &arap::Solver::vertex_count)
      .def_property_readonly("bind_ms", [](const arap::Solver& s) { return s.bind_stats().total_ms; })
      .def_property_readonly("factor_nonzeros", &arap::Solver::factor_nonzeros)
      .def_property_readonly("constrained", &arap::Solver::constrained)
      .def_property_readonly("busy", &arap::Solver::busy, "True while a SolveWorker owns the solver");

  py::class_<arap::SolveWorker::Result>(m, "WorkerResult", "The newest solve a SolveWorker finished.")
      .def_readonly("stats", &arap::SolveWorker::Result::stats, "SolveStats of that solve")
      .def_readonly("serial", &arap::SolveWorker::Result::serial, "solves finished by the worker so far")
      .def_readonly("iterations", &arap::SolveWorker::Result::iterations,
                    "iterations spent on the current targets, all solves together")
      .def_readonly("settled", &arap::SolveWorker::Result::settled,
                    "converged or out of iterations: the worker sleeps until new targets come");

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
      .def(
          "post",
          [](arap::SolveWorker& w, const py::array& targets, bool restart) {
            PointsView t = view_points(targets, "targets");
            w.post(t.map(), restart);
          },
          py::arg("targets"), py::arg("restart") = false,
          "New targets (#constrained by 3); returns at once. restart: solve them from a cold start "
          "(the result then depends on the targets alone).")
      .def(
          "take",
          [](arap::SolveWorker& w, py::array out) -> py::object {
            const OutBuffer b = check_out(out, w.vertex_count(), "out");
            arap::SolveWorker::Result result;
            bool taken;
            {
              py::gil_scoped_release release;
              taken = w.take(result, [&b](const RowPoints& positions) { copy_out(positions, b); });
            }
            if (!taken) return py::none();
            return py::cast(std::move(result));
          },
          py::arg("out"),
          "The newest finished solve, written into `out`, as a WorkerResult; None when none finished since\n"
          "the last take(). A solve that failed raises its error here.")
      .def(
          "wait",
          [](const arap::SolveWorker& w, double timeout_ms) {
            py::gil_scoped_release release;
            return w.wait(timeout_ms);
          },
          py::arg("timeout_ms"),
          "Wait at most timeout_ms for a finished solve not yet taken (or a failure): True when take() has one.")
      .def_property_readonly("progress",
                             [](const arap::SolveWorker& w) {
                               const arap::SolveProgress p = w.progress();
                               return py::make_tuple(p.iterations, p.energy);
                             },
                             "(iterations, energy) of the solve in progress")
      .def_property_readonly("settled", &arap::SolveWorker::settled,
                             "every posted target set has settled (or failed) and nothing new came")
      .def(
          "stop",
          [](arap::SolveWorker& w) {
            py::gil_scoped_release release;
            w.stop();
          },
          "End the solve in progress after its current iteration and give the solver back.");

  // One property per option (OPTIONS); those fixed at bind() (weights, volume) are read-only.
  for (const arap::OptionSpec& spec : arap::option_specs()) {
    const std::string name = spec.name;
    auto get = py::cpp_function([name](const arap::Solver& s) { return option_value(arap::option_spec(name), s.options()); });
    if (spec.needs_bind) {
      solver.def_property_readonly(spec.name, get);
      continue;
    }
    solver.def_property(spec.name, get, py::cpp_function([name](arap::Solver& s, const py::object& value) {
                          py::dict one;
                          one[py::str(name)] = value;
                          idle(s).options() = with_options(s.options(), py::kwargs(one));
                        }),
                        ("the option " + name + ": " + arap::option_limits(spec)).c_str());
  }

  // Every option: {name: {"default", "min", "max"} or {"default", "choices"}}, defaults as in arap::Options().
  py::dict specs;
  const arap::Options defaults;
  for (const arap::OptionSpec& spec : arap::option_specs()) {
    py::dict d;
    d["default"] = option_value(spec, defaults);
    if (spec.kind == arap::OptionKind::Choice) {
      d["choices"] = py::cast(spec.choices);
    } else {
      d["kind"] = spec.kind == arap::OptionKind::Integer ? "int" : "float";
      d["min"] = spec.kind == arap::OptionKind::Integer ? py::object(py::int_(static_cast<long long>(spec.min)))
                                                       : py::object(py::float_(spec.min));
      d["max"] = spec.kind == arap::OptionKind::Integer ? py::object(py::int_(static_cast<long long>(spec.max)))
                                                       : py::object(py::float_(spec.max));
    }
    specs[spec.name] = d;
  }
  m.attr("OPTIONS") = specs;
}
