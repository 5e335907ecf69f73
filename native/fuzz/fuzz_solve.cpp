// libFuzzer target: Solver::bind() and solve() on arbitrary small meshes,
// constraint sets, targets and options, with warm-started re-solves and the
// energy functions. Coordinates come at every scale (2^-60 .. 2^60) and now
// and then as NaN, Inf or 1e308. Either arap::Error is thrown, or positions,
// energies and gradients are finite.
#include <fuzzer/FuzzedDataProvider.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "arap/solver.h"
#include "fuzz_common.h"

namespace {

double coordinate(FuzzedDataProvider& in, int exponent) {
  switch (in.ConsumeIntegralInRange<int>(0, 40)) {
    case 0:
      return std::numeric_limits<double>::quiet_NaN();
    case 1:
      return std::numeric_limits<double>::infinity();
    case 2:
      return 1e308;
    case 3:
      return in.ConsumeFloatingPoint<double>();
    default:
      return std::ldexp(in.ConsumeIntegralInRange<int>(-512, 512) / 256.0, exponent);
  }
}

void points(FuzzedDataProvider& in, arap::Points& p, int exponent) {
  for (Eigen::Index i = 0; i < p.size(); ++i) p.data()[i] = coordinate(in, exponent);
}

// Energies are reported in the caller's units (size^2): with coordinates or
// targets beyond ~1e150 they may overflow to +-inf (raw cotangent weights make
// energies negative), which is documented; never NaN, and finite below that.
void check_energy(double e, bool may_overflow, const char* what) {
  if (std::isnan(e) || (!may_overflow && !std::isfinite(e))) arap_fuzz::broken(what);
}

void check_finite(const arap::Solver& solver, const arap::SolveStats& stats, bool may_overflow) {
  if (!solver.positions().allFinite()) arap_fuzz::broken("non-finite positions after a successful solve");
  check_energy(stats.initial_energy, may_overflow, "bad initial energy after a successful solve");
  for (double e : stats.energy) check_energy(e, may_overflow, "bad energy after a successful solve");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  FuzzedDataProvider in(data, size);
  const int n = in.ConsumeIntegralInRange<int>(1, 24);
  const int exponent = in.ConsumeIntegralInRange<int>(-60, 60);
  arap::Points rest(n, 3);
  points(in, rest, exponent);
  arap::Triangles triangles(in.ConsumeIntegralInRange<int>(0, 40), 3);
  for (Eigen::Index i = 0; i < triangles.size(); ++i) triangles.data()[i] = in.ConsumeIntegralInRange<int>(-1, n);
  std::vector<int> constrained(in.ConsumeIntegralInRange<int>(0, n + 1));
  for (int& c : constrained) c = in.ConsumeIntegralInRange<int>(-1, n);
  arap::Options o;
  o.weights = static_cast<arap::Weights>(in.ConsumeIntegralInRange<int>(0, 2));
  o.init = static_cast<arap::InitialGuess>(in.ConsumeIntegralInRange<int>(0, 3));
  o.max_iterations = in.ConsumeIntegralInRange<int>(0, 8);
  o.tolerance = in.ConsumeBool() ? 0.0 : 1e-6;
  o.anderson_window = in.ConsumeIntegralInRange<int>(0, 5);
  // Every method, from a byte already read: the seed corpus keeps its meaning.
  o.method = static_cast<arap::Method>(o.anderson_window % 3);
  // Every volume mode too (Anderson takes none: the core refuses the pair), small lattices.
  if (o.method != arap::Method::Anderson) o.volume = static_cast<arap::Volume>(o.max_iterations % 3);
  o.infill_resolution = 2 + o.max_iterations % 4;
  // Self-contact on half the inputs that can take it (Anderson cannot).
  if (o.method != arap::Method::Anderson && (o.max_iterations / 3) % 2 == 1) o.contact = arap::Contact::Self;
  std::vector<double> stiffness;
  if (in.ConsumeBool()) {
    stiffness.resize(n);
    for (double& s : stiffness) s = in.ConsumeBool() ? 1.0 : std::ldexp(1.0, in.ConsumeIntegralInRange<int>(-20, 20));
  }
  arap::Solver solver;
  try {
    solver.bind(rest, triangles, constrained, o, stiffness);
  } catch (const arap::Error&) {
    return 0;
  }
  bool may_overflow = rest.cwiseAbs().maxCoeff() > 1e150;
  const int solves = in.ConsumeIntegralInRange<int>(1, 3);
  for (int k = 0; k < solves; ++k) {
    arap::Points targets(static_cast<Eigen::Index>(constrained.size()), 3);
    points(in, targets, exponent + in.ConsumeIntegralInRange<int>(-2, 2));
    may_overflow = may_overflow || (targets.size() > 0 && targets.cwiseAbs().maxCoeff() > 1e150);
    try {
      check_finite(solver, solver.solve(targets), may_overflow);
      check_energy(solver.energy(solver.positions()), may_overflow, "bad energy() of a solution");
      if (!solver.energy_gradient(solver.positions()).allFinite()) arap_fuzz::broken("non-finite gradient");
    } catch (const arap::Error&) {
      if (!solver.positions().allFinite()) arap_fuzz::broken("a failed solve left non-finite positions");
    }
    solver.options().init = arap::InitialGuess::WarmStart;
  }
  return 0;
}
