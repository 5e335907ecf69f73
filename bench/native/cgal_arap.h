// CGAL's Surface_mesh_deformation (ORIGINAL_ARAP, its default cotangent
// weights with negative cotangents clamped to 0, its default SparseLU solver)
// on the same mesh and constraints as our solver. Built only when CGAL is found.
#pragma once

#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "arap/types.h"

namespace bench {

struct CgalResult {
  bool ok = false;
  std::string error;
  double build_ms = 0;       // Surface_mesh construction from the arrays
  double preprocess_ms = 0;  // ROI and control vertices, weights, factorization
  double preprocess_cpu_ms = 0;  // the same in CPU time of the calling thread
  std::vector<double> iteration_ms;  // each deform(1, 0) call
  std::vector<double> iteration_cpu_ms;  // the same in CPU time of the calling thread
};

// The whole mesh is the region of interest and every constrained vertex a
// control vertex (fixed ones keep their rest position as target), so the
// problem is the one our solver gets. Runs `iterations` calls of deform(1, 0);
// after each one, `after_iteration` receives the current positions (untimed).
// Stops early once the iterations' CPU time passes `cpu_ms_limit`.
CgalResult run_cgal_arap(const arap::Points& rest, const arap::Triangles& triangles,
                         const std::vector<int>& constrained, const arap::Points& targets, int iterations,
                         const std::function<void(const arap::Points&)>& after_iteration,
                         double cpu_ms_limit = std::numeric_limits<double>::infinity());

}  // namespace bench
