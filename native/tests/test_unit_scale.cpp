// Results do not depend on the unit the mesh is modelled in, and the
// statistics of every solve are finite.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "surface_options.h"
#include "arap/solver.h"
#include "test_meshes.h"

namespace {

using arap_test::concat;
using arap_test::ring_vertices;
using arap_test::rows_of;

constexpr int kAround = 12, kRings = 13;

// A tube bent sideways by its top ring, bottom ring fixed, everything times `scale`.
struct ScaledBend {
  arap_test::Mesh mesh = arap_test::tube(kAround, kRings, 5.0);
  std::vector<int> constrained = concat(ring_vertices(kAround, 0), ring_vertices(kAround, kRings - 1));
  arap::Points targets;
  explicit ScaledBend(double scale) {
    targets = rows_of(mesh.V, constrained);
    for (int k = kAround; k < 2 * kAround; ++k) targets(k, 0) += 2.5;
    mesh.V *= scale;
    targets *= scale;
  }
};

struct Solved {
  arap::Points positions;
  arap::SolveStats stats;
};

Solved solve_at(double scale, arap::Method method) {
  const ScaledBend b(scale);
  arap::Options o = arap_test::surface_options();
  o.max_iterations = 40;
  o.tolerance = 0;
  o.method = method;
  o.anderson_window = 5;  // used by Method::Anderson only
  arap::Solver solver;
  solver.bind(b.mesh.V, b.mesh.F, b.constrained, o);
  Solved s;
  s.stats = solver.solve(b.targets);
  s.positions = solver.positions();
  return s;
}

TEST(UnitScale, EveryFiniteScaleGivesTheSameShape) {
  for (arap::Method method : {arap::Method::LocalGlobal, arap::Method::Anderson, arap::Method::QuasiNewton}) {
    const Solved unit = solve_at(1.0, method);
    for (double scale : {3.0, 1e-3, 1e30, 1e-30, 1e-80, 1e150, 1e-150, 1e300, 1e-300}) {
      SCOPED_TRACE("scale " + std::to_string(scale) + ", method " + arap::to_string(method));
      const Solved s = solve_at(scale, method);
      ASSERT_TRUE(s.positions.allFinite());
      EXPECT_FALSE(std::isnan(s.stats.initial_energy));  // +inf where scale^2 overflows, never NaN
      EXPECT_FALSE(std::isnan(s.stats.energy.back()));
      // Same shape to 1e-9 of the tube's size (height 5) for the plain iteration.
      // Anderson's extrapolation and the quasi-Newton line search amplify rounding,
      // so where they stop moves by up to ~1e-8: a looser bound.
      const double bound = method == arap::Method::LocalGlobal ? 1e-9 : 1e-6;
      EXPECT_LT((s.positions / scale - unit.positions).cwiseAbs().maxCoeff(), bound * 5);
      // Energies in the caller's units (scale^2 times), where that fits in a double.
      if (scale * scale < 1e300 && scale * scale > 1e-300) {
        EXPECT_NEAR(s.stats.initial_energy / (scale * scale), unit.stats.initial_energy,
                    1e-9 * unit.stats.initial_energy);
        EXPECT_NEAR(s.stats.energy.back() / (scale * scale), unit.stats.energy.back(), 1e-9 * unit.stats.energy.back());
      }
    }
  }
}

TEST(UnitScale, PowersOfTwoAreExact) {
  const Solved unit = solve_at(1.0, arap::Method::QuasiNewton);
  const Solved s = solve_at(std::ldexp(1.0, -200), arap::Method::QuasiNewton);
  EXPECT_EQ(s.positions, unit.positions * std::ldexp(1.0, -200));
  EXPECT_EQ(s.stats.energy.back(), unit.stats.energy.back() * std::ldexp(1.0, -400));
}

TEST(UnitScale, EnergyAndGradientAreInTheCallersUnits) {
  const double scale = 1e-40;
  const ScaledBend big(1.0), small(scale);
  arap::Solver a, b;
  a.bind(big.mesh.V, big.mesh.F, big.constrained);
  b.bind(small.mesh.V, small.mesh.F, small.constrained);
  a.solve(big.targets);
  b.solve(small.targets);
  const double ea = a.energy(a.positions()), eb = b.energy(b.positions());
  EXPECT_NEAR(eb / (scale * scale), ea, 1e-9 * ea);
  const arap::Points ga = a.energy_gradient(a.positions()), gb = b.energy_gradient(b.positions());
  EXPECT_LT((gb / scale - ga).cwiseAbs().maxCoeff(), 1e-8 * ga.cwiseAbs().maxCoeff());
  // set_positions() takes the caller's units too.
  b.set_positions(b.positions());
  EXPECT_NEAR(b.energy(b.positions()) / (scale * scale), ea, 1e-9 * ea);
}

TEST(SolveStats, WarmStartReportsAFiniteInitialEnergy) {
  const ScaledBend b(1.0);
  for (arap::Method method : {arap::Method::LocalGlobal, arap::Method::Anderson, arap::Method::QuasiNewton}) {
    SCOPED_TRACE("method " + arap::to_string(method));
    arap::Options o = arap_test::surface_options();
    o.init = arap::InitialGuess::WarmStart;
    o.method = method;
    o.anderson_window = 3;
    arap::Solver solver;
    solver.bind(b.mesh.V, b.mesh.F, b.constrained, o);
    const auto first = solver.solve(b.targets);
    arap::Points moved = b.targets;
    moved(kAround, 1) += 0.1;
    const auto second = solver.solve(moved);  // reuses the last rotations
    EXPECT_TRUE(std::isfinite(first.initial_energy));
    ASSERT_TRUE(std::isfinite(second.initial_energy));
    // The energy it started from: the last solution's, except that the quasi-Newton
    // method first carries the moved targets through with one global step.
    if (method != arap::Method::QuasiNewton) {
      EXPECT_EQ(second.initial_energy, first.energy.back());
    }
  }
}

TEST(SolveStats, ZeroIterationsReturnTheEnergyOfTheReturnedPositions) {
  const ScaledBend b(1.0);
  arap::Options o = arap_test::surface_options();
  o.init = arap::InitialGuess::WarmStart;
  arap::Solver solver;
  solver.bind(b.mesh.V, b.mesh.F, b.constrained, o);
  solver.solve(b.targets);
  solver.options().max_iterations = 0;
  arap::Points moved = b.targets;
  moved(kAround, 1) += 0.1;
  const auto stats = solver.solve(moved);
  EXPECT_EQ(stats.iterations, 0);
  EXPECT_TRUE(stats.energy.empty());
  ASSERT_TRUE(std::isfinite(stats.initial_energy));
  EXPECT_NEAR(stats.initial_energy, solver.energy(solver.positions()), 1e-12 * stats.initial_energy);
}

TEST(BadInput, EnergyAndGradientRefuseNonFinitePositions) {
  const ScaledBend b(1.0);
  arap::Solver solver;
  solver.bind(b.mesh.V, b.mesh.F, b.constrained);
  for (double bad : {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    arap::Points P = b.mesh.V;
    P(7, 1) = bad;
    for (int which = 0; which < 2; ++which) {
      try {
        if (which == 0)
          solver.energy(P);
        else
          solver.energy_gradient(P);
        ADD_FAILURE() << (which ? "energy_gradient" : "energy") << " accepted " << bad;
      } catch (const arap::Error& e) {
        EXPECT_EQ(e.code(), arap::ErrorCode::NonFinite);
      }
    }
  }
}

}  // namespace
