#include "contact/contact_solve.h"

#include <algorithm>
#include <cmath>

#include "runtime/stopwatch.h"

namespace arap::contact {

namespace {

// Handles whose targets the first guess cannot reach without a crossing move
// in rounds of at most kLoadStep of their move (the rest of the mesh carried
// harmonically), each checked on the way and followed by kRelaxIterations; at
// most kMaxRounds rounds, stopped short after kStallRounds rounds in a row that
// gain less than kStallGain of the move. Handles that are truly blocked gain
// geometrically less from round to round (about a quarter each time), while
// handles that slide past an obstacle gain a steady small share (0.05-0.1%):
// the threshold lies well below the latter.
constexpr int kMaxRounds = 200;
constexpr double kLoadStep = 0.125;
constexpr int kRelaxIterations = 10;
constexpr int kStallRounds = 8;
constexpr double kStallGain = 1e-4;
// Steps cut at a contact that lower the energy by at most the tolerance, in a row: the pose has settled.
constexpr int kSettledSteps = 3;

// The barrier's kappa: the mean of sum_j w_ij over the mesh's vertices.
double stiffness_of(const BoundMesh& m) {
  double sum = 0;
  for (int v = 0; v < m.input_n; ++v)
    for (int k = m.spoke_begin[v]; k < m.spoke_begin[v + 1]; ++k) sum += m.spokes[k].w;
  return m.input_n > 0 && sum > 0 ? sum / m.input_n : 1.0;
}

}  // namespace

void ContactSolve::bind(const BoundMesh& mesh, const Triangles& triangles) {
  mesh_ = &mesh;
  barrier_.bind(mesh.rest, triangles, stiffness_of(mesh));
  handle_moves_.bind(mesh.constrained, mesh.user_constrained, triangles, mesh.n);
  round_goal_.resize(mesh.user_constrained, 3);
  from_ = mesh.rest;
  goal_ = mesh.rest;
}

void ContactSolve::start(InitialGuess guess, bool resume, bool cold_in_two_parts, int threads, const Points& state,
                         const Points& targets) {
  interrupted_ = false;
  lists_before_ = barrier_.lists_made();
  if (!resume) {
    deferred_ = active() && cold_in_two_parts;
    deferred_guess_ = guess;
    checks_may_stop_ = guess == InitialGuess::WarmStart;
    settling_ = 0;
  }
  if (!active()) return;
  if (!(round_targets_.rows() == targets.rows() && round_targets_ == targets)) {
    round_targets_ = targets;
    stalled_rounds_ = 0;
  }
  barrier_.set_threads(threads);
  // Steps start from a clear state: the last solution, or the rest shape for a cold start
  // (which must not depend on what came before) and after the positions were set to a crossing.
  const bool warm = guess == InitialGuess::WarmStart;
  if (warm && !clear_ && !deferred_) clear_ = barrier_.is_clear(state.data());
  if (warm && clear_)
    from_ = state;
  else
    from_ = mesh_->rest;
  clear_ = false;  // until this solve ends well
}

void ContactSolve::allow_checks_to_stop(const std::function<bool()>* out_of_time, bool time_budget) {
  trial_out_of_time_ = checks_may_stop_ && time_budget ? out_of_time : nullptr;
}

void ContactSolve::resume(SolverHooks& solver, SolveStats& stats) {
  if (on()) {
    solver.current_state() = from_;
    solver.couple_state();
  }
  stats.contact_reached = reached_;  // the handles stand where the solve resumed stopped them
  stats.contact_stopped_vertex = stopped_vertex_;
}

void ContactSolve::add_gradient_at(const double* P, double* gradient) const {
  SelfContact at(barrier_);
  at.energy(P);
  at.add_gradient(gradient);
}

void ContactSolve::step_from(const Points& state, const std::vector<int>& free_row, double* g) {
  if (!on()) return;
  barrier_.add_half_gradient(free_row, g);
  from_ = state;
}

double ContactSolve::energy(const Points& state, SolveStats& stats) {
  if (!on()) return 0;
  const auto t = Clock::now();
  const double e = barrier_.energy(state.data());
  stats.contact_ms += ms_since(t);
  return e;
}

double ContactSolve::limit(double surface, double refused_above, const Points& trial, SolveStats& stats) {
  if (!on()) return surface;
  fraction_ = 1;
  // The barrier only adds: a trial refused on its surface energy alone skips the check, the costly part.
  if (!(surface <= refused_above)) return surface;
  const auto t = Clock::now();
  const SelfContact::Step step =
      barrier_.evaluate(from_.data(), trial.data(), SelfContact::ListAt::End, trial_out_of_time_);
  stats.contact_ms += ms_since(t);
  fraction_ = step.fraction;
  if (step.fraction < 1) {
    ++(step.out_of_time ? stats.contact_checks_stopped : stats.contact_steps_cut);
    return std::numeric_limits<double>::infinity();
  }
  return surface + step.energy;
}

bool ContactSolve::after_iteration(bool steps_cut, bool small_step) {
  // Pressed against a contact, the direction keeps pointing into it (the Laplacian does not know the
  // barrier's stiffness) and every step is cut.
  settling_ = steps_cut && small_step ? settling_ + 1 : 0;
  return settling_ >= kSettledSteps;
}

bool ContactSolve::clear(const Points& state, SolveStats& stats, double* barrier) {
  const auto t = Clock::now();
  const bool is = barrier_.is_clear(state.data(), barrier);
  stats.contact_ms += ms_since(t);
  return is;
}

// A result of the part without the barrier that crosses nothing and has no pair
// within the barrier's reach is kept: the barrier is zero around it, so it is a
// stationary point with contact too, and no step of the solve is shown. A clear
// one with pairs in reach is where the solve with contact starts; one that is not
// clear leaves the usual cold start (reach_first_guess()).
bool ContactSolve::finish_contact_free_part(bool done, int iterations, SolverHooks& solver, SolveStats& stats,
                                            const std::function<bool()>& out_of_time, double& energy) {
  if (!deferred_ || !done) return false;
  // The part without contact has settled, or reached the cap: the solve with contact, when it is
  // needed, has the cap again.
  stats.contact_free_iterations = iterations;
  deferred_ = false;
  settling_ = 0;
  double barrier = 0;
  if (clear(solver.current_state(), stats, &barrier)) {
    if (barrier == 0) return false;
    energy = solver.start_quasi_newton_here(stats);
    return true;
  }
  from_ = mesh_->rest;
  energy = solver.start_cold(deferred_guess_, stats, out_of_time);
  return true;
}

void ContactSolve::reach_first_guess(bool warm, SolverHooks& solver, SolveStats& stats,
                                     const std::function<bool()>& out_of_time) {
  if (!on()) return;
  interrupted_ = false;
  Points& state = solver.current_state();
  if (warm) {
    // From the last pose: the handles' move carried through the mesh, checked on the way
    // (the global step's move would ignore the barrier).
    state = from_;
    carry_targets_through(1.0, solver, stats);
    solver.project_volume(stats);
    const auto t = Clock::now();
    const double fraction = barrier_.evaluate(from_.data(), state.data()).fraction;
    stats.contact_ms += ms_since(t);
    if (fraction >= 1) return;
  } else if (clear(state, stats)) {
    // A first guess that crosses nothing and keeps every pair beyond the gap is
    // a start: how it was made is not a motion anyone sees.
    return;
  }
  // Else (a cold start) the targets carried through the mesh from the rest
  // shape, and when that crosses too, the handles go there in rounds. A warm
  // start takes the rounds at once: its poses are shown, so every move between
  // them is checked.
  if (!warm) {
    state = from_;
    carry_targets_through(1.0, solver, stats);
    solver.project_volume(stats);
    if (clear(state, stats)) return;
  }
  state = from_;
  solver.couple_state();
  move_in_rounds(solver, stats, out_of_time);
}

// Each round moves the handles as far as is safe, then the pose relaxes around
// them, then the rest of their move is carried through the mesh and tried
// again (a quasi-static loading), until the handles get there or stop short
// (stalled, or out of time / stopped: then interrupted_); the state is clear
// either way and the solver's couplings match it.
void ContactSolve::move_in_rounds(SolverHooks& solver, SolveStats& stats, const std::function<bool()>& out_of_time) {
  Points& state = solver.current_state();
  double remaining = 1;  // the share of the constrained vertices' move still to make
  for (int round = 0; round < kMaxRounds; ++round) {
    ++stats.contact_rounds;
    const double share = std::min(1.0, kLoadStep / remaining);
    from_ = state;
    carry_targets_through(share, solver, stats);
    solver.project_volume(stats);
    goal_ = state;
    auto t = Clock::now();
    const SelfContact::Step step = barrier_.evaluate(from_.data(), goal_.data(), SelfContact::ListAt::Start);
    stats.contact_ms += ms_since(t);
    double made = step.fraction >= 1 ? share : kBackoff * step.fraction * share;
    if (step.fraction < 1) {
      state = from_ + kBackoff * step.fraction * (goal_ - from_);
      // A pair pressed within rounding of the gap (a share of 1e-14) can measure
      // inside it after even that move: the round then stays where it started.
      if (!std::isfinite(barrier_.energy(state.data()))) {
        state = from_;
        made = 0;
      }
    }
    remaining *= 1 - made;
    if (step.fraction >= 1 && share >= 1) {
      solver.apply_targets_to_state();
      stats.contact_reached = 1;
      stats.contact_stopped_vertex = -1;
      return;
    }
    stats.contact_reached = 1 - remaining;
    if (step.fraction < 1) stats.contact_stopped_vertex = stopping_vertex(step, state, solver.current_targets());
    stalled_rounds_ = made < kStallGain ? stalled_rounds_ + 1 : 0;
    solver.couple_state();
    if (stalled_rounds_ >= kStallRounds) return;
    interrupted_ = out_of_time();
    if (interrupted_) return;
    solver.relax(kRelaxIterations, stats, out_of_time);
  }
}

// The user's constrained vertices moved `share` of the way to their targets
// (each part that moves as one turning as a rigid body, see handle_moves.h),
// the free ones by the harmonic extension of that move.
void ContactSolve::carry_targets_through(double share, SolverHooks& solver, SolveStats& stats) {
  const auto t = Clock::now();
  if (share < 1) handle_moves_.toward(solver.current_state(), solver.current_targets(), share, round_goal_);
  solver.carry_constrained_to(share >= 1 ? solver.current_targets() : round_goal_, share >= 1);
  stats.linear_solve_ms += ms_since(t);
}

// The input index of a user-constrained vertex still short of its target:
// one of the pair that stopped a step if it has one, else the nearest to that pair.
int ContactSolve::stopping_vertex(const SelfContact::Step& step, const Points& state, const Points& targets) const {
  const BoundMesh& mesh = *mesh_;
  int best = -1;
  double nearest = std::numeric_limits<double>::infinity();
  for (int slot = 0; slot < mesh.user_constrained; ++slot) {
    const int v = mesh.constrained[slot];
    if (state.row(v) == targets.row(slot)) continue;
    for (int b : step.blocking) {
      if (b < 0) continue;
      const double d = b == v ? -1 : (mesh.rest.row(v) - mesh.rest.row(b)).squaredNorm();
      if (d < nearest) nearest = d, best = v;
    }
  }
  return best < 0 ? -1 : mesh.order[best];
}

void ContactSolve::finish(SolveStats& stats) {
  trial_out_of_time_ = nullptr;
  clear_ = active() && !deferred_;
  if (interrupted_) stats.converged = false;  // the handles are still on their way
  reached_ = stats.contact_reached;
  stopped_vertex_ = stats.contact_stopped_vertex;
  if (!active()) return;
  stats.contact_pairs = barrier_.active_pairs();
  stats.contact_lists = barrier_.lists_made() - lists_before_;
}

}  // namespace arap::contact
