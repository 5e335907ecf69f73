#include "arap/solver.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>
#include <limits>
#include <string>

#include "local_step.h"
#include "solver_impl.h"
#include "unit_scale.h"

namespace arap {

struct Solver::Shared {
  std::atomic<bool> stop{false};
  std::atomic<bool> busy{false};
  std::atomic<int> iterations{0};
  std::atomic<double> energy{0.0};
};

Solver::Solver() : impl_(std::make_unique<Impl>()), shared_(std::make_unique<Shared>()) {}
Solver::~Solver() = default;
Solver::Solver(Solver&&) noexcept = default;
Solver& Solver::operator=(Solver&&) noexcept = default;

SolveStats Solver::solve(const Eigen::Ref<const Points>& targets) {
  Impl& s = *impl_;
  s.check_solve_input(targets);
  SolveStats stats;
  // With contact a cold solve's two parts each have the cap (contact/contact_solve.h).
  const size_t most_iterations = static_cast<size_t>(s.options.max_iterations) * s.contact.parts();
  stats.energy.reserve(most_iterations);
  stats.iteration_ms.reserve(most_iterations);
  s.state_backup = s.state;  // same size every solve: no allocation; restored if anything below goes wrong
  try {
    const auto solve_start = Clock::now();
    const bool quasi_newton = s.runs_quasi_newton();
    bool resume = false, reuse_rotations = false;
    const InitialGuess guess = s.prepare_first_guess(targets, quasi_newton, resume, reuse_rotations);
    stats.init_ms = ms_since(solve_start);
    shared_->iterations.store(0, std::memory_order_relaxed);
    const auto out_of_time = [&] {
      return (s.options.time_budget_ms > 0 && ms_since(solve_start) >= s.options.time_budget_ms) ||
             shared_->stop.load(std::memory_order_relaxed);
    };
    const std::function<bool()> trial_out_of_time = out_of_time;
    s.contact.allow_checks_to_stop(&trial_out_of_time, s.options.time_budget_ms > 0);
    double previous_energy = s.start_iterating(guess, resume, reuse_rotations, quasi_newton, stats, out_of_time);
    shared_->energy.store(energy_to_user_units(stats.initial_energy, s.unit), std::memory_order_relaxed);
    int cap = s.options.max_iterations;
    for (int it = 0; it < cap; ++it) {
      const auto t = Clock::now();
      double e = s.iteration(quasi_newton, previous_energy, stats);
      stats.iteration_ms.push_back(ms_since(t));
      stats.energy.push_back(e);
      stats.iterations = it + 1;
      shared_->energy.store(energy_to_user_units(e, s.unit), std::memory_order_relaxed);
      shared_->iterations.store(it + 1, std::memory_order_relaxed);
      if (s.contact.finish_contact_free_part(stats.converged || it + 1 == cap, it + 1, s, stats, out_of_time, e)) {
        stats.converged = false;
        cap = it + 1 + s.options.max_iterations;
      }
      if (stats.converged) break;
      previous_energy = e;
      if (out_of_time()) break;
    }
    s.end_iterating(stats, previous_energy);
  } catch (...) {
    s.contact.allow_checks_to_stop(nullptr, false);
    s.state = s.state_backup;
    s.rotations_valid = false;
    throw;
  }
  s.keep_solution(targets, stats);
  return stats;
}

void Solver::Impl::check_solve_input(const Eigen::Ref<const Points>& given) {
  if (!bound) throw Error(ErrorCode::NotBound, "solve() called before bind()");
  check_options(options);
  if (options.weights != bound_weights)
    throw Error(ErrorCode::InvalidInput,
                "the weights changed since bind(): bind again to use " + to_string(options.weights));
  if (options.volume != bound_volume || options.infill_resolution != bound_infill_resolution)
    throw Error(ErrorCode::InvalidInput,
                "the volume mode changed since bind(): bind again to use volume " + to_string(options.volume));
  if (options.contact != bound_contact)
    throw Error(ErrorCode::InvalidInput,
                "the contact mode changed since bind(): bind again to use contact " + to_string(options.contact));
  if (given.rows() != mesh.user_constrained)
    throw Error(ErrorCode::InvalidInput, "expected " + std::to_string(mesh.user_constrained) +
                                             " target positions (one per constrained vertex), got " +
                                             std::to_string(given.rows()));
  for (Eigen::Index r = 0; r < given.rows(); ++r)
    if (!given.row(r).allFinite())
      throw Error(ErrorCode::NonFinite, "target " + std::to_string(r) + " (vertex " +
                                            std::to_string(constrained_input[r]) + ") is not finite");
  targets = given / unit;  // same size every solve: no allocation after the first
  if (!targets.allFinite())
    throw Error(ErrorCode::NonFinite, "a target is beyond the double range relative to the mesh's size");
}

// The first guess in `state`, the targets applied; whether the solve resumes the last
// quasi-Newton solve, and whether it may reuse the last rotations.
InitialGuess Solver::Impl::prepare_first_guess(const Eigen::Ref<const Points>& given, bool quasi_newton, bool& resume,
                                               bool& reuse_rotations) {
  InitialGuess guess = options.init;
  if (guess == InitialGuess::WarmStart && !has_solution) guess = options.cold_start;
  // A warm start keeps the rotations of the last solution for its first global step.
  // (Not with no iteration to run: the returned energy must be that of the returned positions.)
  reuse_rotations = guess == InitialGuess::WarmStart && rotations_valid && options.max_iterations > 0;
  // A cold start forgets every hint of the last solve: same input, same output bit for bit.
  if (guess != InitialGuess::WarmStart) std::fill(eigenvalues.begin(), eigenvalues.end(), 0.0);
  resume = quasi_newton && guess == InitialGuess::WarmStart && qn_resumable && last_targets.rows() == given.rows() &&
           last_targets == given;
  const bool cold_quasi_newton = quasi_newton && guess != InitialGuess::WarmStart && options.max_iterations > 0;
  contact.start(guess, resume, cold_quasi_newton, options.threads, state, targets);
  // Where the volume term refuses the global step on the last rotations, a warm start carries
  // the handles' move through the mesh by its harmonic extension instead (contact carries it itself).
  if (quasi_newton && reuse_rotations && !resume && !contact.on() && !warm_start_by_global_step())
    carry_constrained_to(targets, true);
  apply_targets(targets, state);
  if (start_given && guess != InitialGuess::WarmStart) {
    for (int v : mesh.free_vertices) state.row(v) = given_start.row(v);
    start_given = false;  // once: later solves go on from their own solution
  } else {
    first_guess(guess);
  }
  return guess;
}

// The state the iterations start from; returns its energy (NaN when unknown).
double Solver::Impl::start_iterating(InitialGuess guess, bool resume, bool reuse_rotations, bool quasi_newton,
                                     SolveStats& stats, const std::function<bool()>& out_of_time) {
  qn_history = options.method == Method::QuasiNewton;
  double previous_energy = std::numeric_limits<double>::quiet_NaN();
  qn_resumable = false;  // until this solve ends well
  if (resume) {
    contact.resume(*this, stats);
    previous_energy = stats.initial_energy = qn_energy;
  } else if (quasi_newton) {
    // It starts from a point with known energy and gradient. A warm start first
    // carries the moved targets through the mesh with one global step on the
    // last rotations (as the plain iteration's first step does; contact carries them
    // itself), where the volume term allows it.
    if (reuse_rotations && !contact.on() && warm_start_by_global_step()) global_step(stats);
    previous_energy = stats.initial_energy =
        start_quasi_newton_from_guess(guess == InitialGuess::WarmStart, stats, out_of_time);
  } else if (!reuse_rotations) {
    previous_energy = stats.initial_energy = local(stats);
  } else {
    stats.initial_energy = last_energy;  // the first guess's own energy would cost a local step
  }
  if (options.method == Method::Anderson && options.anderson_window > 0) {
    const size_t nf3 = 3 * mesh.free_vertices.size();
    free_before.resize(nf3), free_after.resize(nf3), free_next.resize(nf3);
    anderson.reset(options.anderson_window, static_cast<Eigen::Index>(nf3));
  }
  return previous_energy;
}

// One iteration of the solve's method; sets stats.converged.
double Solver::Impl::iteration(bool quasi_newton, double previous_energy, SolveStats& stats) {
  if (quasi_newton) return quasi_newton_iteration(previous_energy, stats);
  const double e = iterate(previous_energy, stats);
  stats.converged =
      std::isfinite(previous_energy) && previous_energy - e <= options.tolerance * std::abs(previous_energy);
  return e;
}

void Solver::Impl::end_iterating(SolveStats& stats, double previous_energy) {
  last_energy = stats.energy.empty() ? stats.initial_energy : stats.energy.back();
  // Stopped just after the solve with contact began: the state is its start.
  if (!stats.converged && !stats.energy.empty()) last_energy = previous_energy;
  if (volume_term) stats.volume_drift = volume_term->drift(state.data());
  // Finite in internal units is not enough: times `unit` it must stay finite too.
  if (!state.allFinite() || !std::isfinite(state.cwiseAbs().maxCoeff() * unit) || !std::isfinite(last_energy))
    throw Error(ErrorCode::NonFinite,
                "the solve produced non-finite positions or energy (the mesh was left unchanged)");
}

void Solver::Impl::keep_solution(const Eigen::Ref<const Points>& given, SolveStats& stats) {
  // Stopped while still without the barrier: that pose may cross, the positions stay as they were.
  if (!contact.unchecked()) {
    to_input(mesh, state, positions);
    if (unit != 1.0) positions *= unit;
  }
  has_solution = true;
  contact.finish(stats);
  // A solve whose handles were still on their way when time ran out starts the way again.
  if (!contact.interrupted() && runs_quasi_newton()) {
    qn_resumable = true;
    qn_energy = last_energy;
    last_targets = given;
  }
  energies_to_user_units(stats, unit);  // after qn_energy: that one stays in internal units
}

const Points& Solver::positions() const { return impl_->positions; }

namespace {

// Throws unless the solver is `bound` and `positions` are finite, one row per input vertex (`input_n`);
// `call` names the caller.
void check_positions(bool bound, int input_n, const Eigen::Ref<const Points>& positions, const char* call) {
  if (!bound) throw Error(ErrorCode::NotBound, std::string(call) + " called before bind()");
  if (positions.rows() != input_n)
    throw Error(ErrorCode::InvalidInput,
                "expected " + std::to_string(input_n) + " positions, got " + std::to_string(positions.rows()));
  if (!positions.allFinite()) throw Error(ErrorCode::NonFinite, "positions contain NaN or Inf");
}

}  // namespace

void Solver::set_positions(const Eigen::Ref<const Points>& positions) {
  Impl& s = *impl_;
  check_positions(s.bound, s.mesh.input_n, positions, "set_positions()");
  s.positions = positions;
  to_internal(s.mesh, positions / s.unit, s.state);
  s.has_solution = true;
  s.rotations_valid = false;
  s.qn_resumable = false;
  s.contact.positions_set();  // checked at the next solve
}

void Solver::forget_solution() {
  Impl& s = *impl_;
  s.has_solution = false;
  s.rotations_valid = false;
  s.qn_resumable = false;
  s.start_given = false;
}

void Solver::start_from(const Eigen::Ref<const Points>& positions) {
  Impl& s = *impl_;
  check_positions(s.bound, s.mesh.input_n, positions, "start_from()");
  forget_solution();
  s.given_start = s.mesh.rest;
  to_internal(s.mesh, positions / s.unit, s.given_start);
  lattice_follows_surface(s.mesh, s.given_start);
  s.start_given = true;
}

void Solver::set_stop_requested(bool stop) { shared_->stop.store(stop); }

SolveProgress Solver::progress() const {
  return {shared_->iterations.load(std::memory_order_relaxed), shared_->energy.load(std::memory_order_relaxed)};
}

bool Solver::busy() const { return shared_->busy.load(); }

bool Solver::claim() {
  bool expected = false;
  return shared_->busy.compare_exchange_strong(expected, true);
}

void Solver::release() { shared_->busy.store(false); }

Options& Solver::options() { return impl_->options; }
const Options& Solver::options() const { return impl_->options; }
bool Solver::is_bound() const { return impl_->bound; }
int Solver::vertex_count() const { return impl_->mesh.input_n; }
const std::vector<int>& Solver::constrained() const { return impl_->constrained_input; }
const MeshReport& Solver::mesh_report() const { return impl_->mesh.report; }
const BindStats& Solver::bind_stats() const { return impl_->bind_stats; }
long Solver::factor_nonzeros() const { return impl_->laplacian.nonzeros(); }

namespace {

// Positions given in input order, moved to internal order, with the optimal
// rotation of every cell; returns the energy. For energy() and energy_gradient().
// Volume::Infill's lattice nodes are where `current` has them (the solver's state).
double evaluate(const BoundMesh& m, double unit, const Eigen::Ref<const Points>& positions, int threads,
                const char* caller, const Points& current, Points& P, std::vector<Eigen::Matrix3d>& R) {
  if (positions.rows() != m.input_n)
    throw Error(ErrorCode::InvalidInput, std::string(caller) + ": expected " + std::to_string(m.input_n) +
                                             " positions, got " + std::to_string(positions.rows()));
  if (!positions.allFinite()) throw Error(ErrorCode::NonFinite, std::string(caller) + ": positions contain NaN or Inf");
  P = current;
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
  double e = evaluate(s.mesh, s.unit, positions, s.options.threads, "energy()", s.state, P, R);
  if (s.volume_term) e += s.volume_term->energy(P.data());
  if (s.contact.active()) e += s.contact.energy_at(P.data());
  return energy_to_user_units(e, s.unit);
}

Points Solver::energy_gradient(const Eigen::Ref<const Points>& positions) const {
  const Impl& s = *impl_;
  if (!s.bound) throw Error(ErrorCode::NotBound, "energy_gradient() called before bind()");
  Points P;
  std::vector<Eigen::Matrix3d> R;
  evaluate(s.mesh, s.unit, positions, s.options.threads, "energy_gradient()", s.state, P, R);
  Points gradient(s.mesh.n, 3), gradient_input;
  arap::energy_gradient(s.mesh, P.data(), R.data(), gradient.data());
  if (s.volume_term) s.volume_term->add_gradient(P.data(), gradient.data());
  if (s.contact.active()) s.contact.add_gradient_at(P.data(), gradient.data());
  to_input(s.mesh, gradient, gradient_input);
  gradient_input *= s.unit;  // E = unit^2 E(p / unit): dE/dp = unit dE_internal
  if (!gradient_input.allFinite())
    throw Error(ErrorCode::NonFinite, "energy_gradient(): the gradient is beyond the double range at this scale");
  return gradient_input;
}

}  // namespace arap
