#include "pose_stop.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace arap {

void PoseStop::record(double step) {
  steps_[count_ % steps_.size()] = step;
  ++count_;
}

double PoseStop::distance_left() const {
  constexpr long size = kWindow + 1;
  if (count_ < size) return std::numeric_limits<double>::infinity();
  const double newest = steps_[(count_ - 1) % size], oldest = steps_[count_ % size];
  if (newest == 0) return 0;
  // The 4th root as two square roots: std::pow would need glibc 2.29 (portable_math.h).
  static_assert(kWindow == 4, "rho is the 4th root of the window's ratio");
  const double rho = std::sqrt(std::sqrt(newest / oldest));
  if (!(rho < 1)) return std::numeric_limits<double>::infinity();
  double largest = 0;
  for (long k = 1; k < size; ++k) largest = std::max(largest, steps_[(count_ - k) % size]);
  return largest * rho / (1 - rho);
}

double largest_row(const double* s, long rows) {
  double most = 0;
  for (long r = 0; r < rows; ++r)
    most = std::max(most, s[3 * r] * s[3 * r] + s[3 * r + 1] * s[3 * r + 1] + s[3 * r + 2] * s[3 * r + 2]);
  return std::sqrt(most);
}

}  // namespace arap
