#include "unit_scale.h"

#include <cmath>
#include <limits>

namespace arap {

double unit_scale_of(const Eigen::Ref<const Points>& rest) {
  if (rest.size() == 0 || !rest.allFinite()) return 1.0;
  const double largest = rest.cwiseAbs().maxCoeff();
  if (largest == 0.0) return 1.0;
  int exponent = 0;
  std::frexp(largest, &exponent);        // largest = f * 2^exponent, f in [0.5, 1)
  return std::ldexp(1.0, exponent - 1);  // not 2^exponent: 2^1024 is not a double
}

double energy_to_user_units(double energy, double unit) {
  // An energy that overflowed on the way (inf - inf in a cell gives NaN) is +inf.
  if (std::isnan(energy)) return std::numeric_limits<double>::infinity();
  // Two factors of `unit`, each exact; a zero energy stays zero where unit^2 overflows (not 0 * inf = NaN).
  return energy == 0.0 || unit == 1.0 ? energy : energy * unit * unit;
}

void energies_to_user_units(SolveStats& stats, double unit) {
  stats.initial_energy = energy_to_user_units(stats.initial_energy, unit);
  for (double& e : stats.energy) e = energy_to_user_units(e, unit);
}

}  // namespace arap
