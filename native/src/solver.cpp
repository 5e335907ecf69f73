#include "arap/solver.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>

#include "anderson.h"
#include "block_cholesky.h"
#include "bound_mesh.h"
#include "initial_guess.h"
#include "local_step.h"
#include "unit_scale.h"

namespace arap {

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

void check_options(const Options& o) {
  if (o.max_iterations < 0) throw Error(ErrorCode::InvalidInput, "iterations must be >= 0");
  if (!(o.tolerance >= 0) || !std::isfinite(o.tolerance))
    throw Error(ErrorCode::InvalidInput, "tolerance must be a finite number >= 0");
  if (o.threads < 1) throw Error(ErrorCode::InvalidInput, "threads must be >= 1");
  if (o.anderson_window < 0 || o.anderson_window > 20)
    throw Error(ErrorCode::InvalidInput, "anderson window must be between 0 and 20");
  if (o.cold_start == InitialGuess::WarmStart)
    throw Error(ErrorCode::InvalidInput, "the cold-start guess cannot itself be a warm start");
}

}  // namespace

struct Solver::Impl {
  Options options;
  Weights bound_weights = Weights::CotanClamped;
  BoundMesh mesh;
  Triangles triangles;
  std::vector<int> constrained_input;  // as given to bind()
  BlockCholesky laplacian;
  DifferentialGuess differential;
  BindStats bind_stats;
  bool bound = false;
  bool has_solution = false;   // positions hold a solve() result (warm start possible)
  bool rotations_valid = false;  // rotations are optimal for `positions`
  double unit = 1.0;           // internal coordinates = input / unit (see unit_scale.h)
  double last_energy = 0.0;    // energy of the last solution (internal units)

  Points state;      // the current solution in internal vertex order and units (see bound_mesh.h)
  Points targets;    // the last targets in internal units
  Points positions;  // the same in input order, as returned by positions()
  Points state_backup;
  std::vector<Eigen::Matrix3d> rotations;
  std::vector<double> cell_energy, coupled, rhs, work;
  std::vector<double> eigenvalues;  // per cell, warm start of the rotation fit
  AndersonAccelerator anderson;
  std::vector<double> free_before, free_after, free_next;  // #free by 3 each, for Anderson

  void gather_free(std::vector<double>& out) const {
    for (size_t r = 0; r < mesh.free_vertices.size(); ++r)
      for (int d = 0; d < 3; ++d) out[3 * r + d] = state(mesh.free_vertices[r], d);
  }
  void scatter_free(const std::vector<double>& in) {
    for (size_t r = 0; r < mesh.free_vertices.size(); ++r)
      for (int d = 0; d < 3; ++d) state(mesh.free_vertices[r], d) = in[3 * r + d];
  }

  // One iteration: global step, then the local step that gives the new energy
  // and the rotations for the next one. With Anderson acceleration the point
  // after the global step is extrapolated and kept only if its energy is lower
  // than `previous_energy` (then the iteration stays monotone like plain ARAP).
  double iterate(double previous_energy, SolveStats& stats) {
    const bool accelerate = options.anderson_window > 0 && std::isfinite(previous_energy);
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

  // Writes the constrained positions into P and sum_j w_ij p_j into `coupled`.
  void apply_targets(const Eigen::Ref<const Points>& targets, Points& P) {
    for (int s = 0; s < mesh.user_constrained; ++s) P.row(mesh.constrained[s]) = targets.row(s);
    for (size_t s = mesh.user_constrained; s < mesh.constrained.size(); ++s)
      P.row(mesh.constrained[s]) = mesh.rest.row(mesh.constrained[s]);
    std::fill(coupled.begin(), coupled.end(), 0.0);
    for (const Coupling& c : mesh.couplings) {
      const int v = mesh.constrained[c.constrained_slot];
      for (int d = 0; d < 3; ++d) coupled[3 * c.free_row + d] += c.w * P(v, d);
    }
  }

  void first_guess(InitialGuess guess) {
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

  // Global step: L_ff p_f = b_f(R) + coupled.
  void global_step(SolveStats& stats) {
    auto t = Clock::now();
    assemble_rhs(mesh, rotations.data(), coupled.data(), rhs.data(), options.threads);
    stats.rhs_ms += ms_since(t);
    t = Clock::now();
    laplacian.solve_in_place(rhs.data(), work);
    for (size_t r = 0; r < mesh.free_vertices.size(); ++r)
      state.row(mesh.free_vertices[r]) << rhs[3 * r], rhs[3 * r + 1], rhs[3 * r + 2];
    stats.linear_solve_ms += ms_since(t);
  }

  double local(SolveStats& stats) {
    const auto t = Clock::now();
    const double e = local_step(mesh, state.data(), rotations.data(), cell_energy.data(), options.threads,
                                &stats.rotation_fallbacks, eigenvalues.data());
    stats.rotation_ms += ms_since(t);
    rotations_valid = true;
    return e;
  }
};

Solver::Solver() : impl_(std::make_unique<Impl>()) {}
Solver::~Solver() = default;
Solver::Solver(Solver&&) noexcept = default;
Solver& Solver::operator=(Solver&&) noexcept = default;

void Solver::bind(const Eigen::Ref<const Points>& rest, const Eigen::Ref<const Triangles>& triangles,
                  const std::vector<int>& constrained, const Options& options,
                  const std::vector<double>& stiffness) {
  check_options(options);
  const auto start = Clock::now();
  auto next = std::make_unique<Impl>();
  next->options = options;
  next->bound_weights = options.weights;
  next->unit = unit_scale_of(rest);
  next->mesh = build_bound_mesh(rest / next->unit, triangles, constrained, options.weights, stiffness);
  next->bind_stats.mesh_ms = ms_since(start);
  next->triangles.resize(triangles.rows(), 3);
  for (Eigen::Index f = 0; f < triangles.rows(); ++f)
    for (int k = 0; k < 3; ++k) next->triangles(f, k) = next->mesh.rank[triangles(f, k)];
  next->constrained_input = constrained;
  if (!next->laplacian.factor(next->mesh.laplacian_ff))
    throw Error(ErrorCode::Factorization,
                "the Laplacian could not be factored (not positive definite); with --weights cotan on a badly "
                "triangulated mesh, try cotan-clamped");
  const int n = next->mesh.n;
  const size_t nf = next->mesh.free_vertices.size();
  next->state = next->mesh.rest;
  next->positions = rest;
  next->rotations.assign(n, Eigen::Matrix3d::Identity());
  next->cell_energy.assign(n, 0.0);
  next->eigenvalues.assign(n, 0.0);
  next->coupled.assign(3 * nf, 0.0);
  next->rhs.assign(3 * nf, 0.0);
  next->work.assign(3 * nf, 0.0);
  next->bound = true;
  next->bind_stats.ordering_ms = next->laplacian.ordering_ms();
  next->bind_stats.factor_ms = next->laplacian.factor_ms();
  next->bind_stats.total_ms = ms_since(start);
  impl_ = std::move(next);  // only a successful bind replaces the previous state
}

SolveStats Solver::solve(const Eigen::Ref<const Points>& targets) {
  Impl& s = *impl_;
  if (!s.bound) throw Error(ErrorCode::NotBound, "solve() called before bind()");
  check_options(s.options);
  if (s.options.weights != s.bound_weights)
    throw Error(ErrorCode::InvalidInput, "the weights changed since bind(): bind again to use " +
                                             to_string(s.options.weights));
  if (targets.rows() != s.mesh.user_constrained)
    throw Error(ErrorCode::InvalidInput, "expected " + std::to_string(s.mesh.user_constrained) +
                                             " target positions (one per constrained vertex), got " +
                                             std::to_string(targets.rows()));
  for (Eigen::Index r = 0; r < targets.rows(); ++r)
    if (!targets.row(r).allFinite())
      throw Error(ErrorCode::NonFinite, "target " + std::to_string(r) + " (vertex " +
                                            std::to_string(s.constrained_input[r]) + ") is not finite");
  s.targets = targets / s.unit;  // same size every solve: no allocation after the first
  if (!s.targets.allFinite())
    throw Error(ErrorCode::NonFinite, "a target is beyond the double range relative to the mesh's size");

  SolveStats stats;
  stats.energy.reserve(s.options.max_iterations);
  stats.iteration_ms.reserve(s.options.max_iterations);
  s.state_backup = s.state;  // same size every solve: no allocation; restored if anything below goes wrong
  try {
    auto t = Clock::now();
    InitialGuess guess = s.options.init;
    if (guess == InitialGuess::WarmStart && !s.has_solution) guess = s.options.cold_start;
    // A warm start keeps the rotations of the last solution for its first global step.
    // (Not with no iteration to run: the returned energy must be that of the returned positions.)
    const bool reuse_rotations =
        guess == InitialGuess::WarmStart && s.rotations_valid && s.options.max_iterations > 0;
    // A cold start forgets every hint of the last solve: same input, same output bit for bit.
    if (guess != InitialGuess::WarmStart) std::fill(s.eigenvalues.begin(), s.eigenvalues.end(), 0.0);
    s.apply_targets(s.targets, s.state);
    s.first_guess(guess);
    stats.init_ms = ms_since(t);

    double previous_energy = std::numeric_limits<double>::quiet_NaN();
    if (!reuse_rotations) previous_energy = stats.initial_energy = s.local(stats);
    else stats.initial_energy = s.last_energy;  // the first guess's own energy would cost a local step
    if (s.options.anderson_window > 0) {
      const size_t nf3 = 3 * s.mesh.free_vertices.size();
      s.free_before.resize(nf3), s.free_after.resize(nf3), s.free_next.resize(nf3);
      s.anderson.reset(s.options.anderson_window, static_cast<Eigen::Index>(nf3));
    }
    for (int it = 0; it < s.options.max_iterations; ++it) {
      t = Clock::now();
      const double e = s.iterate(previous_energy, stats);
      stats.iteration_ms.push_back(ms_since(t));
      stats.energy.push_back(e);
      stats.iterations = it + 1;
      if (std::isfinite(previous_energy) && previous_energy - e <= s.options.tolerance * std::abs(previous_energy)) {
        stats.converged = true;
        break;
      }
      previous_energy = e;
    }
    s.last_energy = stats.energy.empty() ? stats.initial_energy : stats.energy.back();
    // Finite in internal units is not enough: times `unit` it must stay finite too.
    if (!s.state.allFinite() || !std::isfinite(s.state.cwiseAbs().maxCoeff() * s.unit) ||
        !std::isfinite(s.last_energy))
      throw Error(ErrorCode::NonFinite,
                  "the solve produced non-finite positions or energy (the mesh was left unchanged)");
  } catch (...) {
    s.state = s.state_backup;
    s.rotations_valid = false;
    throw;
  }
  to_input(s.mesh, s.state, s.positions);
  if (s.unit != 1.0) s.positions *= s.unit;
  s.has_solution = true;
  energies_to_user_units(stats, s.unit);
  return stats;
}

const Points& Solver::positions() const { return impl_->positions; }

void Solver::set_positions(const Eigen::Ref<const Points>& positions) {
  Impl& s = *impl_;
  if (!s.bound) throw Error(ErrorCode::NotBound, "set_positions() called before bind()");
  if (positions.rows() != s.mesh.n)
    throw Error(ErrorCode::InvalidInput, "expected " + std::to_string(s.mesh.n) + " positions, got " +
                                             std::to_string(positions.rows()));
  if (!positions.allFinite()) throw Error(ErrorCode::NonFinite, "positions contain NaN or Inf");
  s.positions = positions;
  to_internal(s.mesh, positions / s.unit, s.state);
  s.has_solution = true;
  s.rotations_valid = false;
}

Options& Solver::options() { return impl_->options; }
const Options& Solver::options() const { return impl_->options; }
bool Solver::is_bound() const { return impl_->bound; }
int Solver::vertex_count() const { return impl_->mesh.n; }
const std::vector<int>& Solver::constrained() const { return impl_->constrained_input; }
const MeshReport& Solver::mesh_report() const { return impl_->mesh.report; }
double Solver::bind_ms() const { return impl_->bind_stats.total_ms; }
const BindStats& Solver::bind_stats() const { return impl_->bind_stats; }
long Solver::factor_nonzeros() const { return impl_->laplacian.nonzeros(); }

namespace {

// Positions given in input order, moved to internal order, with the optimal
// rotation of every cell; returns the energy. For energy() and energy_gradient().
double evaluate(const BoundMesh& m, double unit, const Eigen::Ref<const Points>& positions, int threads,
                const char* caller, Points& P, std::vector<Eigen::Matrix3d>& R) {
  if (positions.rows() != m.n)
    throw Error(ErrorCode::InvalidInput, std::string(caller) + ": expected " + std::to_string(m.n) +
                                             " positions, got " + std::to_string(positions.rows()));
  if (!positions.allFinite())
    throw Error(ErrorCode::NonFinite, std::string(caller) + ": positions contain NaN or Inf");
  to_internal(m, positions / unit, P);
  R.resize(m.n);
  std::vector<double> cells(m.n);
  return local_step(m, P.data(), R.data(), cells.data(), threads, nullptr);
}

}  // namespace

double Solver::energy(const Eigen::Ref<const Points>& positions) const {
  const Impl& s = *impl_;
  if (!s.bound) throw Error(ErrorCode::NotBound, "energy() called before bind()");
  Points P;
  std::vector<Eigen::Matrix3d> R;
  return energy_to_user_units(evaluate(s.mesh, s.unit, positions, s.options.threads, "energy()", P, R), s.unit);
}

Points Solver::energy_gradient(const Eigen::Ref<const Points>& positions) const {
  const Impl& s = *impl_;
  if (!s.bound) throw Error(ErrorCode::NotBound, "energy_gradient() called before bind()");
  Points P;
  std::vector<Eigen::Matrix3d> R;
  evaluate(s.mesh, s.unit, positions, s.options.threads, "energy_gradient()", P, R);
  Points gradient(s.mesh.n, 3), gradient_input;
  arap::energy_gradient(s.mesh, P.data(), R.data(), gradient.data());
  to_input(s.mesh, gradient, gradient_input);
  gradient_input *= s.unit;  // E = unit^2 E(p / unit): dE/dp = unit dE_internal
  if (!gradient_input.allFinite())
    throw Error(ErrorCode::NonFinite, "energy_gradient(): the gradient is beyond the double range at this scale");
  return gradient_input;
}

}  // namespace arap
