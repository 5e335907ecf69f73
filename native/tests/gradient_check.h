// A check shared by the solver's tests: the gradient is the derivative of the energy.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "arap/solver.h"

namespace arap_test {

// dE/dp from energy_gradient() against central differences of energy() at
// `vertices`, at the solver's current positions.
inline void expect_gradient_matches_finite_differences(const arap::Solver& solver, const std::vector<int>& vertices) {
  const arap::Points P = solver.positions();
  const arap::Points gradient = solver.energy_gradient(P);
  const double h = 1e-6;
  for (int v : vertices)
    for (int d = 0; d < 3; ++d) {
      arap::Points plus = P, minus = P;
      plus(v, d) += h;
      minus(v, d) -= h;
      const double numeric = (solver.energy(plus) - solver.energy(minus)) / (2 * h);
      EXPECT_NEAR(gradient(v, d), numeric, 1e-5 * (1 + std::abs(numeric))) << "vertex " << v << " axis " << d;
    }
}

}  // namespace arap_test
