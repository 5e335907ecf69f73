// The plain iteration of Sorkine & Alexa 2007 (a global step, then a local
// step), with Anderson acceleration (Peng et al. 2018); first guesses; the
// constrained vertices' sums and the harmonic carry of their move.
#include <cmath>

#include "local_step.h"
#include "solver_impl.h"

namespace arap {

void Solver::Impl::gather_free(std::vector<double>& out) const {
  for (size_t r = 0; r < mesh.free_vertices.size(); ++r)
    for (int d = 0; d < 3; ++d) out[3 * r + d] = state(mesh.free_vertices[r], d);
}

void Solver::Impl::scatter_free(const std::vector<double>& in) {
  for (size_t r = 0; r < mesh.free_vertices.size(); ++r)
    for (int d = 0; d < 3; ++d) state(mesh.free_vertices[r], d) = in[3 * r + d];
}

// One iteration: global step, then the local step that gives the new energy
// and the rotations for the next one. With Anderson acceleration the point
// after the global step is extrapolated and kept only if its energy is lower
// than `previous_energy` (then the iteration stays monotone like plain ARAP).
double Solver::Impl::iterate(double previous_energy, SolveStats& stats) {
  const bool accelerate =
      options.method == Method::Anderson && options.anderson_window > 0 && std::isfinite(previous_energy);
  if (accelerate) gather_free(free_before);
  global_step(stats);
  if (!accelerate) return local(stats);
  gather_free(free_after);
  anderson.step(free_before.data(), free_after.data(), free_next.data());
  scatter_free(free_next);
  const double accelerated = local(stats);
  if (accelerated <= previous_energy) return accelerated;
  ++stats.anderson_rejections;
  scatter_free(free_after);
  return local(stats);
}

// Global step: L_ff p_f = b_f(R) + coupled.
void Solver::Impl::global_step(SolveStats& stats) {
  auto t = Clock::now();
  assemble_rhs(mesh, rotations.data(), coupled.data(), rhs.data(), options.threads);
  stats.rhs_ms += ms_since(t);
  t = Clock::now();
  laplacian.solve_in_place(rhs.data(), work, options.threads);
  for (size_t r = 0; r < mesh.free_vertices.size(); ++r)
    state.row(mesh.free_vertices[r]) << rhs[3 * r], rhs[3 * r + 1], rhs[3 * r + 2];
  stats.linear_solve_ms += ms_since(t);
}

// The energy at the current state (the contact barrier's too), its rotations left for the next gradient.
double Solver::Impl::local(SolveStats& stats) {
  const double surface = local_without_contact(stats);
  return surface + contact.energy(state, stats);
}

// ARAP's energy and the volume term's at the current state, its rotations left for the next gradient.
double Solver::Impl::local_without_contact(SolveStats& stats) {
  const auto t = Clock::now();
  double e = local_step(mesh, state.data(), rotations.data(), cell_energy.data(), options.threads,
                        &stats.rotation_fallbacks, eigenvalues.data());
  if (volume_term) e += volume_term->energy(state.data());
  stats.rotation_ms += ms_since(t);
  rotations_valid = true;
  return e;
}

// Writes the constrained positions into P and sum_j w_ij p_j into `coupled`.
void Solver::Impl::apply_targets(const Eigen::Ref<const Points>& targets_now, Points& P) {
  for (int s = 0; s < mesh.user_constrained; ++s) P.row(mesh.constrained[s]) = targets_now.row(s);
  for (size_t s = mesh.user_constrained; s < mesh.constrained.size(); ++s)
    P.row(mesh.constrained[s]) = mesh.rest.row(mesh.constrained[s]);
  couple(P);
}

// sum_j w_ij p_j over the constrained neighbours j of each free vertex, into `coupled`.
void Solver::Impl::couple(const Points& P) {
  std::fill(coupled.begin(), coupled.end(), 0.0);
  for (const Coupling& c : mesh.couplings) {
    const int v = mesh.constrained[c.constrained_slot];
    for (int d = 0; d < 3; ++d) coupled[3 * c.free_row + d] += c.w * P(v, d);
  }
}

void Solver::Impl::first_guess(InitialGuess guess) {
  switch (guess) {
    case InitialGuess::WarmStart:
      break;
    case InitialGuess::Naive:
      for (int v : mesh.free_vertices) state.row(v) = mesh.rest.row(v);
      break;
    case InitialGuess::Laplacian:
      laplacian_guess(mesh, laplacian, coupled.data(), state, rhs, work);
      break;
    case InitialGuess::Differential:
      if (!differential.prepared()) differential.prepare(mesh, triangles);
      differential.solve(mesh, state, work);
      break;
  }
}

// The free vertices follow the user's constrained vertices' move to `goal` by
// its harmonic extension, L_ff d_f = sum_c w_fc d_c (one solve with the factor).
void Solver::Impl::carry_constrained_to(const Points& goal, bool all_the_way) {
  std::fill(rhs.begin(), rhs.end(), 0.0);
  for (const Coupling& c : mesh.couplings) {
    if (c.constrained_slot >= mesh.user_constrained) continue;
    const int v = mesh.constrained[c.constrained_slot];
    for (int d = 0; d < 3; ++d) rhs[3 * c.free_row + d] += c.w * (goal(c.constrained_slot, d) - state(v, d));
  }
  laplacian.solve_in_place(rhs.data(), work, options.threads);
  for (size_t r = 0; r < mesh.free_vertices.size(); ++r)
    for (int d = 0; d < 3; ++d) state(mesh.free_vertices[r], d) += rhs[3 * r + d];
  if (all_the_way) {
    apply_targets(targets, state);
  } else {
    for (int slot = 0; slot < mesh.user_constrained; ++slot) state.row(mesh.constrained[slot]) = goal.row(slot);
    couple(state);
  }
}

}  // namespace arap
