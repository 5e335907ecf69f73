#include <string>

#include "arap/mesh_check.h"
#include "arap/solve_stats.h"
#include "bindings.h"

namespace arap_python {

void bind_solve_stats(py::module_& m) {
  using arap::SolveStats;
  py::class_<SolveStats>(m, "SolveStats", "Statistics of one solve() call (times in milliseconds).")
      .def_readonly("initial_energy", &SolveStats::initial_energy)
      .def_readonly("energy", &SolveStats::energy, "energy after each iteration")
      .def_readonly("iteration_ms", &SolveStats::iteration_ms)
      .def_readonly("init_ms", &SolveStats::init_ms)
      .def_readonly("rotation_ms", &SolveStats::rotation_ms)
      .def_readonly("rhs_ms", &SolveStats::rhs_ms)
      .def_readonly("linear_solve_ms", &SolveStats::linear_solve_ms)
      .def_readonly("iterations", &SolveStats::iterations)
      .def_readonly("converged", &SolveStats::converged)
      .def_readonly("rotation_fallbacks", &SolveStats::rotation_fallbacks)
      .def_readonly("anderson_rejections", &SolveStats::anderson_rejections)
      .def_readonly("direction_ms", &SolveStats::direction_ms)
      .def_readonly("line_search_steps", &SolveStats::line_search_steps)
      .def_readonly("quasi_newton_resets", &SolveStats::quasi_newton_resets)
      .def_readonly("volume_ms", &SolveStats::volume_ms)
      .def_readonly("volume_drift", &SolveStats::volume_drift,
                    "volume global: largest |V / V_rest - 1| of a kept part at the end")
      .def_readonly("contact_ms", &SolveStats::contact_ms)
      .def_readonly("contact_pairs", &SolveStats::contact_pairs,
                    "contact self: pairs within the barrier's reach at the end")
      .def_readonly("contact_steps_cut", &SolveStats::contact_steps_cut)
      .def_readonly("contact_checks_stopped", &SolveStats::contact_checks_stopped,
                    "contact self: trial steps cut to the share checked within the time budget (warm starts)")
      .def_readonly("contact_lists", &SolveStats::contact_lists)
      .def_readonly("contact_rounds", &SolveStats::contact_rounds)
      .def_readonly("contact_free_iterations", &SolveStats::contact_free_iterations)
      .def_readonly("contact_reached", &SolveStats::contact_reached,
                    "contact self: the share of their moves the constrained vertices made (1: targets met)")
      .def_readonly("contact_stopped_vertex", &SolveStats::contact_stopped_vertex,
                    "contact self: a constrained vertex of the pair that stopped the pose short, or -1")
      .def("__repr__", [](const SolveStats& s) {
        return "<SolveStats iterations=" + std::to_string(s.iterations) +
               " energy=" + (s.energy.empty() ? std::to_string(s.initial_energy) : std::to_string(s.energy.back())) +
               (s.converged ? " converged>" : ">");
      });
}

void bind_mesh_report(py::module_& m) {
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
    for (const arap::MeshReportField& f : arap::kMeshReportFields)
      text += " " + std::string(f.name) + "=" + std::to_string(r.*f.member);
    return text + ">";
  });
}

}  // namespace arap_python
