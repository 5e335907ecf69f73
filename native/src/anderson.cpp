#include "anderson.h"

#include <algorithm>

#include <Eigen/Cholesky>

namespace arap {

void AndersonAccelerator::reset(int window, Eigen::Index dimension) {
  window_ = window;
  stored_ = 0;
  newest_ = -1;
  has_previous_ = false;
  previous_f_.resize(dimension);
  previous_g_.resize(dimension);
  f_.resize(dimension);
  delta_f_.resize(dimension, window);
  delta_g_.resize(dimension, window);
  gram_.setZero(window, window);
}

void AndersonAccelerator::step(const double* x, const double* g, double* next) {
  const Eigen::Index n = f_.size();
  const Eigen::Map<const Eigen::VectorXd> X(x, n), G(g, n);
  Eigen::Map<Eigen::VectorXd> out(next, n);
  f_ = G - X;
  if (has_previous_) {
    newest_ = (newest_ + 1) % window_;
    delta_f_.col(newest_) = f_ - previous_f_;
    delta_g_.col(newest_) = G - previous_g_;
    stored_ = std::min(stored_ + 1, window_);
    for (int c = 0; c < stored_; ++c) {
      const double d = delta_f_.col(c).dot(delta_f_.col(newest_));
      gram_(c, newest_) = gram_(newest_, c) = d;
    }
  }
  previous_f_ = f_;
  previous_g_ = G;
  has_previous_ = true;
  if (stored_ == 0) {
    out = G;
    return;
  }
  Small A = gram_.topLeftCorner(stored_, stored_);
  SmallVector b(stored_);
  b.noalias() = delta_f_.leftCols(stored_).transpose() * f_;
  // A tiny ridge keeps the normal equations solvable when differences are collinear.
  A.diagonal().array() += 1e-10 * (A.diagonal().maxCoeff() + 1e-300);
  const SmallVector theta = A.ldlt().solve(b);
  out = G;
  out.noalias() -= delta_g_.leftCols(stored_) * theta;
  if (!out.allFinite()) out = G;
}

}  // namespace arap
