#include "arap/solver.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <new>
#include <string>

#include "anderson.h"
#include "bound_mesh.h"
#include "contact/handle_moves.h"
#include "contact/self_contact.h"
#include "initial_guess.h"
#include "lbfgs.h"
#include "linalg/spd_solve.h"
#include "local_step.h"
#include "runtime/memory_headroom.h"
#include "runtime/prefault.h"
#include "runtime/vector_halves.h"
#include "unit_scale.h"
#include "volume/infill.h"
#include "volume/infill_volume.h"
#include "volume/volume.h"

namespace arap {

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

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
// What a bind allocates per vertex (lattice nodes included), measured on
// spheres and bars of 100k-1M vertices (docs/robustness.md, "Memory"): the
// mesh's structures (weights, spokes, the Laplacian) at their peak, and the
// solver's state made after the factorization; the factorization's own bytes
// come from its column counts (spd_solve.h).
constexpr double kMeshBytesPerVertex = 600;
constexpr double kStateBytesPerVertex = 128;

// Refuses (arap::Error OutOfMemory) before a bind allocates what would not fit
// (runtime/memory_headroom.h): the previous binding is kept.
void require_bind_memory(Eigen::Index vertices, double bytes_per_vertex, const char* part, double more_bytes = 0) {
  require_headroom(static_cast<double>(vertices) * bytes_per_vertex + more_bytes,
                   "binding " + std::to_string(vertices) + " vertices (" + part + ")");
}

// The barrier's kappa: the mean of sum_j w_ij over the mesh's vertices, so that
// the barrier weighs like the springs around a vertex.
double contact_stiffness(const BoundMesh& m) {
  double sum = 0;
  for (int v = 0; v < m.input_n; ++v)
    for (int k = m.spoke_begin[v]; k < m.spoke_begin[v + 1]; ++k) sum += m.spokes[k].w;
  return m.input_n > 0 && sum > 0 ? sum / m.input_n : 1.0;
}

// Volume::Global: halvings of a plain step whose return onto the volume
// constraint raised the energy (the step itself lowers it to first order).
constexpr int kVolumeBacktracks = 30;

// Contact::Self (contact/self_contact.h). A trial point that a pair would reach
// is cut back to this share of the safe part of the step (the collision check
// is conservative already; the margin keeps the next step from starting at the gap).
constexpr double kContactBackoff = 0.9;
// Handles whose targets the first guess cannot reach without a crossing move
// in rounds of at most kContactLoadStep of their move (the rest of the mesh
// carried harmonically), each checked on the way and followed by
// kContactRelaxIterations; at most kContactMaxRounds rounds, stopped short
// after kContactStallRounds rounds in a row that gain less than
// kContactStallGain of the move. Handles that are truly blocked gain
// geometrically less from round to round (about a quarter each time), while
// handles that slide past an obstacle gain a steady small share (0.05-0.1%):
// the threshold lies well below the latter.
constexpr int kContactMaxRounds = 200;
constexpr double kContactLoadStep = 0.125;
constexpr int kContactRelaxIterations = 10;
constexpr int kContactStallRounds = 8;
constexpr double kContactStallGain = 1e-4;
// Steps cut at a contact that lower the energy by at most the tolerance, in a row: the pose has settled.
constexpr int kContactSettledSteps = 3;

}  // namespace

struct Solver::Impl {
  Options options;
  Weights bound_weights = Weights::CotanClamped;
  Volume bound_volume = Volume::None;
  int bound_infill_resolution = 0;
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
  LbfgsHistory lbfgs;
  std::vector<double> qn_x, qn_g, qn_d;  // #free by 3 each, for the quasi-Newton method
  // The last solve was quasi-Newton and nothing touched its state since: a warm
  // solve with the same targets continues from qn_x, qn_g, qn_d, qn_energy and the history.
  bool qn_resumable = false;
  double qn_energy = 0;
  bool qn_plain = false;  // qn_d is the plain step
  double qn_slope = 0;    // dE/dalpha along qn_d, the direction of the next step
  Points last_targets;
  // Volume::Global (see volume/volume.h): the constraint, and at qn_x its gradient n
  // and u = L^-1 n (#free by 3 each); the quasi-Newton path then keeps the
  // Lagrangian gradient in qn_g. Local/global runs on that path too, without history.
  VolumeConstraint volume;
  std::vector<double> qn_n, qn_u;
  // Volume::Infill's bulk term (see volume/infill_volume.h), on the same path.
  LatticeBulk bulk;
  bool qn_history = true;
  // Contact::Self: the barrier and collision checks; contact_from is the state
  // the trial points are reached from (qn_x's, all rows); contact_clear: the
  // state is one a step may start from (a solve left it so).
  contact::SelfContact contact;
  Contact bound_contact = Contact::None;
  Points contact_from, contact_goal;
  contact::HandleMoves handle_moves;  // where the constrained vertices go in each round of a forced pose
  Points round_goal;                  // that round's positions of the user's constrained vertices
  bool contact_clear = false;
  double contact_fraction = 1;  // the safe share of the last trial's step (1: the trial was not cut)
  // A solve that warm-starts from a pose on screen (Live, Auto mode's previews), and the chunks that
  // resume it, may stop a trial's collision check at the time budget, between the pieces of a long
  // step: the trial is then cut to the share checked (trial_out_of_time, during its iterations).
  bool contact_checks_may_stop = false;
  const std::function<bool()>* trial_out_of_time = nullptr;
  // Rounds toward the same targets that gained almost nothing, counted across
  // solves (a viewport's chunks), and how far the last solve's handles came.
  Points contact_round_targets;
  int contact_stalled_rounds = 0;
  double contact_reached = 1;
  int contact_stopped_vertex = -1;
  int contact_settling = 0;  // iterations in a row whose step was cut and lowered the energy by at most the tolerance
  // A cold solve with contact first runs without the barrier; while it does,
  // contact_deferred (and the start it came from, contact_deferred_guess).
  // Its result, when clear, is where the solve with contact starts (see
  // contact_free_part_done()); chunks of it are resumed like any solve's.
  bool contact_deferred = false;
  InitialGuess contact_deferred_guess = InitialGuess::Naive;

  // The volume terms and contact run on the quasi-Newton path (local/global: without its history), see
  // volume/volume.h.
  bool runs_quasi_newton() const {
    return options.method == Method::QuasiNewton ||
           ((volume.active() || bulk.active() || contact.active()) && options.method == Method::LocalGlobal);
  }

  // Whether the barrier and the collision checks take part in this iteration.
  bool contact_on() const { return contact.active() && !contact_deferred; }

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

  // Quasi-Newton state at the current point (rotations optimal): its free
  // positions and half its gradient over them (dE/dp_f = 2 g).
  void start_quasi_newton(SolveStats& stats) {
    const size_t nf3 = 3 * mesh.free_vertices.size();
    qn_x.resize(nf3), qn_g.resize(nf3), qn_d.resize(nf3);
    lbfgs.reset(kQuasiNewtonHistory, static_cast<Eigen::Index>(nf3));
    gather_free(qn_x);
    const auto t = Clock::now();
    half_gradient(mesh, state.data(), rotations.data(), qn_g.data(), options.threads);
    if (bulk.active()) bulk.add_half_gradient(state.data(), qn_g.data());
    if (contact_on()) {
      contact.add_half_gradient(mesh.free_row, qn_g.data());  // the pairs of the local() that came before
      contact_from = state;
    }
    stats.direction_ms += ms_since(t);
    if (volume.active()) {
      volume_normal(stats);
      volume.lagrangian_gradient(qn_g.data(), qn_n.data(), qn_u.data());
    }
  }

  // Volume::Global: n = dV/dp and u = L^-1 n at the current positions.
  void volume_normal(SolveStats& stats) {
    auto t = Clock::now();
    volume.gradient(state.data(), qn_n.data());
    std::copy(qn_n.begin(), qn_n.end(), qn_u.begin());
    stats.volume_ms += ms_since(t);
    t = Clock::now();
    laplacian.solve_in_place(qn_u.data(), work, options.threads);
    stats.linear_solve_ms += ms_since(t);
    t = Clock::now();
    volume.set_normal(qn_n.data(), qn_u.data());
    stats.volume_ms += ms_since(t);
  }

  // Volume::Global: the current positions moved onto the volume constraint
  // along u (a first guess, or a warm start whose targets moved).
  void project_volume(SolveStats& stats) {
    volume_normal(stats);
    const auto t = Clock::now();
    volume.retract(state.data(), qn_u.data());  // no root within reach: the next trial points return instead
    stats.volume_ms += ms_since(t);
  }

  // d = -L_ff^{-1} g: the local/global step from the current point. Returns 2 g.d.
  double plain_direction(SolveStats& stats) {
    const auto t = Clock::now();
    for (size_t k = 0; k < qn_d.size(); ++k) qn_d[k] = -qn_g[k];
    laplacian.solve_in_place(qn_d.data(), work, options.threads);
    stats.linear_solve_ms += ms_since(t);
    // With the volume kept, -L^-1 g~ is tangent already (u.g~ = 0): this only removes rounding.
    if (volume.active()) volume.project_tangent(qn_d.data(), qn_n.data(), qn_u.data());
    return 2 * dot(qn_g, qn_d, options.threads);
  }

  // Energy at x + alpha d (its local step leaves the rotations for the next gradient).
  // A trial whose energy would be refused when above `refused_above` may return
  // any value above it: with contact, one whose surface energy alone is that
  // high (the barrier only adds) skips the collision check, the costly part.
  double trial(double alpha, SolveStats& stats,
               double refused_above = std::numeric_limits<double>::infinity()) {
    for_each_half(static_cast<std::ptrdiff_t>(qn_x.size()), options.threads,
                  [&](std::ptrdiff_t begin, std::ptrdiff_t end, int) {
                    for (std::ptrdiff_t r = begin / 3; r < end / 3; ++r) {
                      double* p = state.data() + 3 * mesh.free_vertices[r];
                      for (int c = 0; c < 3; ++c) p[c] = qn_x[3 * r + c] + alpha * qn_d[3 * r + c];
                    }
                  });
    if (volume.active()) {
      const auto t = Clock::now();
      const bool on_constraint = volume.retract(state.data(), qn_u.data());
      stats.volume_ms += ms_since(t);
      if (!on_constraint) return std::numeric_limits<double>::infinity();
    }
    if (!contact_on()) return local(stats);
    contact_fraction = 1;
    const double surface = local_without_contact(stats);
    if (!(surface <= refused_above)) return surface;
    // Reached from qn_x in a straight line only if no watched pair comes within the gap on the way.
    const auto t = Clock::now();
    const contact::SelfContact::Step step =
        contact.evaluate(contact_from.data(), state.data(), contact::SelfContact::ListAt::End, trial_out_of_time);
    stats.contact_ms += ms_since(t);
    contact_fraction = step.fraction;
    if (step.fraction < 1) {
      ++(step.out_of_time ? stats.contact_checks_stopped : stats.contact_steps_cut);
      return std::numeric_limits<double>::infinity();
    }
    return surface + step.energy;
  }

  // The next, shorter trial step after `alpha` failed: cut to the safe share
  // when a pair stopped it, else `fallback`.
  double shorter_step(double alpha, double fallback) const {
    if (contact_on() && contact_fraction < 1) return kContactBackoff * contact_fraction * alpha;
    return fallback;
  }

  // The L-BFGS direction from qn_x with the Laplacian as H0 into qn_d, or the
  // plain local/global step when it does not descend (history dropped).
  // Returns the slope dE/dalpha at alpha = 0 (negative). -slope / 2 is the
  // decrease the quadratic model predicts for the step.
  double quasi_newton_direction(SolveStats& stats) {
    const auto t = Clock::now();
    double solve_ms = 0;
    double slope = 2 * lbfgs.direction(qn_g.data(), qn_d.data(), [&](double* v) {
      const auto ts = Clock::now();
      laplacian.solve_in_place(v, work, options.threads);
      solve_ms += ms_since(ts);
    }, options.threads);
    stats.linear_solve_ms += solve_ms;
    stats.direction_ms += ms_since(t) - solve_ms;
    if (volume.active()) {
      // Onto the tangent plane; dE/dalpha = 2 g.d there (= 2 g~.d: n.d = 0 and g - g~ is along n).
      volume.project_tangent(qn_d.data(), qn_n.data(), qn_u.data());
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
  double quasi_newton_step(double energy, double slope, bool& stuck, SolveStats& stats) {
    stuck = false;
    bool plain = qn_plain;
    // What each trial must not exceed to be taken: the Armijo bound, or for the plain step a lower energy.
    auto bound = [&](double a) { return plain ? energy : energy + kArmijo * a * slope; };
    double alpha = 1, next = trial(alpha, stats, bound(alpha));
    for (int k = 1; k < kLineSearchTrials && !plain && !(next <= energy + kArmijo * alpha * slope); ++k) {
      // Minimum of the parabola through E(0), E'(0) and E(alpha), kept in [alpha / 10, alpha / 2].
      const double curvature = next - energy - slope * alpha;
      const double shorter = curvature > 0 ? -slope * alpha * alpha / (2 * curvature) : 0.5 * alpha;
      alpha = shorter_step(alpha, std::clamp(shorter, 0.1 * alpha, 0.5 * alpha));
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
    // The plain step lowers the energy on the tangent plane; its return onto the
    // volume constraint is of second order in the step: a shorter step always does.
    // With contact, the global step does not see the barrier: a shorter step does too.
    for (int k = 0; (volume.active() || contact_on()) && k < kVolumeBacktracks && !(next <= energy); ++k) {
      alpha = shorter_step(alpha, 0.5 * alpha);
      ++stats.line_search_steps;
      next = trial(alpha, stats, energy);
    }
    if (!(next <= energy)) {
      // Only at a stationary point to rounding: stay where we were.
      scatter_free(qn_x);
      local(stats);
      stuck = true;
      return energy;
    }
    // Accepted: s = alpha d, x += s, y = g_new - g, g = g_new, written straight into the history.
    auto t = Clock::now();
    double* s = lbfgs.next_s();
    double* y = lbfgs.next_y();
    half_gradient(mesh, state.data(), rotations.data(), y, options.threads);
    if (bulk.active()) bulk.add_half_gradient(state.data(), y);
    if (contact_on()) {
      contact.add_half_gradient(mesh.free_row, y);  // the pairs of the accepted trial
      contact_from = state;
    }
    if (volume.active()) {
      // The step returned onto the constraint: s is where it landed, y the change of the Lagrangian gradient.
      stats.direction_ms += ms_since(t);
      volume_normal(stats);
      volume.lagrangian_gradient(y, qn_n.data(), qn_u.data());
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
    if (qn_history && lbfgs.commit(sy, ss, yy))
      lbfgs.set_h0_scale(std::clamp(squared_norm_in(mesh.laplacian_ff, s, options.threads) / sy, 1.0, kMaxH0Scale));
    if (volume.active()) gather_free(qn_x);  // exactly where the step landed (x + s rounds)
    stats.direction_ms += ms_since(t);
    return next;
  }

  // Writes the constrained positions into P and sum_j w_ij p_j into `coupled`.
  void apply_targets(const Eigen::Ref<const Points>& targets, Points& P) {
    for (int s = 0; s < mesh.user_constrained; ++s) P.row(mesh.constrained[s]) = targets.row(s);
    for (size_t s = mesh.user_constrained; s < mesh.constrained.size(); ++s)
      P.row(mesh.constrained[s]) = mesh.rest.row(mesh.constrained[s]);
    couple(P);
  }

  // sum_j w_ij p_j over the constrained neighbours j of each free vertex, into `coupled`.
  void couple(const Points& P) {
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

  // Contact::Self: makes the first guess in `state` (targets applied) reachable
  // from the clear state contact_from. When a pair stands in the straight way,
  // the handles move in rounds: as far as is safe, then the pose relaxes
  // around them, then the rest of their move is carried through the mesh
  // harmonically (L_ff d_f = L_fc-coupled d_c) and tried again. Returns false
  // when the handles stopped short (stalled, or out of time / stopped: then
  // `interrupted`); the state is clear either way and `coupled` matches it.
  bool reach_first_guess(bool warm, SolveStats& stats, const std::function<bool()>& out_of_time,
                         bool& interrupted) {
    interrupted = false;
    if (warm) {
      // From the last pose: the handles' move carried through the mesh, checked on the way
      // (the global step's move would ignore the barrier).
      state = contact_from;
      carry_targets_through(1.0, stats);
      if (volume.active()) project_volume(stats);
      const auto t = Clock::now();
      const double fraction = contact.evaluate(contact_from.data(), state.data()).fraction;
      stats.contact_ms += ms_since(t);
      if (fraction >= 1) return true;
    } else if (clear(stats)) {
      // A first guess that crosses nothing and keeps every pair beyond the gap is
      // a start: how it was made is not a motion anyone sees.
      return true;
    }
    // Else (a cold start) the targets carried through the mesh from the rest
    // shape, and when that crosses too, the handles go there in steps, each
    // checked on the way and followed by a few iterations that let the pose
    // settle around the contacts (a quasi-static loading). A warm start takes
    // the steps at once: its poses are shown, so every move between them is checked.
    if (!warm) {
      state = contact_from;
      carry_targets_through(1.0, stats);
      if (volume.active()) project_volume(stats);
      if (clear(stats)) return true;
    }
    state = contact_from;
    couple(state);
    double remaining = 1;  // the share of the constrained vertices' move still to make
    int& stalled = contact_stalled_rounds;
    for (int round = 0; round < kContactMaxRounds; ++round) {
      ++stats.contact_rounds;
      const double share = std::min(1.0, kContactLoadStep / remaining);
      contact_from = state;
      carry_targets_through(share, stats);
      if (volume.active()) project_volume(stats);
      contact_goal = state;
      auto t = Clock::now();
      const contact::SelfContact::Step step =
          contact.evaluate(contact_from.data(), contact_goal.data(), contact::SelfContact::ListAt::Start);
      stats.contact_ms += ms_since(t);
      double made = step.fraction >= 1 ? share : kContactBackoff * step.fraction * share;
      if (step.fraction < 1) {
        state = contact_from + kContactBackoff * step.fraction * (contact_goal - contact_from);
        // A pair pressed within rounding of the gap (a share of 1e-14) can measure
        // inside it after even that move: the round then stays where it started.
        if (!std::isfinite(contact.energy(state.data()))) {
          state = contact_from;
          made = 0;
        }
      }
      remaining *= 1 - made;
      if (step.fraction >= 1 && share >= 1) {
        apply_targets(targets, state);
        stats.contact_reached = 1;
        stats.contact_stopped_vertex = -1;
        return true;
      }
      stats.contact_reached = 1 - remaining;
      if (step.fraction < 1) stats.contact_stopped_vertex = stopping_vertex(step);
      stalled = made < kContactStallGain ? stalled + 1 : 0;
      couple(state);
      if (stalled >= kContactStallRounds) return false;
      interrupted = out_of_time();
      if (interrupted) return false;
      relax(kContactRelaxIterations, stats, out_of_time);
    }
    return false;
  }

  bool clear(SolveStats& stats, double* barrier = nullptr) {
    const auto t = Clock::now();
    const bool is = contact.is_clear(state.data(), barrier);
    stats.contact_ms += ms_since(t);
    return is;
  }

  // The end of a cold solve's first part, run without the barrier (at its stop
  // or at the iteration cap). A result that crosses nothing and has no pair
  // within the barrier's reach is kept: the barrier is zero around it, so it is
  // a stationary point with contact too, and no step of the solve is shown. A
  // clear one with pairs in reach is where the solve with contact starts; one
  // that is not clear leaves the usual cold start (reach_first_guess()).
  // Returns whether to iterate on, `energy` then the energy of the start.
  bool contact_free_part_done(SolveStats& stats, const std::function<bool()>& out_of_time, bool& interrupted,
                              double& energy) {
    contact_deferred = false;
    contact_settling = 0;
    double barrier = 0;
    if (clear(stats, &barrier)) {
      if (barrier == 0) return false;
      energy = start_quasi_newton_here(stats);
      return true;
    }
    std::fill(eigenvalues.begin(), eigenvalues.end(), 0.0);  // as a cold start: no hint of that solve
    contact_from = mesh.rest;
    apply_targets(targets, state);
    first_guess(contact_deferred_guess);
    energy = start_quasi_newton_from_guess(false, stats, out_of_time, interrupted);
    return true;
  }

  // The first guess in `state` moved onto the volume constraint and, with
  // contact, made reachable (reach_first_guess()); then the quasi-Newton state
  // there. Returns its energy.
  double start_quasi_newton_from_guess(bool warm, SolveStats& stats, const std::function<bool()>& out_of_time,
                                       bool& interrupted) {
    if (volume.active()) project_volume(stats);
    if (contact_on()) reach_first_guess(warm, stats, out_of_time, interrupted);
    return start_quasi_newton_here(stats);
  }

  // The energy at `state` and the quasi-Newton state and first direction there.
  double start_quasi_newton_here(SolveStats& stats) {
    const double e = local(stats);
    start_quasi_newton(stats);
    qn_slope = quasi_newton_direction(stats);
    return e;
  }

  // The input index of a user-constrained vertex still short of its target:
  // one of the pair that stopped a step if it has one, else the nearest to that pair.
  int stopping_vertex(const contact::SelfContact::Step& step) const {
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

  // A few quasi-Newton iterations with the constrained vertices where they are.
  void relax(int iterations, SolveStats& stats, const std::function<bool()>& out_of_time) {
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

  // The user's constrained vertices moved `share` of the way to their targets
  // (each part that moves as one turning as a rigid body, see contact/handle_moves.h),
  // the free ones by the harmonic extension of that move: L_ff d_f = sum_c w_fc d_c.
  void carry_targets_through(double share, SolveStats& stats) {
    const auto t = Clock::now();
    const Points& goal = share >= 1 ? targets : round_goal;
    if (share < 1) handle_moves.toward(state, targets, share, round_goal);
    std::fill(rhs.begin(), rhs.end(), 0.0);
    for (const Coupling& c : mesh.couplings) {
      if (c.constrained_slot >= mesh.user_constrained) continue;
      const int v = mesh.constrained[c.constrained_slot];
      for (int d = 0; d < 3; ++d) rhs[3 * c.free_row + d] += c.w * (goal(c.constrained_slot, d) - state(v, d));
    }
    laplacian.solve_in_place(rhs.data(), work, options.threads);
    for (size_t r = 0; r < mesh.free_vertices.size(); ++r)
      for (int d = 0; d < 3; ++d) state(mesh.free_vertices[r], d) += rhs[3 * r + d];
    if (share >= 1) {
      apply_targets(targets, state);
    } else {
      for (int slot = 0; slot < mesh.user_constrained; ++slot) state.row(mesh.constrained[slot]) = round_goal.row(slot);
      couple(state);
    }
    stats.linear_solve_ms += ms_since(t);
  }

  // Global step: L_ff p_f = b_f(R) + coupled.
  void global_step(SolveStats& stats) {
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
  double local(SolveStats& stats) {
    double e = local_without_contact(stats);
    if (contact_on()) {
      const auto t = Clock::now();
      e += contact.energy(state.data());
      stats.contact_ms += ms_since(t);
    }
    return e;
  }

  double local_without_contact(SolveStats& stats) {
    const auto t = Clock::now();
    double e = local_step(mesh, state.data(), rotations.data(), cell_energy.data(), options.threads,
                          &stats.rotation_fallbacks, eigenvalues.data());
    if (bulk.active()) e += bulk.energy(state.data());
    stats.rotation_ms += ms_since(t);
    rotations_valid = true;
    return e;
  }
};

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

void Solver::bind(const Eigen::Ref<const Points>& rest, const Eigen::Ref<const Triangles>& triangles,
                  const std::vector<int>& constrained, const Options& options,
                  const std::vector<double>& stiffness) {
  check_options(options);
  check_bind_input(rest, triangles, constrained);   // before the infill lattice reads the triangles
  require_bind_memory(rest.rows(), kMeshBytesPerVertex, "the mesh's structures");
  // Built aside: only a successful bind replaces the previous state.
  auto make_binding = [&] {
    const auto start = Clock::now();
    auto next = std::make_unique<Impl>();
    next->options = options;
    next->bound_weights = options.weights;
    next->bound_volume = options.volume;
    next->bound_infill_resolution = options.infill_resolution;
    next->unit = unit_scale_of(rest);
    Points scaled(rest.rows(), 3);
    prefault(scaled.data(), sizeof(double) * scaled.size());
    scaled = rest / next->unit;
    InfillGraph infill;
    if (options.volume == Volume::Infill) {
      infill = build_infill(scaled, triangles, options.infill_resolution);
      require_bind_memory(rest.rows() + infill.nodes.rows(), kMeshBytesPerVertex, "the infill lattice");
    }
    next->mesh = build_bound_mesh(scaled, triangles, constrained, options.weights, stiffness,
                                  options.volume == Volume::Infill ? &infill : nullptr);
    next->bind_stats.mesh_ms = ms_since(start);
    next->triangles.resize(triangles.rows(), 3);
    prefault(next->triangles.data(), sizeof(int) * next->triangles.size());
    for (Eigen::Index f = 0; f < triangles.rows(); ++f)
      for (int k = 0; k < 3; ++k) next->triangles(f, k) = next->mesh.rank[triangles(f, k)];
    next->constrained_input = constrained;
    if (!next->laplacian.factor(next->mesh.laplacian_ff, BlockCholesky::Kernel::Supernodal, options.threads,
                                BlockCholesky::Ordering::Auto,
                                [&](double factor_bytes) {
                                  require_bind_memory(next->mesh.n, kStateBytesPerVertex, "the factorization",
                                                      factor_bytes);
                                }))
      throw Error(ErrorCode::Factorization,
                  "the Laplacian could not be factored (not positive definite); with --weights cotan on a badly "
                  "triangulated mesh, try cotan-clamped");
    const int n = next->mesh.n;
    const size_t nf = next->mesh.free_vertices.size();
    next->state.resize(n, 3);
    next->positions.resize(rest.rows(), 3);
    for (Points* p : {&next->state, &next->positions}) prefault(p->data(), sizeof(double) * p->size());
    next->state = next->mesh.rest;
    next->positions = rest;
    assign_prefaulted(next->rotations, n, Eigen::Matrix3d::Identity());
    assign_prefaulted(next->cell_energy, n, 0.0);
    assign_prefaulted(next->eigenvalues, n, 0.0);
    assign_prefaulted(next->coupled, 3 * nf, 0.0);
    assign_prefaulted(next->rhs, 3 * nf, 0.0);
    assign_prefaulted(next->work, 3 * nf, 0.0);
    if (options.volume == Volume::Infill) next->bulk.bind(next->mesh, infill, kInfillBulk);
    next->bound_contact = options.contact;
    if (options.contact == Contact::Self) {
      next->contact.bind(next->mesh.rest, next->triangles, contact_stiffness(next->mesh));
      next->handle_moves.bind(next->mesh.constrained, next->mesh.user_constrained, next->triangles, n);
      next->round_goal.resize(next->mesh.user_constrained, 3);
      next->contact_from = next->mesh.rest;
      next->contact_goal = next->mesh.rest;
    }
    if (options.volume == Volume::Global) {
      next->volume.bind(next->mesh, next->triangles);
      next->mesh.report.volume_kept_components = next->volume.kept_components();
      next->mesh.report.volume_open_components = next->volume.open_components();
      next->qn_n.assign(3 * nf, 0.0);
      next->qn_u.assign(3 * nf, 0.0);
    }
    next->bound = true;
    next->bind_stats.ordering_ms = next->laplacian.ordering_ms();
    next->bind_stats.factor_ms = next->laplacian.factor_ms();
    next->bind_stats.total_ms = ms_since(start);
    return next;
  };
  try {
    impl_ = make_binding();
  } catch (const std::bad_alloc&) {
    throw Error(ErrorCode::OutOfMemory, "binding " + std::to_string(rest.rows()) +
                                            " vertices ran out of memory (the system refused an allocation); the "
                                            "previous binding is kept");
  }
}

SolveStats Solver::solve(const Eigen::Ref<const Points>& targets) {
  Impl& s = *impl_;
  if (!s.bound) throw Error(ErrorCode::NotBound, "solve() called before bind()");
  check_options(s.options);
  if (s.options.weights != s.bound_weights)
    throw Error(ErrorCode::InvalidInput, "the weights changed since bind(): bind again to use " +
                                             to_string(s.options.weights));
  if (s.options.volume != s.bound_volume || s.options.infill_resolution != s.bound_infill_resolution)
    throw Error(ErrorCode::InvalidInput, "the volume mode changed since bind(): bind again to use volume " +
                                             to_string(s.options.volume));
  if (s.options.contact != s.bound_contact)
    throw Error(ErrorCode::InvalidInput, "the contact mode changed since bind(): bind again to use contact " +
                                             to_string(s.options.contact));
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
  // With contact a cold solve's two parts each have the cap (see contact_free_part_done()).
  const size_t most_iterations = static_cast<size_t>(s.options.max_iterations) * (s.contact.active() ? 2 : 1);
  stats.energy.reserve(most_iterations);
  stats.iteration_ms.reserve(most_iterations);
  s.state_backup = s.state;  // same size every solve: no allocation; restored if anything below goes wrong
  bool contact_interrupted = false;
  const long contact_lists_before = s.contact.lists_made();
  try {
    const auto solve_start = Clock::now();
    auto t = solve_start;
    InitialGuess guess = s.options.init;
    if (guess == InitialGuess::WarmStart && !s.has_solution) guess = s.options.cold_start;
    // A warm start keeps the rotations of the last solution for its first global step.
    // (Not with no iteration to run: the returned energy must be that of the returned positions.)
    const bool reuse_rotations =
        guess == InitialGuess::WarmStart && s.rotations_valid && s.options.max_iterations > 0;
    // A cold start forgets every hint of the last solve: same input, same output bit for bit.
    if (guess != InitialGuess::WarmStart) std::fill(s.eigenvalues.begin(), s.eigenvalues.end(), 0.0);
    const bool quasi_newton = s.runs_quasi_newton();
    const bool resume = quasi_newton && guess == InitialGuess::WarmStart && s.qn_resumable &&
                        s.last_targets.rows() == targets.rows() && s.last_targets == targets;
    // A cold solve with contact runs without the barrier first (contact_free_part_done()).
    if (!resume) {
      s.contact_deferred = s.contact.active() && quasi_newton && guess != InitialGuess::WarmStart &&
                           s.options.max_iterations > 0;
      s.contact_deferred_guess = guess;
      s.contact_checks_may_stop = guess == InitialGuess::WarmStart;
    }
    if (s.contact.active() && !(s.contact_round_targets.rows() == s.targets.rows() &&
                                s.contact_round_targets == s.targets)) {
      s.contact_round_targets = s.targets;
      s.contact_stalled_rounds = 0;
    }
    if (s.contact.active()) {
      s.contact.set_threads(s.options.threads);
      // Steps start from a clear state: the last solution, or the rest shape for a cold start
      // (which must not depend on what came before) and after set_positions() left a crossing.
      const bool warm = guess == InitialGuess::WarmStart;
      if (warm && !s.contact_clear && !s.contact_deferred) s.contact_clear = s.contact.is_clear(s.state.data());
      if (warm && s.contact_clear) s.contact_from = s.state;
      else s.contact_from = s.mesh.rest;
      s.contact_clear = false;  // until this solve ends well
    }
    s.apply_targets(s.targets, s.state);
    s.first_guess(guess);
    stats.init_ms = ms_since(t);
    shared_->iterations.store(0, std::memory_order_relaxed);

    const auto out_of_time = [&] {
      return (s.options.time_budget_ms > 0 && ms_since(solve_start) >= s.options.time_budget_ms) ||
             shared_->stop.load(std::memory_order_relaxed);
    };
    const std::function<bool()> trial_out_of_time = out_of_time;
    if (s.contact_checks_may_stop && s.options.time_budget_ms > 0) s.trial_out_of_time = &trial_out_of_time;

    s.qn_history = s.options.method == Method::QuasiNewton;
    double previous_energy = std::numeric_limits<double>::quiet_NaN();
    s.qn_resumable = false;  // until this solve ends well
    if (!resume) s.contact_settling = 0;
    if (resume) {
      if (s.contact_on()) {
        // Where the last solve stopped the handles short of these targets, they stay.
        s.state = s.contact_from;
        s.couple(s.state);
      }
      previous_energy = stats.initial_energy = s.qn_energy;
      stats.contact_reached = s.contact_reached;  // the handles stand where the solve resumed stopped them
      stats.contact_stopped_vertex = s.contact_stopped_vertex;
    } else if (quasi_newton) {
      // It starts from a point with known energy and gradient. A warm start first
      // carries the moved targets through the mesh with one global step on the
      // last rotations (as the plain iteration's first step does).
      if (reuse_rotations && !s.contact_on()) s.global_step(stats);
      previous_energy = stats.initial_energy = s.start_quasi_newton_from_guess(
          guess == InitialGuess::WarmStart, stats, out_of_time, contact_interrupted);
    } else if (!reuse_rotations) {
      previous_energy = stats.initial_energy = s.local(stats);
    } else {
      stats.initial_energy = s.last_energy;  // the first guess's own energy would cost a local step
    }
    if (s.options.method == Method::Anderson && s.options.anderson_window > 0) {
      const size_t nf3 = 3 * s.mesh.free_vertices.size();
      s.free_before.resize(nf3), s.free_after.resize(nf3), s.free_next.resize(nf3);
      s.anderson.reset(s.options.anderson_window, static_cast<Eigen::Index>(nf3));
    }
    shared_->energy.store(energy_to_user_units(stats.initial_energy, s.unit), std::memory_order_relaxed);
    const double tolerance = s.options.tolerance;
    int cap = s.options.max_iterations;
    for (int it = 0; it < cap; ++it) {
      t = Clock::now();
      double e;
      if (quasi_newton) {
        bool stuck = false;
        const long cut_before = stats.contact_steps_cut;
        e = s.quasi_newton_step(previous_energy, s.qn_slope, stuck, stats);
        // The next direction now, so that the stop can look at it: settled when this
        // step lowered the energy by at most the tolerance and the next one is
        // predicted to lower it by no more (a small step alone can be a short
        // line-search step far from the minimum).
        s.qn_slope = s.quasi_newton_direction(stats);
        const bool small_step = previous_energy - e <= tolerance * std::abs(previous_energy);
        stats.converged = stuck || (small_step && -0.5 * s.qn_slope <= tolerance * std::abs(e));
        // Pressed against a contact, the direction keeps pointing into it (the
        // Laplacian does not know the barrier's stiffness) and every step is cut:
        // settled once such steps lower the energy by at most the tolerance a few times in a row.
        s.contact_settling = stats.contact_steps_cut > cut_before && small_step ? s.contact_settling + 1 : 0;
        stats.converged = stats.converged || s.contact_settling >= kContactSettledSteps;
      } else {
        e = s.iterate(previous_energy, stats);
        stats.converged = std::isfinite(previous_energy) && previous_energy - e <= tolerance * std::abs(previous_energy);
      }
      stats.iteration_ms.push_back(ms_since(t));
      stats.energy.push_back(e);
      stats.iterations = it + 1;
      shared_->energy.store(energy_to_user_units(e, s.unit), std::memory_order_relaxed);
      shared_->iterations.store(it + 1, std::memory_order_relaxed);
      if (s.contact_deferred && (stats.converged || it + 1 == cap)) {
        // The part without contact has settled, or reached the cap: the solve with
        // contact, when it is needed, has the cap again.
        stats.contact_free_iterations = it + 1;
        if (s.contact_free_part_done(stats, out_of_time, contact_interrupted, e)) {
          stats.converged = false;
          cap = it + 1 + s.options.max_iterations;
        }
      }
      if (stats.converged) break;
      previous_energy = e;
      if (s.options.time_budget_ms > 0 && ms_since(solve_start) >= s.options.time_budget_ms) break;
      if (shared_->stop.load(std::memory_order_relaxed)) break;
    }
    s.trial_out_of_time = nullptr;
    s.last_energy = stats.energy.empty() ? stats.initial_energy : stats.energy.back();
    // Stopped just after the solve with contact began: the state is its start.
    if (!stats.converged && !stats.energy.empty()) s.last_energy = previous_energy;
    if (s.volume.active()) stats.volume_drift = s.volume.drift(s.state.data());
    // Finite in internal units is not enough: times `unit` it must stay finite too.
    if (!s.state.allFinite() || !std::isfinite(s.state.cwiseAbs().maxCoeff() * s.unit) ||
        !std::isfinite(s.last_energy))
      throw Error(ErrorCode::NonFinite,
                  "the solve produced non-finite positions or energy (the mesh was left unchanged)");
  } catch (...) {
    s.trial_out_of_time = nullptr;
    s.state = s.state_backup;
    s.rotations_valid = false;
    throw;
  }
  // Stopped while still without the barrier: that pose may cross, the positions stay as they were.
  const bool unchecked = s.contact_deferred;
  if (!unchecked) {
    to_input(s.mesh, s.state, s.positions);
    if (s.unit != 1.0) s.positions *= s.unit;
  }
  s.has_solution = true;
  s.contact_clear = s.contact.active() && !unchecked;
  if (contact_interrupted) stats.converged = false;  // the handles are still on their way
  s.contact_reached = stats.contact_reached;
  s.contact_stopped_vertex = stats.contact_stopped_vertex;
  if (s.contact.active()) {
    stats.contact_pairs = s.contact.active_pairs();
    stats.contact_lists = s.contact.lists_made() - contact_lists_before;
  }
  // A solve whose handles were still on their way when time ran out starts the way again.
  if (!contact_interrupted && s.runs_quasi_newton()) {
    s.qn_resumable = true;
    s.qn_energy = s.last_energy;
    s.last_targets = targets;
  }
  energies_to_user_units(stats, s.unit);  // after qn_energy: that one stays in internal units
  return stats;
}

const Points& Solver::positions() const { return impl_->positions; }

void Solver::set_positions(const Eigen::Ref<const Points>& positions) {
  Impl& s = *impl_;
  if (!s.bound) throw Error(ErrorCode::NotBound, "set_positions() called before bind()");
  if (positions.rows() != s.mesh.input_n)
    throw Error(ErrorCode::InvalidInput, "expected " + std::to_string(s.mesh.input_n) + " positions, got " +
                                             std::to_string(positions.rows()));
  if (!positions.allFinite()) throw Error(ErrorCode::NonFinite, "positions contain NaN or Inf");
  s.positions = positions;
  to_internal(s.mesh, positions / s.unit, s.state);
  s.has_solution = true;
  s.rotations_valid = false;
  s.qn_resumable = false;
  s.contact_clear = false;  // checked at the next solve
}

void Solver::forget_solution() {
  Impl& s = *impl_;
  s.has_solution = false;
  s.rotations_valid = false;
  s.qn_resumable = false;
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
  if (!positions.allFinite())
    throw Error(ErrorCode::NonFinite, std::string(caller) + ": positions contain NaN or Inf");
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
  if (s.bulk.active()) e += s.bulk.energy(P.data());
  if (s.contact.active()) e += contact::SelfContact(s.contact).energy(P.data());
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
  if (s.bulk.active()) s.bulk.add_gradient(P.data(), gradient.data());
  if (s.contact.active()) {
    contact::SelfContact c(s.contact);
    c.energy(P.data());
    c.add_gradient(gradient.data());
  }
  to_input(s.mesh, gradient, gradient_input);
  gradient_input *= s.unit;  // E = unit^2 E(p / unit): dE/dp = unit dE_internal
  if (!gradient_input.allFinite())
    throw Error(ErrorCode::NonFinite, "energy_gradient(): the gradient is beyond the double range at this scale");
  return gradient_input;
}

}  // namespace arap
