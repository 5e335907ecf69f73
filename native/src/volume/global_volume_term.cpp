#include "volume/global_volume_term.h"

#include <algorithm>

#include "runtime/stopwatch.h"

namespace arap {

void GlobalVolumeTerm::bind(const BoundMesh& mesh, const Triangles& triangles) {
  volume_.bind(mesh, triangles);
  n_.assign(3 * mesh.free_vertices.size(), 0.0);
  u_.assign(3 * mesh.free_vertices.size(), 0.0);
}

void GlobalVolumeTerm::take_normal(const double* P, const LaplacianSolve& solve, SolveStats& stats) {
  auto t = Clock::now();
  volume_.gradient(P, n_.data());
  std::copy(n_.begin(), n_.end(), u_.begin());
  stats.volume_ms += ms_since(t);
  solve(u_.data());
  t = Clock::now();
  volume_.set_normal(n_.data(), u_.data());
  stats.volume_ms += ms_since(t);
}

void GlobalVolumeTerm::constrain_gradient(const double* P, double* g, const LaplacianSolve& solve, SolveStats& stats) {
  take_normal(P, solve, stats);
  volume_.lagrangian_gradient(g, n_.data(), u_.data());
}

// With the volume kept, -L^-1 g~ is tangent already (u.g~ = 0): for the plain step this only removes rounding.
void GlobalVolumeTerm::project_direction(double* d) { volume_.project_tangent(d, n_.data(), u_.data()); }

bool GlobalVolumeTerm::retract(double* P, SolveStats& stats) {
  const auto t = Clock::now();
  const bool on_constraint = volume_.retract(P, u_.data());
  stats.volume_ms += ms_since(t);
  return on_constraint;
}

void GlobalVolumeTerm::project(double* P, const LaplacianSolve& solve, SolveStats& stats) {
  take_normal(P, solve, stats);
  const auto t = Clock::now();
  volume_.retract(P, u_.data());  // no root within reach: the next trial points return instead
  stats.volume_ms += ms_since(t);
}

}  // namespace arap
