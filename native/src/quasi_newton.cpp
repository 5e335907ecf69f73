// The quasi-Newton method (Liu et al. 2017): L-BFGS with the factored
// Laplacian as its first inverse Hessian, and a backtracking line search
// whose trial points the volume term and contact may return or cut.
#include <algorithm>
#include <cmath>

#include "local_step.h"
#include "runtime/vector_halves.h"
#include "solver_impl.h"

namespace arap {

namespace {

double dot(const std::vector<double>& a, const std::vector<double>& b, int threads) {
  return sum_over_halves(static_cast<std::ptrdiff_t>(a.size()), threads, [&](std::ptrdiff_t begin, std::ptrdiff_t end) {
    double sum = 0;
    for (std::ptrdiff_t k = begin; k < end; ++k) sum += a[k] * b[k];
    return sum;
  });
}

// s^T A s for s = the x, y, z of every free vertex (row-major, #free by 3) and A
// symmetric with both triangles stored: the squared A-norm of a step.
double squared_norm_in(const Eigen::SparseMatrix<double>& A, const double* s, int threads) {
  const int* outer = A.outerIndexPtr();
  const int* inner = A.innerIndexPtr();
  const double* value = A.valuePtr();
  const std::ptrdiff_t length = 3 * static_cast<std::ptrdiff_t>(A.cols());
  return sum_over_halves(length, threads, [&](std::ptrdiff_t begin, std::ptrdiff_t end) {
    double sum = 0;
    for (std::ptrdiff_t c = begin / 3; c < end / 3; ++c) {
      double ax = 0, ay = 0, az = 0;
      for (int p = outer[c]; p < outer[c + 1]; ++p) {
        const double* si = s + 3 * inner[p];
        ax += value[p] * si[0], ay += value[p] * si[1], az += value[p] * si[2];
      }
      sum += s[3 * c] * ax + s[3 * c + 1] * ay + s[3 * c + 2] * az;
    }
    return sum;
  });
}

// Pairs of (s, y) the quasi-Newton method remembers: beyond 4 a pair saves
// hardly an iteration, and each costs two passes over the free positions
// (iterations against pairs: docs/engine_internals.md).
constexpr int kQuasiNewtonHistory = 4;
// Armijo's sufficient-decrease constant and the most trial points per iteration.
constexpr double kArmijo = 1e-4;
constexpr int kLineSearchTrials = 3;
// The L-BFGS initial inverse Hessian is gamma L^-1, gamma set after each pair
// the history keeps. The energy's Hessian is L less what the turning rotations
// give back (with fixed rotations the half gradient is L p - b), so along a
// step s the Laplacian overrates the curvature by gamma = s.Ls / s.y (>= 1
// where no cell is inverted). As Nocedal & Wright scale H0 = gamma I by the
// last pair (eq. 7.20), we scale L^-1 by that quotient: of the two
// Barzilai-Borwein quotients in L's metric, the one that needs a product with
// L, not a solve. It is the larger of the two, so it is kept in [1, kMaxH0Scale]:
// unscaled or capped higher, the method needs more iterations than with a cap
// of 2 (docs/engine_internals.md). With no pair stored the step stays plain.
constexpr double kMaxH0Scale = 2.0;
// Halvings of a plain step that raised the energy (plain_step_may_rise()).
constexpr int kPlainBacktracks = 30;

}  // namespace

// Quasi-Newton state at the current point (rotations optimal): its free
// positions and half its gradient over them (dE/dp_f = 2 g).
void Solver::Impl::start_quasi_newton(SolveStats& stats) {
  const size_t nf3 = 3 * mesh.free_vertices.size();
  qn_x.resize(nf3), qn_g.resize(nf3), qn_d.resize(nf3);
  lbfgs.reset(kQuasiNewtonHistory, static_cast<Eigen::Index>(nf3));
  gather_free(qn_x);
  pose_stop.start(options.tolerance * pose_stop_scale);
  const auto t = Clock::now();
  half_gradient(mesh, state.data(), rotations.data(), qn_g.data(), options.threads);
  if (volume_term) volume_term->add_half_gradient(state.data(), qn_g.data());
  contact.step_from(state, mesh.free_row, qn_g.data());  // the pairs of the local() that came before
  stats.direction_ms += ms_since(t);
  if (volume_term) volume_term->constrain_gradient(state.data(), qn_g.data(), laplacian_solve(stats), stats);
}

// d = -L_ff^{-1} g: the local/global step from the current point. Returns 2 g.d.
double Solver::Impl::plain_direction(SolveStats& stats) {
  const auto t = Clock::now();
  for (size_t k = 0; k < qn_d.size(); ++k) qn_d[k] = -qn_g[k];
  laplacian.solve_in_place(qn_d.data(), work, options.threads);
  stats.linear_solve_ms += ms_since(t);
  if (volume_term) volume_term->project_direction(qn_d.data());
  return 2 * dot(qn_g, qn_d, options.threads);
}

// Energy at x + alpha d (its local step leaves the rotations for the next gradient).
// A trial whose energy would be refused when above `refused_above` may return
// any value above it (contact then skips the collision check, the costly part).
double Solver::Impl::trial(double alpha, SolveStats& stats, double refused_above) {
  for_each_half(static_cast<std::ptrdiff_t>(qn_x.size()), options.threads,
                [&](std::ptrdiff_t begin, std::ptrdiff_t end, int) {
                  for (std::ptrdiff_t r = begin / 3; r < end / 3; ++r) {
                    double* p = state.data() + 3 * mesh.free_vertices[r];
                    for (int c = 0; c < 3; ++c) p[c] = qn_x[3 * r + c] + alpha * qn_d[3 * r + c];
                  }
                });
  if (volume_term && !volume_term->retract(state.data(), stats)) return std::numeric_limits<double>::infinity();
  // Reached from qn_x in a straight line only if no watched pair comes within the gap on the way.
  return contact.limit(local_without_contact(stats), refused_above, state, stats);
}

// The L-BFGS direction from qn_x with the Laplacian as H0 into qn_d, or the
// plain local/global step when it does not descend (history dropped).
// Returns the slope dE/dalpha at alpha = 0 (negative). -slope / 2 is the
// decrease the quadratic model predicts for the step.
double Solver::Impl::quasi_newton_direction(SolveStats& stats) {
  const auto t = Clock::now();
  double solve_ms = 0;
  double slope = 2 * lbfgs.direction(
                         qn_g.data(), qn_d.data(),
                         [&](double* v) {
                           const auto ts = Clock::now();
                           laplacian.solve_in_place(v, work, options.threads);
                           solve_ms += ms_since(ts);
                         },
                         options.threads);
  stats.linear_solve_ms += solve_ms;
  stats.direction_ms += ms_since(t) - solve_ms;
  if (constrained()) {
    // Onto the tangent plane; dE/dalpha = 2 g.d there (= 2 g~.d: n.d = 0 and g - g~ is along n).
    volume_term->project_direction(qn_d.data());
    slope = 2 * dot(qn_g, qn_d, options.threads);
  }
  qn_plain = lbfgs.stored() == 0;
  if (!(slope < 0) && !qn_plain) {
    ++stats.quasi_newton_resets;
    lbfgs.clear();
    slope = plain_direction(stats);
    qn_plain = true;
  }
  return slope;
}

// The step along qn_d from qn_x (energy `energy`, half gradient qn_g): a
// backtracking line search on the Armijo condition and, when that fails,
// the plain local/global step (which always lowers the energy: the global
// step minimises the quadratic with the rotations fixed, the local step
// then lowers it further). Returns the new energy; `stuck` when not even
// that lowered it (a stationary point to rounding: the point is kept).
double Solver::Impl::quasi_newton_step(double energy, double slope, bool& stuck, SolveStats& stats) {
  stuck = false;
  double alpha = 1;
  const double next = line_search(energy, slope, alpha, stats);
  if (!(next <= energy)) {
    // Only at a stationary point to rounding: stay where we were.
    scatter_free(qn_x);
    local(stats);
    stuck = true;
    return energy;
  }
  accept_step(alpha, stats);
  return next;
}

// The trials along qn_d; returns the energy at the last, whose step is `alpha`.
double Solver::Impl::line_search(double energy, double slope, double& alpha, SolveStats& stats) {
  const bool plain = qn_plain;
  // What each trial must not exceed to be taken: the Armijo bound, or for the plain step a lower energy.
  auto bound = [&](double a) { return plain ? energy : energy + kArmijo * a * slope; };
  alpha = 1;
  double next = trial(alpha, stats, bound(alpha));
  for (int k = 1; k < kLineSearchTrials && !plain && !(next <= energy + kArmijo * alpha * slope); ++k) {
    // Minimum of the parabola through E(0), E'(0) and E(alpha), kept in [alpha / 10, alpha / 2].
    const double curvature = next - energy - slope * alpha;
    const double shorter = curvature > 0 ? -slope * alpha * alpha / (2 * curvature) : 0.5 * alpha;
    alpha = contact.limited_step(alpha, std::clamp(shorter, 0.1 * alpha, 0.5 * alpha));
    ++stats.line_search_steps;
    next = trial(alpha, stats, bound(alpha));
  }
  if (!plain && !(next <= energy + kArmijo * alpha * slope)) {
    ++stats.quasi_newton_resets;
    lbfgs.clear();
    plain_direction(stats);
    alpha = 1;
    next = trial(alpha, stats, energy);
  }
  for (int k = 0; plain_step_may_rise() && k < kPlainBacktracks && !(next <= energy); ++k) {
    alpha = contact.limited_step(alpha, 0.5 * alpha);
    ++stats.line_search_steps;
    next = trial(alpha, stats, energy);
  }
  return next;
}

// The trial point at alpha d accepted: s = alpha d, x += s, y = g_new - g,
// g = g_new, written straight into the history.
void Solver::Impl::accept_step(double alpha, SolveStats& stats) {
  auto t = Clock::now();
  double* s = lbfgs.next_s();
  double* y = lbfgs.next_y();
  half_gradient(mesh, state.data(), rotations.data(), y, options.threads);
  if (volume_term) volume_term->add_half_gradient(state.data(), y);
  contact.step_from(state, mesh.free_row, y);  // the pairs of the accepted trial
  if (constrained()) {
    // The step returned onto the constraint: s is where it landed, y the change of the Lagrangian gradient.
    stats.direction_ms += ms_since(t);
    volume_term->constrain_gradient(state.data(), y, laplacian_solve(stats), stats);
    t = Clock::now();
    for (size_t r = 0; r < mesh.free_vertices.size(); ++r)
      for (int c = 0; c < 3; ++c) qn_d[3 * r + c] = (state(mesh.free_vertices[r], c) - qn_x[3 * r + c]) / alpha;
  }
  double sums[2][3] = {{0, 0, 0}, {0, 0, 0}};  // s.y, s.s, y.y per half
  for_each_half(static_cast<std::ptrdiff_t>(qn_x.size()), options.threads,
                [&](std::ptrdiff_t begin, std::ptrdiff_t end, int half) {
                  double sy = 0, ss = 0, yy = 0;
                  for (std::ptrdiff_t k = begin; k < end; ++k) {
                    const double sk = alpha * qn_d[k], g_new = y[k], yk = g_new - qn_g[k];
                    s[k] = sk, y[k] = yk, qn_x[k] += sk, qn_g[k] = g_new;
                    sy += sk * yk, ss += sk * sk, yy += yk * yk;
                  }
                  sums[half][0] = sy, sums[half][1] = ss, sums[half][2] = yy;
                });
  const double sy = sums[0][0] + sums[1][0], ss = sums[0][1] + sums[1][1], yy = sums[0][2] + sums[1][2];
  if (pose_stop.on()) pose_stop.record(largest_row(s, static_cast<long>(mesh.free_vertices.size())));
  if (qn_history && lbfgs.commit(sy, ss, yy))
    lbfgs.set_h0_scale(std::clamp(squared_norm_in(mesh.laplacian_ff, s, options.threads) / sy, 1.0, kMaxH0Scale));
  if (constrained()) gather_free(qn_x);  // exactly where the step landed (x + s rounds)
  stats.direction_ms += ms_since(t);
}

// One iteration: the step, then the next direction, so that the stop can look
// at it: settled when this step lowered the energy by at most the tolerance and
// the next one is predicted to lower it by no more (a small step alone can be a
// short line-search step far from the minimum), and where the volume term asks
// for it, the pose is near its limit (pose_stop.h); or when contact says so.
double Solver::Impl::quasi_newton_iteration(double previous_energy, SolveStats& stats) {
  const double tolerance = options.tolerance;
  bool stuck = false;
  const long cut_before = stats.contact_steps_cut;
  const double e = quasi_newton_step(previous_energy, qn_slope, stuck, stats);
  qn_slope = quasi_newton_direction(stats);
  const bool small_step = previous_energy - e <= tolerance * std::abs(previous_energy);
  stats.converged = stuck || (small_step && -0.5 * qn_slope <= tolerance * std::abs(e) && pose_stop.settled());
  const bool settled = contact.after_iteration(stats.contact_steps_cut > cut_before, small_step);
  stats.converged = stats.converged || settled;
  return e;
}

// The first guess in `state` moved onto the volume constraint and, with
// contact, made reachable; then the quasi-Newton state there. Returns its energy.
double Solver::Impl::start_quasi_newton_from_guess(bool warm, SolveStats& stats,
                                                   const std::function<bool()>& out_of_time) {
  project_volume(stats);
  contact.reach_first_guess(warm, *this, stats, out_of_time);
  return start_quasi_newton_here(stats);
}

// The energy at `state` and the quasi-Newton state and first direction there.
double Solver::Impl::start_quasi_newton_here(SolveStats& stats) {
  const double e = local(stats);
  start_quasi_newton(stats);
  qn_slope = quasi_newton_direction(stats);
  return e;
}

double Solver::Impl::start_cold(InitialGuess guess, SolveStats& stats, const std::function<bool()>& out_of_time) {
  std::fill(eigenvalues.begin(), eigenvalues.end(), 0.0);  // as a cold start: no hint of the solve before
  apply_targets(targets, state);
  first_guess(guess);
  return start_quasi_newton_from_guess(false, stats, out_of_time);
}

// A few quasi-Newton iterations with the constrained vertices where they are.
void Solver::Impl::relax(int iterations, SolveStats& stats, const std::function<bool()>& out_of_time) {
  double e = local(stats);
  start_quasi_newton(stats);
  double slope = quasi_newton_direction(stats);
  for (int k = 0; k < iterations && !out_of_time(); ++k) {
    bool stuck = false;
    const double next = quasi_newton_step(e, slope, stuck, stats);
    if (stuck) break;
    slope = quasi_newton_direction(stats);
    e = next;
  }
}

void Solver::Impl::project_volume(SolveStats& stats) {
  if (volume_term) volume_term->project(state.data(), laplacian_solve(stats), stats);
}

VolumeTerm::LaplacianSolve Solver::Impl::laplacian_solve(SolveStats& stats) {
  return [this, &stats](double* v) {
    const auto t = Clock::now();
    laplacian.solve_in_place(v, work, options.threads);
    stats.linear_solve_ms += ms_since(t);
  };
}

}  // namespace arap
