// A weight-free measure of how rigid a deformation looks, used to compare
// edge weightings fairly (the ARAP energy itself depends on the weights).
#pragma once

#include "arap/types.h"

namespace arap {

// Area-weighted RMS, over non-degenerate triangles, of the deviation of the
// singular values of each triangle's deformation gradient from 1:
// sqrt( sum_t A_t ((s1 - 1)^2 + (s2 - 1)^2) / sum_t A_t ). 0 for a rigid motion.
// `flipped` (optional) counts triangles whose normal turned by more than 90 degrees.
double rigidity_distortion(const Eigen::Ref<const Points>& rest, const Eigen::Ref<const Points>& deformed,
                           const Eigen::Ref<const Triangles>& triangles, int* flipped = nullptr);

}  // namespace arap
