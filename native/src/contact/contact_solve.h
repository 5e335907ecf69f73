// Self Contact's part of a solve (Options::contact == Contact::Self), one
// member of the solver: the barrier and the collision check of every trial
// point (self_contact.h), the way to a first guess the handles cannot reach in
// a straight line (rounds of handle_moves.h), the cold solve's first part
// without the barrier, and the stop pressed against a contact
// (docs/contact.md, "How"). The solver's line search asks it through a few
// hooks; it asks the solver back through SolverHooks.
#pragma once

#include <functional>
#include <limits>
#include <vector>

#include "arap/options.h"
#include "arap/solve_stats.h"
#include "arap/types.h"
#include "bound_mesh.h"
#include "contact/handle_moves.h"
#include "contact/self_contact.h"

namespace arap::contact {

// What the contact part asks of the solver it serves (positions in internal order and units).
class SolverHooks {
 public:
  virtual Points& current_state() = 0;
  virtual const Points& current_targets() const = 0;
  // The user's constrained vertices to `goal` (one row per slot), the free ones by the harmonic
  // extension of that move, L_ff d_f = sum_c w_fc d_c; `all_the_way`: goal is the targets.
  virtual void carry_constrained_to(const Points& goal, bool all_the_way) = 0;
  // The free vertices' sums over their constrained neighbours, for `state` as it is.
  virtual void couple_state() = 0;
  // The constrained vertices of `state` at their targets, and its sums anew.
  virtual void apply_targets_to_state() = 0;
  // `state` moved onto the volume constraint, when there is one.
  virtual void project_volume(SolveStats& stats) = 0;
  // A few quasi-Newton iterations with the constrained vertices where they are.
  virtual void relax(int iterations, SolveStats& stats, const std::function<bool()>& out_of_time) = 0;
  // The quasi-Newton state at `state`; returns its energy.
  virtual double start_quasi_newton_here(SolveStats& stats) = 0;
  // A cold start anew from `guess` (the targets applied), made reachable; returns its energy.
  virtual double start_cold(InitialGuess guess, SolveStats& stats, const std::function<bool()>& out_of_time) = 0;

 protected:
  ~SolverHooks() = default;
};

class ContactSolve {
 public:
  // The barrier's kappa is the mean of sum_j w_ij over the vertices, so that it weighs like the springs
  // around a vertex. `mesh` must outlive this object.
  void bind(const BoundMesh& mesh, const Triangles& triangles);
  bool active() const { return barrier_.active(); }
  // Whether the barrier and the collision checks take part in this iteration.
  bool on() const { return active() && !deferred_; }
  // 2 when a cold solve may run in two parts (each with the iteration cap), else 1.
  int parts() const { return active() ? 2 : 1; }
  // The barrier's energy at P (#n by 3), and its gradient added to `gradient` (every vertex), for
  // Solver::energy() and energy_gradient(): the solve's own state is left alone.
  double energy_at(const double* P) const { return SelfContact(barrier_).energy(P); }
  void add_gradient_at(const double* P, double* gradient) const;

  // A solve begins: `state` holds the last positions (before the first guess). `resume`: it continues the
  // last quasi-Newton solve; `cold_in_two_parts`: a cold quasi-Newton solve that runs without the
  // barrier first (finish_contact_free_part()).
  void start(InitialGuess guess, bool resume, bool cold_in_two_parts, int threads, const Points& state,
             const Points& targets);
  // A trial's collision check may stop at the time budget (`out_of_time`) when the solve warm-started.
  void allow_checks_to_stop(const std::function<bool()>* out_of_time, bool time_budget);
  // A resumed solve: the handles stay where the last solve stopped them.
  void resume(SolverHooks& solver, SolveStats& stats);
  // Makes the first guess in the solver's state reachable from the clear state the solve started from
  // (warm: the pose on screen). When a pair stands in the straight way, the handles move in rounds.
  void reach_first_guess(bool warm, SolverHooks& solver, SolveStats& stats, const std::function<bool()>& out_of_time);

  // The hooks below do nothing (add nothing) while on() is false.
  // A point steps start from (the start of an iteration, an accepted trial): g += the barrier's half
  // gradient on the free rows, for the pairs of its last evaluation.
  void step_from(const Points& state, const std::vector<int>& free_row, double* g);
  // The barrier energy at `state`.
  double energy(const Points& state, SolveStats& stats);
  // The energy of a trial point `trial`, reached from the last step_from() point in a straight line,
  // whose surface energy is `surface`: +inf when a pair would come within the gap on the way (the
  // step is then limited to limited_step()), `surface` alone when above `refused_above` (a trial that
  // would be refused above it may return any value above it).
  double limit(double surface, double refused_above, const Points& trial, SolveStats& stats);
  // The next, shorter trial step after `alpha` failed: cut to the safe share when a pair stopped it,
  // else `fallback`.
  double limited_step(double alpha, double fallback) const {
    return on() && fraction_ < 1 ? kBackoff * fraction_ * alpha : fallback;
  }
  // After each quasi-Newton iteration: settled when steps cut at a contact lowered the energy by at most
  // the tolerance (`small_step`) a few times in a row.
  bool after_iteration(bool steps_cut, bool small_step);
  // The end of the part without the barrier (`done`: it settled or reached the cap), after `iterations`.
  // Returns whether the solve goes on with contact, `energy` then the energy of its start.
  bool finish_contact_free_part(bool done, int iterations, SolverHooks& solver, SolveStats& stats,
                                const std::function<bool()>& out_of_time, double& energy);
  // The solve ended well (a solve that throws calls allow_checks_to_stop(nullptr, false) only).
  void finish(SolveStats& stats);
  // The solve stopped while still without the barrier: its pose may cross and is not shown.
  bool unchecked() const { return deferred_; }
  // The handles were still on their way when the solve stopped.
  bool interrupted() const { return interrupted_; }
  // The positions were set from outside: checked at the next solve.
  void positions_set() { clear_ = false; }

 private:
  // A trial point that a pair would reach is cut back to this share of the safe part of the step (the
  // collision check is conservative already; the margin keeps the next step from starting at the gap).
  static constexpr double kBackoff = 0.9;

  bool clear(const Points& state, SolveStats& stats, double* barrier = nullptr);
  void carry_targets_through(double share, SolverHooks& solver, SolveStats& stats);
  void move_in_rounds(SolverHooks& solver, SolveStats& stats, const std::function<bool()>& out_of_time);
  int stopping_vertex(const SelfContact::Step& step, const Points& state, const Points& targets) const;

  SelfContact barrier_;
  HandleMoves handle_moves_;  // where the constrained vertices go in each round of a forced pose
  const BoundMesh* mesh_ = nullptr;
  // from_: the state trial points are reached from (all rows); goal_: a round's end before its check.
  Points from_, goal_;
  Points round_goal_;    // a round's positions of the user's constrained vertices
  bool clear_ = false;   // the state is one a step may start from (a solve left it so)
  double fraction_ = 1;  // the safe share of the last trial's step (1: the trial was not cut)
  // A solve that warm-starts from a pose on screen (Live, Auto mode's previews), and the chunks that
  // resume it, may stop a trial's collision check at the time budget, between the pieces of a long
  // step: the trial is then cut to the share checked (trial_out_of_time_, during its iterations).
  bool checks_may_stop_ = false;
  const std::function<bool()>* trial_out_of_time_ = nullptr;
  // Rounds toward the same targets that gained almost nothing, counted across
  // solves (a viewport's chunks), and how far the last solve's handles came.
  Points round_targets_;
  int stalled_rounds_ = 0;
  double reached_ = 1;
  int stopped_vertex_ = -1;
  int settling_ = 0;  // iterations in a row whose step was cut and lowered the energy by at most the tolerance
  // A cold solve with contact first runs without the barrier; while it does, deferred_ (and the start it
  // came from, deferred_guess_). Its result, when clear, is where the solve with contact starts.
  bool deferred_ = false;
  InitialGuess deferred_guess_ = InitialGuess::Naive;
  bool interrupted_ = false;
  long lists_before_ = 0;
};

}  // namespace arap::contact
