// Limited-memory BFGS directions (Nocedal & Wright, "Numerical Optimization",
// algorithm 7.4, the two-loop recursion) whose initial inverse Hessian is a
// caller-given preconditioner. With the factored Laplacian as that
// preconditioner this is the quasi-Newton method of Liu, Bouaziz & Kavan 2017
// ("Quasi-Newton methods for real-time simulation of hyperelastic materials"):
// with an empty history the direction is exactly the local/global step.
#pragma once

#include <Eigen/Core>

namespace arap {

class LbfgsHistory {
 public:
  // Forget every pair and size the buffers (allocates; not in the loop).
  void reset(int capacity, Eigen::Index dimension);
  void clear() { stored_ = 0; }
  int stored() const { return stored_; }

  // Where the caller writes the next pair s = x_{k+1} - x_k, y = g_{k+1} - g_k
  // (no copy); commit() then keeps it if s.y > 0, the curvature condition that
  // keeps the implied inverse Hessian positive definite.
  double* next_s();
  double* next_y();
  bool commit(double sy, double ss, double yy);

  // d = -H g, H the L-BFGS inverse Hessian on preconditioner(v) (in place:
  // v <- H0 v). Returns g.d, the directional derivative of half the energy.
  template <class Preconditioner>
  double direction(const double* g, double* d, const Preconditioner& preconditioner);

 private:
  int column(int k) const { return (newest_ - k + capacity_) % capacity_; }  // k = 0: newest
  int capacity_ = 0, stored_ = 0, newest_ = -1;
  Eigen::MatrixXd s_, y_;        // dimension by capacity, used as rings
  Eigen::VectorXd rho_, alpha_;  // 1 / (s.y) per pair; first-loop coefficients
};

template <class Preconditioner>
double LbfgsHistory::direction(const double* g, double* d, const Preconditioner& preconditioner) {
  const Eigen::Index n = s_.rows();
  double* q = d;
  // Each pass over q applies one pair's update and takes the dot product the
  // next pair needs, so q streams through memory once per pair, not twice.
  // First loop, newest pair to oldest: alpha_i = rho_i s_i.q, q <- q - alpha_i y_i.
  double dot = 0;
  const double* s_first = stored_ > 0 ? s_.col(column(0)).data() : nullptr;
  for (Eigen::Index i = 0; i < n; ++i) q[i] = g[i], dot += s_first ? s_first[i] * g[i] : 0.0;
  for (int k = 0; k < stored_; ++k) {
    const int c = column(k);
    const double a = alpha_[c] = rho_[c] * dot;
    const double* y = y_.col(c).data();
    const double* s_next = k + 1 < stored_ ? s_.col(column(k + 1)).data() : nullptr;
    dot = 0;
    if (s_next) {
      for (Eigen::Index i = 0; i < n; ++i) q[i] -= a * y[i], dot += s_next[i] * q[i];
    } else {
      for (Eigen::Index i = 0; i < n; ++i) q[i] -= a * y[i];
    }
  }
  preconditioner(q);  // r = H0 q
  // Second loop, oldest to newest: beta_i = rho_i y_i.r, r <- r + (alpha_i - beta_i) s_i;
  // the last pass also negates and takes g.d.
  dot = 0;
  if (stored_ > 0) {
    const double* y_oldest = y_.col(column(stored_ - 1)).data();
    for (Eigen::Index i = 0; i < n; ++i) dot += y_oldest[i] * q[i];
  }
  double slope = 0;
  for (int k = stored_ - 1; k >= 0; --k) {
    const int c = column(k);
    const double step = alpha_[c] - rho_[c] * dot;
    const double* s = s_.col(c).data();
    if (k > 0) {
      const double* y_next = y_.col(column(k - 1)).data();
      dot = 0;
      for (Eigen::Index i = 0; i < n; ++i) q[i] += step * s[i], dot += y_next[i] * q[i];
    } else {
      for (Eigen::Index i = 0; i < n; ++i) q[i] = -(q[i] + step * s[i]), slope += q[i] * g[i];
      return slope;
    }
  }
  for (Eigen::Index i = 0; i < n; ++i) q[i] = -q[i], slope += q[i] * g[i];
  return slope;
}

}  // namespace arap
