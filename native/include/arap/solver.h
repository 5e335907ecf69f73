// As-Rigid-As-Possible surface deformation (Sorkine & Alexa 2007).
//
// Bind once per mesh and constraint set (weights, Laplacian, sparse Cholesky
// of its free block), then solve many times with new target positions for
// the constrained vertices. Each Solver owns all of its state: separate
// instances may be used from separate threads.
#pragma once

#include <memory>
#include <vector>

#include "arap/errors.h"
#include "arap/mesh_check.h"
#include "arap/options.h"
#include "arap/solve_stats.h"
#include "arap/types.h"

namespace arap {

class SolveWorker;

class Solver {
 public:
  Solver();
  ~Solver();
  Solver(Solver&&) noexcept;
  Solver& operator=(Solver&&) noexcept;
  Solver(const Solver&) = delete;
  Solver& operator=(const Solver&) = delete;

  // rest: #V by 3 rest positions; triangles: #F by 3; constrained: indices of
  // the vertices whose positions solve() receives (fixed and handles alike,
  // no duplicates). stiffness (optional, #V values > 0, default all 1) scales
  // each cell's term of the energy: E = sum_i s_i sum_j w_ij |e'_ij - R_i e_ij|^2,
  // so a region with larger s bends less. Throws arap::Error on bad input.
  void bind(const Eigen::Ref<const Points>& rest, const Eigen::Ref<const Triangles>& triangles,
            const std::vector<int>& constrained, const Options& options = Options(),
            const std::vector<double>& stiffness = {});

  // targets: #constrained by 3, in the order given to bind(). Runs
  // options().method from options().init until the energy falls by at most
  // options().tolerance relative in an iteration (stats.converged) or
  // options().max_iterations is reached, and leaves the result in positions().
  // The energy never increases from one iteration to the next. A warm start
  // (options().init == WarmStart) with the same targets as the last solve
  // resumes the quasi-Newton iteration where that solve stopped (history
  // included), so a solve cut short by time_budget_ms loses nothing. Never leaves NaN in positions(): on a non-finite
  // target it throws before touching them.
  SolveStats solve(const Eigen::Ref<const Points>& targets);

  // The current solution (#V by 3); the rest shape right after bind().
  const Points& positions() const;
  // Replace the warm-start state (e.g. to resume a bake from a stored frame).
  void set_positions(const Eigen::Ref<const Points>& positions);
  // Forget the last solution: the next solve() starts cold (options().cold_start when its init is
  // WarmStart), as the first one after bind() does, so its result depends on its targets and
  // options alone, bit for bit, whatever was solved before. Solves after it resume it as usual.
  void forget_solution();
  // forget_solution(), then the next solve() starts from `positions` (#V by 3, input order) instead of
  // options().init's first guess, the constrained vertices at their targets (Infill's lattice nodes at
  // rest, as the Naive guess has them): a cold start from a given shape, whose result depends on the
  // targets, options and `positions` alone. For a shape that is already near the pose (a rig's skinned
  // pose).
  void start_from(const Eigen::Ref<const Points>& positions);

  // For a solve() running on another thread (thread-safe): while set, solve() returns after the
  // iteration in progress, as when its time budget runs out (stats.converged false). solve() never
  // clears it.
  void set_stop_requested(bool stop);
  // The solve() in progress (or the last one): iterations done and the latest energy; thread-safe.
  SolveProgress progress() const;
  // True while a SolveWorker owns this solver: nothing else may call it then.
  bool busy() const;

  // Settings that need no re-bind (iterations, tolerance, init, threads, anderson).
  // Changing `weights` here throws at the next solve(): bind again instead.
  Options& options();
  const Options& options() const;

  bool is_bound() const;
  int vertex_count() const;
  const std::vector<int>& constrained() const;
  const MeshReport& mesh_report() const;
  const BindStats& bind_stats() const;
  // Nonzeros of the Cholesky factor of the free block (memory and solve cost follow it);
  // the supernodal factorization drops the explicit zeros its merged supernodes held.
  long factor_nonzeros() const;

  // ARAP energy of `positions` with the optimal rotation of every cell and the
  // weights in use: sum_i s_i sum_j w_ij |(p'_i - p'_j) - R_i (p_i - p_j)|^2.
  double energy(const Eigen::Ref<const Points>& positions) const;
  // Its gradient with respect to every vertex position (#V by 3); throws
  // arap::Error(NonFinite) when that is beyond the double range (coordinates near 1e308):
  // dE/dp'_i = 2 sum_j w_ij (s_i + s_j)(p'_i - p'_j) - 2 sum_j w_ij (s_i R_i + s_j R_j)(p_i - p_j).
  Points energy_gradient(const Eigen::Ref<const Points>& positions) const;

 private:
  // For SolveWorker: take the solver (false when another worker has it), give it back.
  bool claim();
  void release();

  struct Impl;
  struct Shared;   // what other threads may read or set: the stop request, the progress, busy
  std::unique_ptr<Impl> impl_;
  std::unique_ptr<Shared> shared_;
  friend class SolveWorker;
};

}  // namespace arap
