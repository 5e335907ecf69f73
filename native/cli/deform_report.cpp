#include "deform_report.h"

#include "arap/version.h"

namespace arap::cli {

nlohmann::json make_report(const RunInfo& run, const Solver& solver, const SolveStats& stats) {
  const MeshReport& m = solver.mesh_report();
  const Options& o = solver.options();
  nlohmann::json r;
  r["version"] = version();
  r["mesh"] = run.mesh_path;
  r["vertices"] = run.vertices;
  r["faces"] = run.faces;
  r["triangles"] = run.triangles;
  r["fixed_vertices"] = run.fixed;
  r["handle_vertices"] = run.handle_vertices;
  for (const OptionSpec& spec : option_specs()) {
    if (spec.kind == OptionKind::Choice)
      r[spec.name] = spec.get_choice(o);
    else if (spec.kind == OptionKind::Integer)
      r[spec.name] = static_cast<long long>(spec.get_number(o));
    else
      r[spec.name] = spec.get_number(o);
  }

  r["iterations"] = stats.iterations;
  r["converged"] = stats.converged;
  r["initial_energy"] = stats.initial_energy;
  r["energy"] = stats.energy;
  r["iteration_ms"] = stats.iteration_ms;
  r["read_ms"] = run.read_ms;
  r["precompute_ms"] = run.precompute_ms;
  r["init_ms"] = stats.init_ms;
  r["rotation_ms"] = stats.rotation_ms;
  r["rhs_ms"] = stats.rhs_ms;
  r["solve_ms"] = stats.linear_solve_ms;
  r["total_ms"] = run.total_ms;
  r["rotation_fallbacks"] = stats.rotation_fallbacks;
  r["anderson_rejections"] = stats.anderson_rejections;
  r["direction_ms"] = stats.direction_ms;
  r["line_search_steps"] = stats.line_search_steps;
  r["quasi_newton_resets"] = stats.quasi_newton_resets;
  r["volume_ms"] = stats.volume_ms;
  r["volume_drift"] = stats.volume_drift;
  r["contact_ms"] = stats.contact_ms;
  r["contact_pairs"] = stats.contact_pairs;
  r["contact_steps_cut"] = stats.contact_steps_cut;
  r["contact_checks_stopped"] = stats.contact_checks_stopped;
  r["contact_lists"] = stats.contact_lists;
  r["contact_rounds"] = stats.contact_rounds;
  r["contact_free_iterations"] = stats.contact_free_iterations;
  r["contact_reached"] = stats.contact_reached;
  r["contact_stopped_vertex"] = stats.contact_stopped_vertex;
  r["solve_cpu_ms"] = run.solve_cpu_ms;
  r["factor_nonzeros"] = solver.factor_nonzeros();
  r["bind_mesh_ms"] = solver.bind_stats().mesh_ms;
  r["bind_ordering_ms"] = solver.bind_stats().ordering_ms;
  r["bind_factor_ms"] = solver.bind_stats().factor_ms;
  r["distortion"] = run.distortion;
  r["flipped_triangles"] = run.flipped_triangles;

  // The mesh checks (vertices and triangles are those of the run above).
  for (const MeshReportField& f : kMeshReportFields)
    if (!r.contains(f.name)) r[f.name] = m.*f.member;
  return r;
}

}  // namespace arap::cli
