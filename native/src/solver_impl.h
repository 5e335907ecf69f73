// The solver's state and its iteration (arap/solver.h is the front door).
// The features live in rooms behind narrow hooks: the volume in one
// VolumeTerm (volume/volume_term.h), Self Contact in one ContactSolve
// (contact/contact_solve.h). Defined in solver.cpp (the solve's course),
// solver_bind.cpp, iteration.cpp (local/global steps, first guesses) and
// quasi_newton.cpp (the L-BFGS direction and its line search).
#pragma once

#include <functional>
#include <limits>
#include <memory>
#include <vector>

#include "anderson.h"
#include "arap/solver.h"
#include "bound_mesh.h"
#include "contact/contact_solve.h"
#include "initial_guess.h"
#include "lbfgs.h"
#include "linalg/spd_solve.h"
#include "pose_stop.h"
#include "runtime/stopwatch.h"
#include "volume/volume_term.h"

namespace arap {

struct Solver::Impl final : contact::SolverHooks {
  Options options;
  Weights bound_weights = Weights::CotanClamped;
  Volume bound_volume = Volume::None;
  int bound_infill_resolution = 0;
  Contact bound_contact = Contact::None;
  BoundMesh mesh;
  Triangles triangles;
  std::vector<int> constrained_input;  // as given to bind()
  BlockCholesky laplacian;
  DifferentialGuess differential;
  BindStats bind_stats;
  bool bound = false;
  bool has_solution = false;     // positions hold a solve() result (warm start possible)
  bool rotations_valid = false;  // rotations are optimal for `positions`
  double unit = 1.0;             // internal coordinates = input / unit (see unit_scale.h)
  double last_energy = 0.0;      // energy of the last solution (internal units)

  Points state;      // the current solution in internal vertex order and units (see bound_mesh.h)
  Points given_start;        // start_from()'s shape (internal order and units) ...
  bool start_given = false;  // ... which the next cold solve starts from
  Points targets;    // the last targets in internal units
  Points positions;  // the same in input order, as returned by positions()
  Points state_backup;
  std::vector<Eigen::Matrix3d> rotations;
  std::vector<double> cell_energy, coupled, rhs, work;
  std::vector<double> eigenvalues;  // per cell, warm start of the rotation fit
  AndersonAccelerator anderson;
  std::vector<double> free_before, free_after, free_next;  // #free by 3 each, for Anderson
  LbfgsHistory lbfgs;
  std::vector<double> qn_x, qn_g, qn_d;  // #free by 3 each, for the quasi-Newton method
  // The last solve was quasi-Newton and nothing touched its state since: a warm
  // solve with the same targets continues from qn_x, qn_g, qn_d, qn_energy and the history.
  bool qn_resumable = false;
  double qn_energy = 0;
  bool qn_plain = false;   // qn_d is the plain step
  double qn_slope = 0;     // dE/dalpha along qn_d, the direction of the next step
  bool qn_history = true;  // false: local/global on the quasi-Newton path, without history
  Points last_targets;
  // What keeps the volume (null: nothing), on the quasi-Newton path; qn_g then holds its gradient
  // (a constraint's: the Lagrangian's).
  std::unique_ptr<VolumeTerm> volume_term;
  contact::ContactSolve contact;
  // The stop on the pose, where the volume term asks for it: its distance per unit of
  // Options::tolerance (internal units; 0: off), from the rest shape's bounding-box diagonal.
  PoseStop pose_stop;
  double pose_stop_scale = 0;

  // The volume terms and contact run on the quasi-Newton path (local/global: without its history).
  bool runs_quasi_newton() const {
    return options.method == Method::QuasiNewton ||
           ((volume_term || contact.active()) && options.method == Method::LocalGlobal);
  }
  // The iterates stay on a constraint set.
  bool constrained() const { return volume_term && volume_term->constrains(); }
  // Whether a warm start carries the handles' move by a global step on the last rotations, or
  // (where the volume term refuses that step) by the harmonic extension before the iterations start.
  bool warm_start_by_global_step() const { return !volume_term || volume_term->warm_global_step(); }
  // The plain step can raise the energy: where the volume term says so (volume_term.h), and
  // the global step does not see the contact barrier. A shorter step then does not.
  bool plain_step_may_rise() const { return (volume_term && volume_term->plain_step_may_rise()) || contact.on(); }
  VolumeTerm::LaplacianSolve laplacian_solve(SolveStats& stats);

  void gather_free(std::vector<double>& out) const;
  void scatter_free(const std::vector<double>& in);

  // The course of a solve (solver.cpp).
  void check_solve_input(const Eigen::Ref<const Points>& targets_given);
  InitialGuess prepare_first_guess(const Eigen::Ref<const Points>& targets_given, bool quasi_newton, bool& resume,
                                   bool& reuse_rotations);
  double start_iterating(InitialGuess guess, bool resume, bool reuse_rotations, bool quasi_newton, SolveStats& stats,
                         const std::function<bool()>& out_of_time);
  double iteration(bool quasi_newton, double previous_energy, SolveStats& stats);
  void end_iterating(SolveStats& stats, double previous_energy);
  void keep_solution(const Eigen::Ref<const Points>& targets_given, SolveStats& stats);

  // Local/global steps and first guesses (iteration.cpp).
  double iterate(double previous_energy, SolveStats& stats);
  void global_step(SolveStats& stats);
  double local(SolveStats& stats);
  double local_without_contact(SolveStats& stats);
  void apply_targets(const Eigen::Ref<const Points>& targets_now, Points& P);
  void couple(const Points& P);
  void first_guess(InitialGuess guess);

  // The quasi-Newton method (quasi_newton.cpp).
  void start_quasi_newton(SolveStats& stats);
  double plain_direction(SolveStats& stats);
  double trial(double alpha, SolveStats& stats, double refused_above = std::numeric_limits<double>::infinity());
  double quasi_newton_direction(SolveStats& stats);
  double quasi_newton_step(double energy, double slope, bool& stuck, SolveStats& stats);
  double line_search(double energy, double slope, double& alpha, SolveStats& stats);
  void accept_step(double alpha, SolveStats& stats);
  double quasi_newton_iteration(double previous_energy, SolveStats& stats);
  double start_quasi_newton_from_guess(bool warm, SolveStats& stats, const std::function<bool()>& out_of_time);

  // contact::SolverHooks.
  Points& current_state() override { return state; }
  const Points& current_targets() const override { return targets; }
  void carry_constrained_to(const Points& goal, bool all_the_way) override;
  void couple_state() override { couple(state); }
  void apply_targets_to_state() override { apply_targets(targets, state); }
  void project_volume(SolveStats& stats) override;
  void relax(int iterations, SolveStats& stats, const std::function<bool()>& out_of_time) override;
  double start_quasi_newton_here(SolveStats& stats) override;
  double start_cold(InitialGuess guess, SolveStats& stats, const std::function<bool()>& out_of_time) override;
};

}  // namespace arap
