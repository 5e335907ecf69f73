// The JSON report of arap-deform (--report).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "arap/solver.h"

namespace arap::cli {

struct RunInfo {
  std::string mesh_path;
  int vertices = 0;
  int faces = 0;      // polygons of the file
  int triangles = 0;  // after fan triangulation
  int fixed = 0;
  int handle_vertices = 0;
  double read_ms = 0;
  double precompute_ms = 0;  // wall time of Solver::bind
  double total_ms = 0;       // read + bind + solve
  double solve_cpu_ms = 0;   // CPU time of the solving thread in Solver::solve (CLOCK_THREAD_CPUTIME_ID)
  // Weight-free look of the result (arap::rigidity_distortion) and flipped triangles.
  double distortion = 0;
  int flipped_triangles = 0;
};

// Energies, timings, options and the solver's mesh report as one JSON object.
nlohmann::json make_report(const RunInfo& run, const Solver& solver, const SolveStats& stats);

}  // namespace arap::cli
