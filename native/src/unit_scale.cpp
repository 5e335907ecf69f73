#include "unit_scale.h"

#include <cmath>

namespace arap {

double unit_scale_of(const Eigen::Ref<const Points>& rest) {
  if (rest.size() == 0 || !rest.allFinite()) return 1.0;
  const double largest = rest.cwiseAbs().maxCoeff();
  if (largest == 0.0) return 1.0;
  int exponent = 0;
  std::frexp(largest, &exponent);  // largest = f * 2^exponent, f in [0.5, 1)
  return std::ldexp(1.0, exponent);
}

void energies_to_user_units(SolveStats& stats, double unit) {
  if (unit == 1.0) return;
  const double factor = unit * unit;
  stats.initial_energy *= factor;
  for (double& e : stats.energy) e *= factor;
}

}  // namespace arap
