#include <gtest/gtest.h>

#include <limits>
#include <thread>

#include <Eigen/Geometry>

#include "surface_options.h"
#include "arap/solver.h"
#include "gradient_check.h"
#include "linalg/nested_dissection.h"
#include "reference_arap.h"
#include "test_meshes.h"

namespace {

using arap_test::concat;
using arap_test::expect_gradient_matches_finite_differences;
using arap_test::ring_vertices;
using arap_test::rows_of;

using arap_test::BentTube;
constexpr int kAround = arap_test::kBentAround, kRings = arap_test::kBentRings;

arap::Options options_with(arap::InitialGuess init, int iterations, double tolerance = 0,
                           arap::Method method = arap::Method::QuasiNewton) {
  arap::Options o = arap_test::surface_options();
  o.method = method;
  o.init = init;
  o.max_iterations = iterations;
  o.tolerance = tolerance;
  return o;
}

TEST(Solver, RigidMotionOfAllConstraintsGivesTheRigidlyMovedMesh) {
  const BentTube t;
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.3, 1, 0.2).normalized()).toRotationMatrix();
  const Eigen::RowVector3d shift(0.4, -1.0, 2.0);
  const arap::Points moved = (t.mesh.V * R.transpose()).rowwise() + shift;
  for (auto init : {arap::InitialGuess::Naive, arap::InitialGuess::Laplacian, arap::InitialGuess::Differential}) {
    arap::Solver solver;
    solver.bind(t.mesh.V, t.mesh.F, t.constrained, options_with(init, 3000, 1e-15));
    const auto stats = solver.solve(rows_of(moved, t.constrained));
    EXPECT_LT((solver.positions() - moved).cwiseAbs().maxCoeff(), 1e-6) << arap::to_string(init);
    EXPECT_NEAR(stats.energy.back(), 0.0, 1e-9);
  }
}

constexpr arap::Method kMethods[] = {arap::Method::QuasiNewton, arap::Method::LocalGlobal, arap::Method::Anderson};

TEST(Solver, EnergyNeverIncreases) {
  const BentTube t;
  for (auto method : kMethods)
    for (auto weights : {arap::Weights::Cotan, arap::Weights::CotanClamped, arap::Weights::Uniform}) {
      arap::Options o = options_with(arap::InitialGuess::Naive, 50, 0, method);
      o.weights = weights;
      arap::Solver solver;
      solver.bind(t.mesh.V, t.mesh.F, t.constrained, o);
      const auto stats = solver.solve(t.targets);
      // Tolerance 0 still stops once the energy no longer falls (the quasi-Newton method gets there).
      ASSERT_GE(stats.energy.size(), method == arap::Method::LocalGlobal ? 50u : 10u) << arap::to_string(method);
      EXPECT_LE(stats.energy[0], stats.initial_energy * (1 + 1e-12));
      // The quasi-Newton method keeps a step only if its energy is not higher; the plain step
      // (and Anderson's fallback to it) may rise by rounding at the minimum.
      const double slack = method == arap::Method::QuasiNewton ? 0.0 : 1e-10 * std::abs(stats.energy[0]);
      for (size_t k = 1; k < stats.energy.size(); ++k)
        EXPECT_LE(stats.energy[k], stats.energy[k - 1] + slack) << arap::to_string(method) << " iteration " << k;
    }
}

// The solver's energies and positions after `iterations` plain iterations
// from the naive start against the textbook implementation's (reference_arap.h).
void expect_matches_textbook(const arap_test::Mesh& mesh, const std::vector<int>& constrained,
                             const arap::Points& targets, const arap::Solver& solver,
                             const arap::SolveStats& stats, int iterations) {
  arap_test::ReferenceArap reference(mesh.V, mesh.F, constrained, arap::Weights::CotanClamped);
  arap::Points P = mesh.V;
  for (size_t k = 0; k < constrained.size(); ++k) P.row(constrained[k]) = targets.row(k);
  const auto expected = reference.run(P, iterations);
  for (int k = 0; k < iterations; ++k) EXPECT_NEAR(stats.energy[k], expected[k], 1e-9 * expected[0]);
  EXPECT_LT((solver.positions() - P).cwiseAbs().maxCoeff(), 1e-8);
}

TEST(Solver, MatchesAnIndependentTextbookImplementation) {
  const BentTube t;
  arap::Solver solver;
  solver.bind(t.mesh.V, t.mesh.F, t.constrained,
              options_with(arap::InitialGuess::Naive, 10, 0, arap::Method::LocalGlobal));
  solver.options().weights = arap::Weights::CotanClamped;
  const auto stats = solver.solve(t.targets);
  expect_matches_textbook(t.mesh, t.constrained, t.targets, solver, stats, 10);
  EXPECT_NEAR(solver.energy(solver.positions()), stats.energy.back(), 1e-12 * stats.energy[0]);
}

TEST(Solver, ConvergesToAStationaryPoint) {
  const BentTube t;
  for (auto method : kMethods) {
    arap::Solver solver;
    solver.bind(t.mesh.V, t.mesh.F, t.constrained, options_with(arap::InitialGuess::Laplacian, 2000, 1e-13, method));
    arap::Points start = t.mesh.V;
    for (size_t k = 0; k < t.constrained.size(); ++k) start.row(t.constrained[k]) = t.targets.row(k);
    const double initial_gradient = solver.energy_gradient(start).norm();
    solver.solve(t.targets);
    const arap::Points& P = solver.positions();
    const arap::Points gradient = solver.energy_gradient(P);
    double free_gradient = 0;
    for (int v = 2 * kAround; v < P.rows() - kAround; ++v) free_gradient += gradient.row(v).squaredNorm();
    // Ring 0 and the last ring are the first and last vertices: the rest are free.
    EXPECT_LT(std::sqrt(free_gradient), 1e-4 * initial_gradient) << arap::to_string(method);
    for (size_t k = 0; k < t.constrained.size(); ++k)
      EXPECT_LT((P.row(t.constrained[k]) - t.targets.row(k)).norm(), 1e-12);
  }
}

// The tube bent sideways, or twisted by a quarter turn about its axis.
std::vector<BentTube> quasi_newton_cases() {
  std::vector<BentTube> cases{BentTube(2.5), BentTube(0.0)};
  const Eigen::Matrix3d R = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  for (int k = kAround; k < 2 * kAround; ++k) cases[1].targets.row(k) = cases[1].targets.row(k) * R.transpose();
  return cases;
}

TEST(QuasiNewton, ReachesPlainArapsMinimumInFewerIterations) {
  for (const BentTube& t : quasi_newton_cases()) {
    arap::Solver plain, quasi_newton;
    plain.bind(t.mesh.V, t.mesh.F, t.constrained,
               options_with(arap::InitialGuess::Naive, 2000, 0, arap::Method::LocalGlobal));
    quasi_newton.bind(t.mesh.V, t.mesh.F, t.constrained, arap_test::surface_options());  // the defaults but the volume
    const auto p = plain.solve(t.targets), q = quasi_newton.solve(t.targets);
    const double best = std::min(p.energy.back(), q.energy.back());
    const double band = best + 1e-3 * std::abs(best);
    auto to_band = [&](const arap::SolveStats& s) {
      for (size_t k = 0; k < s.energy.size(); ++k)
        if (s.energy[k] <= band) return static_cast<int>(k + 1);
      return 1 << 20;
    };
    EXPECT_TRUE(q.converged);  // the tolerance stopped it, not the cap
    EXPECT_LE(q.energy.back(), band);  // the same minimum, within 1e-3
    EXPECT_LT(2 * to_band(q), to_band(p)) << to_band(q) << " vs " << to_band(p);
    // The same shape too, not just the same energy.
    EXPECT_LT((quasi_newton.positions() - plain.positions()).cwiseAbs().maxCoeff(), 1e-2);
    EXPECT_EQ(q.quasi_newton_resets, 0);  // its directions were descent directions on this smooth problem
  }
}

TEST(QuasiNewton, EmptyHistoryStepIsTheLocalGlobalStep) {
  // With no pair stored, the first direction is -L^-1 g, i.e. the plain global step: one iteration of
  // each method from the same start lands on the same positions.
  const BentTube t;
  arap::Solver plain, quasi_newton;
  plain.bind(t.mesh.V, t.mesh.F, t.constrained,
             options_with(arap::InitialGuess::Naive, 1, 0, arap::Method::LocalGlobal));
  quasi_newton.bind(t.mesh.V, t.mesh.F, t.constrained, options_with(arap::InitialGuess::Naive, 1));
  const auto p = plain.solve(t.targets), q = quasi_newton.solve(t.targets);
  EXPECT_LT((quasi_newton.positions() - plain.positions()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_NEAR(q.energy[0], p.energy[0], 1e-9 * p.energy[0]);
}

TEST(QuasiNewton, AWarmSolveWithTheSameTargetsResumesWhereTheLastStopped) {
  // 12 iterations in one solve, or 5 and then 7 warm: the same arithmetic, bit for bit.
  const BentTube t;
  arap::Solver once, split;
  once.bind(t.mesh.V, t.mesh.F, t.constrained, options_with(arap::InitialGuess::Naive, 12));
  split.bind(t.mesh.V, t.mesh.F, t.constrained, options_with(arap::InitialGuess::Naive, 5));
  const auto whole = once.solve(t.targets);
  split.solve(t.targets);
  split.options().init = arap::InitialGuess::WarmStart;
  split.options().max_iterations = 7;
  const auto rest = split.solve(t.targets);
  EXPECT_EQ(split.positions(), once.positions());
  EXPECT_EQ(rest.energy.back(), whole.energy.back());
  EXPECT_EQ(rest.initial_energy, whole.energy[4]);
  // New targets start afresh from the warm positions instead (a global step, then a new history).
  const BentTube moved(2.6);
  const auto next = split.solve(moved.targets);
  EXPECT_NE(next.initial_energy, rest.energy.back());
}

TEST(Solver, AfterForgetSolutionASolveGivesTheBitsOfAFreshBind) {
  // A frame's pose must not depend on the frames solved before it (renders in chunks, jumps).
  const BentTube t, far(2.6), near(1.3);
  for (auto method : kMethods)
    for (auto volume : {arap::Volume::None, arap::Volume::Global, arap::Volume::Infill})
      for (auto cold : {arap::InitialGuess::Naive, arap::InitialGuess::Differential}) {
        if (method == arap::Method::Anderson && volume != arap::Volume::None) continue;  // refused
        arap::Options o = options_with(arap::InitialGuess::WarmStart, 40, 1e-9, method);
        o.cold_start = cold;
        o.volume = volume;
        o.threads = 2;
        arap::Solver fresh, used;
        fresh.bind(t.mesh.V, t.mesh.F, t.constrained, o);
        used.bind(t.mesh.V, t.mesh.F, t.constrained, o);
        const auto direct = fresh.solve(near.targets);
        used.solve(far.targets);
        used.solve(t.targets);
        used.forget_solution();
        const auto after = used.solve(near.targets);
        const std::string what = arap::to_string(method) + " " + arap::to_string(volume) + " " + arap::to_string(cold);
        EXPECT_EQ(used.positions(), fresh.positions()) << what;
        EXPECT_EQ(after.energy, direct.energy) << what;
        // Without it, the same solve starts from the last pose: another path, other bits.
        used.solve(far.targets);
        used.solve(near.targets);
        EXPECT_NE(used.positions(), fresh.positions()) << what;
      }
}

TEST(Solver, AStartFromAGivenShapeDependsOnThatShapeAlone) {
  // A rig's frame starts from its skinned pose: the pose must not depend on the frames solved before it,
  // and a start already at the pose settles at once.
  const BentTube t, far(2.6), near(1.3);
  for (auto volume : {arap::Volume::None, arap::Volume::Infill}) {
    arap::Options o = options_with(arap::InitialGuess::WarmStart, 200, 1e-9, arap::Method::QuasiNewton);
    o.cold_start = arap::InitialGuess::Naive;
    o.volume = volume;
    arap::Solver fresh, used, naive;
    fresh.bind(t.mesh.V, t.mesh.F, t.constrained, o);
    used.bind(t.mesh.V, t.mesh.F, t.constrained, o);
    naive.bind(t.mesh.V, t.mesh.F, t.constrained, o);
    const auto settled = naive.solve(near.targets);
    const arap::Points start = naive.positions();
    fresh.start_from(start);
    const auto direct = fresh.solve(near.targets);
    used.solve(far.targets);
    used.start_from(start);
    used.solve(near.targets);
    const std::string what = arap::to_string(volume);
    EXPECT_EQ(used.positions(), fresh.positions()) << what;
    // The surface's own energy has nothing left to settle. (Infill's lattice starts near the surface's move,
    // not at its own settled place: it still takes iterations.)
    if (volume == arap::Volume::None) {
      EXPECT_LE(direct.iterations, 2) << what;
    }
    EXPECT_LE(direct.energy.back(), settled.energy.back() * (1 + 1e-6)) << what;
    // Once: the next solve goes on from its own solution (a warm start), not from `start` again.
    used.solve(far.targets);
    EXPECT_NE(used.positions(), fresh.positions()) << what;
    EXPECT_THROW(used.start_from(start.topRows(3)), arap::Error);
  }
}

TEST(LocalGlobal, AWarmSolveWithTheSameTargetsContinuesTheIteration) {
  // The time-to-band benchmark resumes runs this way: 12 plain iterations, or 5 and then 7 warm, alike.
  const BentTube t;
  const arap::Options o = options_with(arap::InitialGuess::Naive, 12, 0, arap::Method::LocalGlobal);
  arap::Solver once, split;
  once.bind(t.mesh.V, t.mesh.F, t.constrained, o);
  split.bind(t.mesh.V, t.mesh.F, t.constrained, o);
  const auto whole = once.solve(t.targets);
  split.options().max_iterations = 5;
  split.solve(t.targets);
  split.options().init = arap::InitialGuess::WarmStart;
  split.options().max_iterations = 7;
  const auto rest = split.solve(t.targets);
  ASSERT_EQ(rest.iterations, 7);
  EXPECT_EQ(split.positions(), once.positions());
  for (int k = 0; k < 7; ++k) EXPECT_EQ(rest.energy[k], whole.energy[5 + k]) << k;
}

TEST(Solver, TimeBudgetStopsAfterTheIterationThatSpendsIt) {
  const BentTube t;
  for (auto method : kMethods) {
    arap::Options o = options_with(arap::InitialGuess::Naive, 500, 1e-12, method);
    o.time_budget_ms = 1e-9;
    arap::Solver solver;
    solver.bind(t.mesh.V, t.mesh.F, t.constrained, o);
    const auto stats = solver.solve(t.targets);
    EXPECT_EQ(stats.iterations, 1) << arap::to_string(method);
    EXPECT_FALSE(stats.converged);
  }
  arap::Solver solver;
  arap::Options bad = arap_test::surface_options();
  bad.time_budget_ms = -1;
  EXPECT_THROW(solver.bind(t.mesh.V, t.mesh.F, t.constrained, bad), arap::Error);
}

TEST(Solver, GradientMatchesFiniteDifferencesOfTheEnergy) {
  const BentTube t;
  arap::Solver solver;
  solver.bind(t.mesh.V, t.mesh.F, t.constrained, options_with(arap::InitialGuess::Naive, 3));
  solver.solve(t.targets);
  expect_gradient_matches_finite_differences(solver, {40, 77, 150, 200});
}

TEST(Solver, EveryFirstGuessMeetsTheConstraintsAndConverges) {
  const BentTube t;
  for (auto init : {arap::InitialGuess::Naive, arap::InitialGuess::Laplacian, arap::InitialGuess::Differential,
                    arap::InitialGuess::WarmStart}) {
    arap::Solver solver;
    solver.bind(t.mesh.V, t.mesh.F, t.constrained, options_with(init, 0));
    const auto guess = solver.solve(t.targets);
    EXPECT_TRUE(solver.positions().allFinite());
    EXPECT_LT((rows_of(solver.positions(), t.constrained) - t.targets).norm(), 1e-12) << arap::to_string(init);
    solver.options().max_iterations = 300;
    solver.options().init = arap::InitialGuess::WarmStart;
    const auto stats = solver.solve(t.targets);
    EXPECT_LT(stats.energy.back(), guess.initial_energy) << arap::to_string(init);
  }
  // The guesses differ: the differential one keeps the uniform-Laplacian detail of the rest shape.
  arap::Solver naive, differential;
  naive.bind(t.mesh.V, t.mesh.F, t.constrained, options_with(arap::InitialGuess::Naive, 0));
  differential.bind(t.mesh.V, t.mesh.F, t.constrained, options_with(arap::InitialGuess::Differential, 0));
  naive.solve(t.targets);
  differential.solve(t.targets);
  EXPECT_GT((naive.positions() - differential.positions()).norm(), 1e-3);
}

TEST(Solver, WarmStartNeedsFewerIterationsThanColdStartForASmallMove) {
  for (auto method : kMethods) {
    BentTube t(2.5);
    const double tolerance = 1e-7;
    arap::Solver warm;
    warm.bind(t.mesh.V, t.mesh.F, t.constrained, options_with(arap::InitialGuess::WarmStart, 1000, tolerance, method));
    warm.solve(t.targets);
    BentTube moved(2.6);
    const auto warm_stats = warm.solve(moved.targets);
    arap::Solver cold;
    cold.bind(t.mesh.V, t.mesh.F, t.constrained, options_with(arap::InitialGuess::Laplacian, 1000, tolerance, method));
    const auto cold_stats = cold.solve(moved.targets);
    EXPECT_TRUE(warm_stats.converged);
    EXPECT_TRUE(cold_stats.converged);
    EXPECT_LT(warm_stats.iterations, cold_stats.iterations) << arap::to_string(method);
  }
}

// A tube of `around` x `rings` vertices, bottom ring fixed, top ring moved by `shift` along `axis`.
struct LongTube {
  arap_test::Mesh mesh;
  std::vector<int> constrained;
  arap::Points targets;
  LongTube(int around, int rings, double height, int axis, double shift)
      : mesh(arap_test::tube(around, rings, height)),
        constrained(concat(ring_vertices(around, 0), ring_vertices(around, rings - 1))),
        targets(rows_of(mesh.V, constrained)) {
    for (int k = around; k < 2 * around; ++k) targets(k, axis) += shift;
  }
};

TEST(Solver, ResultsAreDeterministicAndIndependentOfThreads) {
  // Large enough (4800 vertices) that two threads really run.
  const LongTube t(80, 60, 6.0, 1, 2.0);
  const auto& mesh = t.mesh;
  const auto& constrained = t.constrained;
  const auto& targets = t.targets;
  arap::Points first;
  std::vector<double> first_energy;
  for (int threads : {1, 2, 1}) {
    arap::Options o = options_with(arap::InitialGuess::Laplacian, 20);
    o.threads = threads;
    arap::Solver solver;
    solver.bind(mesh.V, mesh.F, constrained, o);
    const auto stats = solver.solve(targets);
    if (first.size() == 0) {
      first = solver.positions();
      first_energy = stats.energy;
    } else {
      EXPECT_EQ(solver.positions(), first);
      EXPECT_EQ(stats.energy, first_energy);
    }
  }
}

TEST(Solver, LargeMeshesSolveTheSameOnOneOrTwoThreadsAndMatchTheTextbook) {
  // 22,400 vertices: above the size at which the factor is split in two halves and a separator.
  const LongTube t(160, 140, 20.0, 0, 6.0);
  const auto& mesh = t.mesh;
  const auto& constrained = t.constrained;
  const auto& targets = t.targets;
  arap::Points first;
  for (int threads : {1, 2}) {
    arap::Options o = options_with(arap::InitialGuess::Naive, 4, 0, arap::Method::LocalGlobal);
    o.threads = threads;
    arap::Solver solver;
    solver.bind(mesh.V, mesh.F, constrained, o);
    const auto stats = solver.solve(targets);
    if (threads == 1) {
      first = solver.positions();
      expect_matches_textbook(mesh, constrained, targets, solver, stats, 4);
    } else {
      EXPECT_EQ(solver.positions(), first);
    }
  }
}

TEST(Solver, VeryLargeMeshesMatchTheTextbook) {
  // 205,000 vertices, 204,000 free: from kDissectionRows free rows the bind orders the factor
  // both by AMD and by nested dissection and keeps the cheaper (linalg/spd_solve.h).
  const LongTube t(500, 410, 60.0, 0, 6.0);
  ASSERT_GE(static_cast<long>(t.mesh.V.rows() - t.constrained.size()), arap::kDissectionRows);
  arap::Solver solver;
  solver.bind(t.mesh.V, t.mesh.F, t.constrained,
              options_with(arap::InitialGuess::Naive, 2, 0, arap::Method::LocalGlobal));
  const auto stats = solver.solve(t.targets);
  expect_matches_textbook(t.mesh, t.constrained, t.targets, solver, stats, 2);
}

TEST(QuasiNewton, LargeMeshesSolveTheSameOnOneOrTwoThreads) {
  // 22,080 free vertices: the factor's solves and the L-BFGS vector passes both split in two halves.
  const LongTube t(160, 140, 20.0, 0, 6.0);
  arap::Points first;
  std::vector<double> first_energy;
  for (int threads : {1, 2}) {
    arap::Options o = options_with(arap::InitialGuess::Naive, 8);
    o.threads = threads;
    arap::Solver solver;
    solver.bind(t.mesh.V, t.mesh.F, t.constrained, o);
    const auto stats = solver.solve(t.targets);
    ASSERT_EQ(stats.iterations, 8);
    if (threads == 1) {
      first = solver.positions();
      first_energy = stats.energy;
      EXPECT_LT(stats.energy.back(), stats.energy.front());
    } else {
      EXPECT_EQ(solver.positions(), first);
      EXPECT_EQ(stats.energy, first_energy);
    }
  }
}

TEST(Solver, RepeatedColdSolvesAreBitIdentical) {
  const BentTube t;
  arap::Solver solver;
  solver.bind(t.mesh.V, t.mesh.F, t.constrained, options_with(arap::InitialGuess::Naive, 7));
  solver.solve(t.targets);
  const arap::Points first = solver.positions();
  BentTube other(1.0);
  solver.solve(other.targets);  // a different solve in between
  solver.solve(t.targets);
  EXPECT_EQ(solver.positions(), first);
}

TEST(Solver, SeparateInstancesRunConcurrently) {
  // No global state: two solvers on two threads give what each gives alone.
  const BentTube a(2.5), b(1.0);
  auto solve = [](const BentTube& t) {
    arap::Solver solver;
    solver.bind(t.mesh.V, t.mesh.F, t.constrained, options_with(arap::InitialGuess::Naive, 30));
    solver.solve(t.targets);
    return arap::Points(solver.positions());
  };
  const arap::Points alone_a = solve(a), alone_b = solve(b);
  arap::Points together_a, together_b;
  std::thread other([&] { together_a = solve(a); });
  together_b = solve(b);
  other.join();
  EXPECT_EQ(together_a, alone_a);
  EXPECT_EQ(together_b, alone_b);
}

TEST(Solver, ToleranceStopsEarlyAndReportsIt) {
  const BentTube t;
  arap::Solver solver;
  solver.bind(t.mesh.V, t.mesh.F, t.constrained, options_with(arap::InitialGuess::Laplacian, 500, 1e-4));
  const auto stats = solver.solve(t.targets);
  EXPECT_TRUE(stats.converged);
  EXPECT_LT(stats.iterations, 500);
  EXPECT_EQ(stats.energy.size(), static_cast<size_t>(stats.iterations));
  EXPECT_EQ(stats.iteration_ms.size(), static_cast<size_t>(stats.iterations));
}

}  // namespace

namespace {

TEST(Solver, AndersonAccelerationStaysMonotoneAndConvergesFaster) {
  const BentTube t;
  auto run = [&](int window) {
    arap::Options o = options_with(arap::InitialGuess::Naive, 150, 0,
                                   window ? arap::Method::Anderson : arap::Method::LocalGlobal);
    o.anderson_window = window;
    arap::Solver solver;
    solver.bind(t.mesh.V, t.mesh.F, t.constrained, o);
    return solver.solve(t.targets);
  };
  const auto plain = run(0), accelerated = run(5);
  for (size_t k = 1; k < accelerated.energy.size(); ++k)
    EXPECT_LE(accelerated.energy[k], accelerated.energy[k - 1] + 1e-12 * accelerated.energy[0]);
  // Iterations to come within 1e-3 (of the first-iteration energy) of plain ARAP's final energy.
  auto reached = [&](const arap::SolveStats& s) {
    for (size_t k = 0; k < s.energy.size(); ++k)
      if (s.energy[k] - plain.energy.back() <= 1e-3 * plain.energy[0]) return static_cast<int>(k + 1);
    return 1 << 20;
  };
  EXPECT_LT(reached(accelerated), reached(plain));
  EXPECT_LE(accelerated.energy.back(), plain.energy.back() + 1e-9 * plain.energy[0]);
}

}  // namespace

#include "arap/tools/quality.h"

namespace {

TEST(Quality, RigidMotionHasNoDistortionAndStretchHas) {
  const auto m = arap_test::tube(12, 8, 3.0);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(1.1, Eigen::Vector3d(1, 0, 1).normalized()).toRotationMatrix();
  const arap::Points moved = (m.V * R.transpose()).rowwise() + Eigen::RowVector3d(1, 2, 3);
  EXPECT_NEAR(arap::rigidity_distortion(m.V, moved, m.F), 0.0, 1e-12);
  arap::Points stretched = m.V;
  stretched.col(2) *= 2.0;  // s = (2, 1) on every side triangle: sqrt(1) = 1
  int flipped = -1;
  EXPECT_NEAR(arap::rigidity_distortion(m.V, stretched, m.F, &flipped), 1.0, 1e-9);
  EXPECT_EQ(flipped, 0);
}

}  // namespace

namespace {

std::vector<double> middle_rings_stiff(const arap_test::Mesh& m, double value) {
  std::vector<double> s(m.V.rows(), 1.0);
  for (Eigen::Index v = 0; v < m.V.rows(); ++v)
    if (m.V(v, 2) > 2.0 && m.V(v, 2) < 4.0) s[v] = value;
  return s;
}

TEST(Stiffness, UniformScaleChangesTheEnergyNotTheShape) {
  const BentTube t;
  arap::Solver plain, scaled;
  plain.bind(t.mesh.V, t.mesh.F, t.constrained, options_with(arap::InitialGuess::Laplacian, 40));
  scaled.bind(t.mesh.V, t.mesh.F, t.constrained, options_with(arap::InitialGuess::Laplacian, 40),
              std::vector<double>(t.mesh.V.rows(), 3.0));
  const auto a = plain.solve(t.targets), b = scaled.solve(t.targets);
  // The quasi-Newton method is scale-invariant but for rounding, which can steer its line
  // search differently: the same shape to 1e-7 (the tube is 6 long), the textbook one exactly.
  EXPECT_LT((plain.positions() - scaled.positions()).cwiseAbs().maxCoeff(), 1e-7);
  EXPECT_NEAR(b.energy.back(), 3.0 * a.energy.back(), 1e-8 * a.energy.back());
  for (arap::Solver* s : {&plain, &scaled}) s->options().method = arap::Method::LocalGlobal;
  plain.solve(t.targets), scaled.solve(t.targets);
  EXPECT_LT((plain.positions() - scaled.positions()).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(Stiffness, GradientMatchesFiniteDifferencesAndEnergyNeverIncreases) {
  const BentTube t;
  arap::Solver solver;
  solver.bind(t.mesh.V, t.mesh.F, t.constrained, options_with(arap::InitialGuess::Naive, 30),
              middle_rings_stiff(t.mesh, 8.0));
  const auto stats = solver.solve(t.targets);
  for (size_t k = 1; k < stats.energy.size(); ++k)
    EXPECT_LE(stats.energy[k], stats.energy[k - 1] + 1e-12 * stats.energy[0]);
  expect_gradient_matches_finite_differences(solver, {60, 150, 170, 250});
}

TEST(Stiffness, AStiffRegionBendsLess) {
  const BentTube t;
  auto middle_distortion = [&](const std::vector<double>& stiffness) {
    arap::Solver solver;
    solver.bind(t.mesh.V, t.mesh.F, t.constrained, options_with(arap::InitialGuess::Laplacian, 300), stiffness);
    solver.solve(t.targets);
    // Triangles of the middle third only.
    arap::Triangles middle(0, 3);
    for (Eigen::Index f = 0; f < t.mesh.F.rows(); ++f) {
      const double z = t.mesh.V(t.mesh.F(f, 0), 2);
      if (z > 2.2 && z < 3.8) {
        middle.conservativeResize(middle.rows() + 1, 3);
        middle.row(middle.rows() - 1) = t.mesh.F.row(f);
      }
    }
    return arap::rigidity_distortion(t.mesh.V, solver.positions(), middle);
  };
  const double soft = middle_distortion({}), stiff = middle_distortion(middle_rings_stiff(t.mesh, 20.0));
  EXPECT_LT(stiff, 0.5 * soft);
}

TEST(Stiffness, BadValuesAreRefused) {
  const BentTube t;
  arap::Solver solver;
  std::vector<double> s(t.mesh.V.rows(), 1.0);
  s[5] = 0.0;
  EXPECT_THROW(solver.bind(t.mesh.V, t.mesh.F, t.constrained, arap_test::surface_options(), s), arap::Error);
  s[5] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(solver.bind(t.mesh.V, t.mesh.F, t.constrained, arap_test::surface_options(), s), arap::Error);
  EXPECT_THROW(solver.bind(t.mesh.V, t.mesh.F, t.constrained, arap_test::surface_options(), {1.0, 2.0}), arap::Error);
}

}  // namespace
