// The solver's internal unit: results must not depend on the unit the mesh
// was modelled in. Far from 1, the iteration loses its footing: at 1e30 the
// covariances' fourth powers overflow in the rotation fit, at 1e-30 the
// energies underflow to 0/0 and the fit's "zero covariance" test (1e-300)
// fires on every cell. bind() divides the rest shape (and solve() the
// targets) by a power of two near the largest |coordinate|, so the loop sees
// coordinates in [-2, 2]; results are multiplied back, energies by unit^2.
// A power of two keeps this exact: at unit 1 nothing changes bit for bit, and
// a mesh scaled by 2^k gives the same result scaled by 2^k.
#pragma once

#include "arap/solve_stats.h"
#include "arap/types.h"

namespace arap {

// 2^e with the largest |coordinate| of `rest` in [2^e, 2^(e+1));
// 1 when `rest` is empty, all zero, or not finite (bind() refuses it then).
double unit_scale_of(const Eigen::Ref<const Points>& rest);

// An energy from internal units to the caller's (times unit^2): +-inf when
// that exceeds the double range (coordinates beyond ~1e154), never NaN (an
// energy that overflowed inside the solver, inf - inf, is reported as +inf).
double energy_to_user_units(double energy, double unit);
void energies_to_user_units(SolveStats& stats, double unit);

}  // namespace arap
