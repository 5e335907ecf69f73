#include "band.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <limits>
#include <sstream>
#include <utility>

#include "arap/solver.h"
#include "cpu_clock.h"
#include "methods.h"
#ifdef ARAP_BENCH_HAVE_CGAL
#include "cgal_arap.h"
#endif

namespace bench {

namespace {

using nlohmann::json;

const MethodLabel kMethods[] = {kLocalGlobal, kAnderson5, kQuasiNewton};

// First k (1-based) with energy[k-1] <= limit, or 0.
int first_in_band(const std::vector<double>& energy, double limit) {
  for (size_t k = 0; k < energy.size(); ++k)
    if (energy[k] <= limit) return static_cast<int>(k) + 1;
  return 0;
}

arap::Solver bound(const Case& c, arap::Method method) {
  arap::Options o = bench::surface_options();
  o.method = method;
  o.weights = arap::Weights::CotanClamped;  // the default, and CGAL's weights
  o.init = arap::InitialGuess::Naive;
  arap::Solver s;
  s.bind(c.rest, c.triangles, c.constrained, o);
  return s;
}

// Median CPU ms of `repeats` cold solves with the solver's current options.
double timed_solve(arap::Solver& s, const Case& c, int repeats, arap::SolveStats* last) {
  std::vector<double> ms;
  for (int r = 0; r < repeats; ++r) {
    const double t = thread_cpu_ms();
    arap::SolveStats st = s.solve(c.targets);
    ms.push_back(thread_cpu_ms() - t);
    if (last) *last = std::move(st);
  }
  return median(ms);
}

// Resumes a reference run that ended outside the band: warm-started chunks of
// `kChunk` iterations continue local-global and quasi-newton exactly where the
// last solve stopped (rotations, and the L-BFGS history, kept), each chunk's
// CPU time measured. The chunk that enters the band is counted pro rata (the
// iterations of one method cost alike). Returns {iterations, CPU ms} to the
// band from the cold start, or {0, ms spent} when it never got there (within
// `extend_iterations`, or before its CPU time passed `cpu_ms_cap`).
std::pair<int, double> resume_into_band(arap::Solver& s, const Case& c, double limit, int iterations, double cpu_ms,
                                        int extend_iterations, double cpu_ms_cap) {
  constexpr int kChunk = 100;
  s.options().init = arap::InitialGuess::WarmStart;
  s.options().tolerance = 1e-14;
  while (iterations < extend_iterations && cpu_ms <= cpu_ms_cap) {
    s.options().max_iterations = std::min(kChunk, extend_iterations - iterations);
    const double t = thread_cpu_ms();
    const arap::SolveStats st = s.solve(c.targets);
    const double chunk_ms = thread_cpu_ms() - t;
    const int k = first_in_band(st.energy, limit);
    if (k) return {iterations + k, cpu_ms + chunk_ms * k / st.iterations};
    iterations += st.iterations;
    cpu_ms += chunk_ms;
    if (st.converged || st.iterations == 0) break;  // settled outside the band (another minimum)
  }
  return {0, cpu_ms};
}

}  // namespace

json time_to_band(const Case& c, const BandSettings& settings) {
  json runs = json::array();
  std::vector<arap::Solver> solvers;
  double best = std::numeric_limits<double>::infinity();
  // Reference runs: the whole budget, stopping only once the energy no longer moves.
  for (const MethodLabel& m : kMethods) {
    solvers.push_back(bound(c, m.method));
    arap::Solver& s = solvers.back();
    s.options().max_iterations = settings.reference_iterations;
    s.options().tolerance = 1e-14;
    const double cpu = thread_cpu_ms();
    const arap::SolveStats st = s.solve(c.targets);
    const double reference_cpu_ms = thread_cpu_ms() - cpu;
    for (double e : st.energy) best = std::min(best, e);
    runs.push_back({{"method", m.label},
                    {"energy", st.energy},
                    {"reference_iterations", st.iterations},
                    {"reference_cpu_ms", reference_cpu_ms}});
  }
  const double limit = best + settings.band * std::abs(best);
  // The default method first: its time to the band sets the others' cap.
  std::vector<size_t> order(solvers.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_partition(order.begin(), order.end(),
                        [](size_t i) { return kMethods[i].method == arap::Options().method; });
  double cpu_ms_cap = std::numeric_limits<double>::infinity();
  for (size_t i : order) {
    json& r = runs[i];
    arap::Solver& s = solvers[i];
    int k = first_in_band(r["energy"].get<std::vector<double>>(), limit);
    r["iterations_to_band"] = k;
    r["cpu_ms_to_band"] = nullptr;
    if (k) {
      s.options().max_iterations = k;
      s.options().tolerance = 0;
      // A solve that alone passes the cap (its share of the reference run) is timed once, not `repeats` times.
      const double one_solve_ms = r["reference_cpu_ms"].get<double>() * k / r["reference_iterations"].get<int>();
      const int repeats = one_solve_ms > cpu_ms_cap ? 1 : settings.repeats;
      r["cpu_ms_to_band"] = timed_solve(s, c, repeats, nullptr);
      r["timed_solves"] = repeats;
    } else if (settings.extend_iterations > settings.reference_iterations &&
               kMethods[i].method != arap::Method::Anderson) {  // Anderson's warm start does not resume its history
      const auto [extended_k, ms] =
          resume_into_band(s, c, limit, r["reference_iterations"].get<int>(), r["reference_cpu_ms"].get<double>(),
                           settings.extend_iterations, cpu_ms_cap);
      k = extended_k;
      r["extended"] = true;
      r["iterations_to_band"] = k;
      r[k ? "cpu_ms_to_band" : "cpu_ms_budget"] = ms;
    } else {
      // Not in the band within the budget: the reference run's time is a lower bound.
      r["cpu_ms_budget"] = r["reference_cpu_ms"];
    }
    std::cerr << "  " << kMethods[i].label << ": " << k << " iterations, "
              << (k ? r["cpu_ms_to_band"].get<double>() : r["cpu_ms_budget"].get<double>())
              << (k ? " CPU ms to the band" : " CPU ms without reaching it") << std::endl;
    if (kMethods[i].method != arap::Options().method) continue;
    if (k && settings.cap_ratio > 0) cpu_ms_cap = settings.cap_ratio * r["cpu_ms_to_band"].get<double>();
    // The defaults a user gets (the default method, its tolerance stop and safety cap).
    s.options() = bench::surface_options();
    arap::SolveStats st;
    r["default_cpu_ms"] = timed_solve(s, c, settings.repeats, &st);
    r["default_iterations"] = st.iterations;
    r["default_converged"] = st.converged;
    r["default_energy"] = st.energy.empty() ? st.initial_energy : st.energy.back();
    r["default_in_band"] = r["default_energy"].get<double>() <= limit;
    r["line_search_steps"] = st.line_search_steps;
    r["quasi_newton_resets"] = st.quasi_newton_resets;
    std::cerr << "  defaults: " << st.iterations << " iterations, " << r["default_cpu_ms"].get<double>()
              << " CPU ms, " << (r["default_in_band"].get<bool>() ? "in" : "NOT in") << " the band" << std::endl;
  }
  json out = {{"name", c.name}, {"vertices", c.rest.rows()}, {"best_energy", best}, {"band_limit", limit},
              {"runs", runs}, {"cgal", nullptr}};
  if (std::isfinite(cpu_ms_cap)) out["cpu_ms_cap"] = cpu_ms_cap;
#ifdef ARAP_BENCH_HAVE_CGAL
  if (settings.cgal && c.rest.rows() <= settings.cgal_max_vertices) {
    // CGAL's k-th iteration is our (k-1)-th from the Laplacian guess; it follows plain local/global, so
    // it gets that method's iterations plus a margin (or the budget).
    const int plain_k = runs[0]["iterations_to_band"].get<int>();
    const int budget = plain_k ? std::min(plain_k + 20, settings.reference_iterations) : settings.reference_iterations;
    arap::Solver evaluator = bound(c, arap::Method::LocalGlobal);
    std::vector<double> energy;
    const CgalResult res = run_cgal_arap(c.rest, c.triangles, c.constrained, c.targets, budget,
                                         [&](const arap::Points& p) { energy.push_back(evaluator.energy(p)); },
                                         cpu_ms_cap);
    json cg = {{"iterations_run", res.iteration_cpu_ms.size()}};
    if (!res.ok) {
      cg["error"] = res.error;
    } else {
      const int k = first_in_band(energy, limit);
      double ms = 0;
      for (int j = 0; j < (k ? k : static_cast<int>(energy.size())); ++j) ms += res.iteration_cpu_ms[j];
      cg["iterations_to_band"] = k;
      cg[k ? "cpu_ms_to_band" : "cpu_ms_budget"] = ms;
      cg["final_energy"] = energy.empty() ? NAN : energy.back();
      std::cerr << "  CGAL: " << k << " iterations, " << ms << " CPU ms" << std::endl;
    }
    out["cgal"] = cg;
  }
#endif
  for (json& r : out["runs"]) r.erase("energy");  // large; the table needs only the counts
  return out;
}

namespace {

std::string ms_text(const json& run) {
  char buf[64];
  const char* mark = run.value("extended", false) ? " *" : "";
  if (run.contains("cpu_ms_to_band") && !run["cpu_ms_to_band"].is_null())
    std::snprintf(buf, sizeof buf, "%.4g%s", run["cpu_ms_to_band"].get<double>(), mark);
  else if (run.contains("cpu_ms_budget"))
    std::snprintf(buf, sizeof buf, "> %.4g%s", run["cpu_ms_budget"].get<double>(), mark);
  else
    return "–";
  return buf;
}

}  // namespace

std::string band_table(const json& meshes) {
  std::ostringstream md;
  md << "| mesh | V | local-global (it / CPU ms) | anderson-5 | quasi-newton | CGAL | quasi-newton / local-global | "
        "defaults: it / CPU ms / in band |\n"
     << "|---|---:|---:|---:|---:|---:|---:|---|\n";
  for (const json& m : meshes) {
    md << "| " << m["name"].get<std::string>() << " | " << m["vertices"].get<long>() << " | ";
    for (const json& r : m["runs"])
      md << r["iterations_to_band"].get<int>() << " / " << ms_text(r) << " | ";
    const json& cg = m["cgal"];
    if (cg.is_object() && cg.contains("iterations_to_band"))
      md << cg["iterations_to_band"].get<int>() << " / " << ms_text(cg) << " | ";
    else
      md << "– | ";
    const json& plain = m["runs"][0];
    const json& qn = m["runs"][2];
    char ratio[32] = "–";
    if (!qn["cpu_ms_to_band"].is_null()) {
      const double denominator = plain["cpu_ms_to_band"].is_null() ? plain["cpu_ms_budget"].get<double>()
                                                                   : plain["cpu_ms_to_band"].get<double>();
      std::snprintf(ratio, sizeof ratio, "%s%.3f", plain["cpu_ms_to_band"].is_null() ? "< " : "",
                    qn["cpu_ms_to_band"].get<double>() / denominator);
    }
    char defaults[96];
    std::snprintf(defaults, sizeof defaults, "%d / %.4g / %s", qn["default_iterations"].get<int>(),
                  qn["default_cpu_ms"].get<double>(), qn["default_in_band"].get<bool>() ? "yes" : "no");
    md << ratio << " | " << defaults << " |\n";
  }
  return md.str();
}

}  // namespace bench
