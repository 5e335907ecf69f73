#include "lbfgs.h"

#include <cmath>

namespace arap {

void LbfgsHistory::reset(int capacity, Eigen::Index dimension) {
  capacity_ = capacity;
  stored_ = 0;
  newest_ = -1;
  h0_scale_ = 1;
  s_.resize(dimension, capacity);
  y_.resize(dimension, capacity);
  rho_.resize(capacity);
  alpha_.resize(capacity);
}

double* LbfgsHistory::next_s() { return s_.col((newest_ + 1) % capacity_).data(); }
double* LbfgsHistory::next_y() { return y_.col((newest_ + 1) % capacity_).data(); }

bool LbfgsHistory::commit(double sy, double ss, double yy) {
  // Skip pairs with no (or numerically no) positive curvature along s. A full
  // ring has just lost its oldest pair to next_s()/next_y().
  if (!(sy > 1e-12 * std::sqrt(ss * yy)) || !std::isfinite(sy)) {
    if (stored_ == capacity_) --stored_;
    return false;
  }
  newest_ = (newest_ + 1) % capacity_;
  rho_[newest_] = 1.0 / sy;
  if (stored_ < capacity_) ++stored_;
  return true;
}

}  // namespace arap
