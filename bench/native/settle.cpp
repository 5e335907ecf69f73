#include "settle.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <limits>
#include <sstream>
#include <vector>

#include "arap/solver.h"
#include "cpu_clock.h"
#include "methods.h"

namespace bench {

namespace {

using nlohmann::json;

const MethodLabel kMethods[] = {kQuasiNewton, kLocalGlobal, kAnderson5};

// The targets one step further: every handle vertex (a target away from its rest
// position) moves by `step` times the longest side along the handles' mean motion.
arap::Points stepped_targets(const Case& c, double step) {
  const Eigen::RowVector3d extent = c.rest.colwise().maxCoeff() - c.rest.colwise().minCoeff();
  Eigen::RowVector3d motion = Eigen::RowVector3d::Zero();
  std::vector<Eigen::Index> moved;
  for (Eigen::Index k = 0; k < c.targets.rows(); ++k) {
    const Eigen::RowVector3d d = c.targets.row(k) - c.rest.row(c.constrained[static_cast<size_t>(k)]);
    if (d.norm() > 1e-12 * extent.maxCoeff()) motion += d, moved.push_back(k);
  }
  arap::Points out = c.targets;
  if (moved.empty() || motion.norm() == 0) return out;
  const Eigen::RowVector3d further = step * extent.maxCoeff() * motion.normalized();
  for (Eigen::Index k : moved) out.row(k) += further;
  return out;
}

}  // namespace

json settle_after_step(const Case& c, const SettleSettings& settings) {
  const arap::Points further = stepped_targets(c, settings.step);
  json runs = json::array();
  double best = std::numeric_limits<double>::infinity();
  arap::Points best_positions;
  std::vector<std::vector<double>> traces;  // each method's energies over its timed settle
  for (const MethodLabel& m : kMethods) {
    arap::Options o = bench::surface_options();  // the defaults a user gets, but for the method and the volume
    o.method = m.method;
    arap::Solver s;
    s.bind(c.rest, c.triangles, c.constrained, o);
    std::vector<double> ms;
    arap::SolveStats settle, first;
    for (int r = 0; r < settings.repeats; ++r) {
      // Settled at the case's pose (untimed), then the step: the same arithmetic every repeat.
      s.options().init = o.init;
      first = s.solve(c.targets);
      s.options().init = arap::InitialGuess::WarmStart;
      const double t = thread_cpu_ms();
      settle = s.solve(further);
      ms.push_back(thread_cpu_ms() - t);
    }
    const double energy = settle.energy.empty() ? settle.initial_energy : settle.energy.back();
    if (energy < best) best = energy, best_positions = s.positions();
    traces.push_back(settle.energy);
    runs.push_back({{"method", m.label},
                    {"cpu_ms", median(ms)},
                    {"cpu_ms_runs", ms},
                    {"iterations", settle.iterations},
                    {"converged", settle.converged},
                    {"energy", energy},
                    {"initial_energy", settle.initial_energy},
                    {"first_pose_iterations", first.iterations}});
    std::cerr << "  " << m.label << ": settle " << settle.iterations << " iterations, " << median(ms)
              << " CPU ms" << std::endl;
  }
  // E*: quasi-newton resumed from the lowest settle, run until the energy no longer moves.
  {
    arap::Options o = bench::surface_options();
    arap::Solver s;
    s.bind(c.rest, c.triangles, c.constrained, o);
    s.set_positions(best_positions);
    s.options().init = arap::InitialGuess::WarmStart;
    s.options().tolerance = 0;
    s.options().max_iterations = settings.reference_iterations;
    const arap::SolveStats st = s.solve(further);
    for (double e : st.energy) best = std::min(best, e);
  }
  const double limit = best + settings.band * std::abs(best);
  const double reference_ms = runs[0]["cpu_ms"].get<double>();
  for (size_t k = 0; k < runs.size(); ++k) {
    json& r = runs[k];
    const auto entered = std::find_if(traces[k].begin(), traces[k].end(), [&](double e) { return e <= limit; });
    r["band_iteration"] = entered == traces[k].end() ? -1 : 1 + (entered - traces[k].begin());
    r["in_band"] = r["energy"].get<double>() <= limit;
    r["gap"] = (r["energy"].get<double>() - best) / std::abs(best);
    r["ratio_to_quasi_newton"] = r["cpu_ms"].get<double>() / reference_ms;
  }
  return {{"name", c.name}, {"vertices", c.rest.rows()}, {"step", settings.step}, {"best_energy", best},
          {"band_limit", limit}, {"runs", runs}};
}

std::string settle_table(const json& meshes) {
  std::ostringstream md;
  md << "| mesh | V |";
  for (const MethodLabel& m : kMethods) md << " " << m.label << ": it / band at / CPU ms / in band |";
  md << " local-global / quasi-newton | anderson-5 / quasi-newton |\n|---|---:|";
  for (size_t k = 0; k < std::size(kMethods); ++k) md << "---:|";
  md << "---:|---:|\n";
  for (const json& m : meshes) {
    md << "| " << m["name"].get<std::string>() << " | " << m["vertices"].get<long>() << " |";
    for (const json& r : m["runs"]) {
      const int band_at = r["band_iteration"].get<int>();
      char cell[128];
      std::snprintf(cell, sizeof cell, " %d%s / %s / %.4g / %s |", r["iterations"].get<int>(),
                    r["converged"].get<bool>() ? "" : " (cap)",
                    band_at > 0 ? std::to_string(band_at).c_str() : "-", r["cpu_ms"].get<double>(),
                    r["in_band"].get<bool>() ? "yes" : "no");
      md << cell;
    }
    for (size_t k = 1; k < m["runs"].size(); ++k) {
      char cell[32];
      std::snprintf(cell, sizeof cell, " %.2f |", m["runs"][k]["ratio_to_quasi_newton"].get<double>());
      md << cell;
    }
    md << "\n";
  }
  return md.str();
}

}  // namespace bench
