// What bind() and solve() report about themselves: timings, energies,
// iteration counts (Solver::bind_stats(), Solver::solve(), Solver::progress()).
#pragma once

#include <vector>

namespace arap {

struct SolveStats {
  double initial_energy = 0;          // energy of the first guess
  std::vector<double> energy;         // ARAP energy after each iteration (optimal rotations)
  std::vector<double> iteration_ms;   // wall time of each iteration
  double init_ms = 0;                 // first guess
  double rotation_ms = 0;             // local steps (covariance + rotation fit), all iterations
  double rhs_ms = 0;                  // right-hand side assembly, all iterations
  double linear_solve_ms = 0;         // triangular solves, all iterations
  int iterations = 0;
  bool converged = false;             // stopped on the tolerance, not the budget
  long rotation_fallbacks = 0;        // 3x3 fits that needed the full SVD
  long anderson_rejections = 0;       // accelerated steps refused by the energy safeguard
  double direction_ms = 0;            // quasi-Newton: gradients and the L-BFGS two-loop, all iterations
  long line_search_steps = 0;         // quasi-Newton: trial points beyond the first of each iteration
  long quasi_newton_resets = 0;       // quasi-Newton: directions refused (history dropped, plain step taken)
  double volume_ms = 0;               // Volume::Global: volume gradients and returns onto the constraint
  double volume_drift = 0;            // Volume::Global: largest |V / V_rest - 1| of a kept component at the end
  double contact_ms = 0;              // Contact::Self: pair search, barrier and collision checks
  long contact_pairs = 0;             // Contact::Self: pairs within the barrier's reach at the end
  long contact_lists = 0;             // Contact::Self: times the list of near pairs was made (a search of the mesh)
  long contact_steps_cut = 0;         // Contact::Self: trial points refused because a pair would come too close
  long contact_checks_stopped = 0;    // Contact::Self: trial points cut to the share checked within the time budget
  int contact_rounds = 0;             // Contact::Self: rounds that moved the handles part of the way (0: none needed)
  // Contact::Self: a cold solve first runs without the barrier, for this many of `iterations` (energy[0,
  // this) are theirs). Its pose is kept when it crosses nothing and no pair is within the barrier's reach;
  // else the solve with contact goes on from it (no crossing) or from the usual first guess, and the
  // energy can rise there, where the barrier comes in. Each part has the iteration cap.
  int contact_free_iterations = 0;
  // Contact::Self: the share of their moves the constrained vertices made (1 = their targets are met). Below 1
  // when reaching the targets would make the surface cross itself: the pose stops short at contact, and
  // contact_stopped_vertex is a constrained vertex (input index) of the pair that stopped it.
  double contact_reached = 1;
  int contact_stopped_vertex = -1;
};

// How far the solve() in progress has come (Solver::progress(), readable from another thread).
struct SolveProgress {
  int iterations = 0;    // iterations done so far
  double energy = 0;     // the energy after the last of them (the first guess's before the first)
};

struct BindStats {
  double total_ms = 0;
  double mesh_ms = 0;      // checks, weights, components, vertex order, Laplacian assembly
  double ordering_ms = 0;  // fill-reducing ordering (AMD; nested dissection too for the largest) and permutation
  double factor_ms = 0;    // numeric Cholesky factorization
};

}  // namespace arap
