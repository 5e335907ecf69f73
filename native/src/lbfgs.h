// Limited-memory BFGS directions (Nocedal & Wright, "Numerical Optimization",
// algorithm 7.4, the two-loop recursion) whose initial inverse Hessian is a
// caller-given preconditioner. With the factored Laplacian as that
// preconditioner this is the quasi-Newton method of Liu, Bouaziz & Kavan 2017
// ("Quasi-Newton methods for real-time simulation of hyperelastic materials"):
// with an empty history the direction is exactly the local/global step.
#pragma once

#include <algorithm>

#include <Eigen/Core>

#include "runtime/vector_halves.h"

namespace arap {

class LbfgsHistory {
 public:
  // Forget every pair and size the buffers (allocates; not in the loop).
  void reset(int capacity, Eigen::Index dimension);
  void clear() { stored_ = 0, h0_scale_ = 1; }
  int stored() const { return stored_; }

  // Where the caller writes the next pair s = x_{k+1} - x_k, y = g_{k+1} - g_k
  // (no copy); commit() then keeps it if s.y > 0, the curvature condition that
  // keeps the implied inverse Hessian positive definite.
  double* next_s();
  double* next_y();
  bool commit(double sy, double ss, double yy);
  // H0 = scale * P from now on (the caller's estimate from the pair just
  // committed); back to 1 when the history is cleared or reset.
  void set_h0_scale(double scale) { h0_scale_ = scale; }

  // d = -H g, H the L-BFGS inverse Hessian on H0 = scale * P (set_h0_scale),
  // P applied by preconditioner(v) (in place: v <- P v); the scale only counts
  // once a pair is stored (with none, d = -P g exactly). Returns g.d, the
  // directional derivative of half the energy. Long vectors are streamed in two
  // halves, on two threads if `threads` > 1 (the same result either way, see
  // vector_halves.h).
  template <class Preconditioner>
  double direction(const double* g, double* d, const Preconditioner& preconditioner, int threads = 1);

 private:
  int column(int k) const { return (newest_ - k + capacity_) % capacity_; }  // k = 0: newest
  int capacity_ = 0, stored_ = 0, newest_ = -1;
  double h0_scale_ = 1;
  Eigen::MatrixXd s_, y_;        // dimension by capacity, used as rings
  Eigen::VectorXd rho_, alpha_;  // 1 / (s.y) per pair; first-loop coefficients
};

namespace lbfgs_detail {

// q[i] <- f(i, q[i]) for every i, and returns z.q of the new q (z may be null:
// returns 0). Four partial sums in a fixed order: the compiler may vectorise
// the loop without reassociating, and the result does not depend on it.
template <class F>
double map_dot(double* q, const F& f, const double* z, Eigen::Index n) {
  double d[4] = {0, 0, 0, 0};
  Eigen::Index i = 0;
  if (!z) {
    for (; i < n; ++i) q[i] = f(i, q[i]);
    return 0;
  }
  for (; i + 4 <= n; i += 4)
    for (int k = 0; k < 4; ++k) q[i + k] = f(i + k, q[i + k]), d[k] += z[i + k] * q[i + k];
  for (; i < n; ++i) q[i] = f(i, q[i]), d[0] += z[i] * q[i];
  return (d[0] + d[1]) + (d[2] + d[3]);
}

}  // namespace lbfgs_detail

template <class Preconditioner>
double LbfgsHistory::direction(const double* g, double* d, const Preconditioner& preconditioner, int threads) {
  const Eigen::Index n = s_.rows();
  double* q = d;
  // q[i] <- f(i, q[i]) and z.q, over the halves (z may be null).
  auto pass = [&](const auto& f, const double* z) {
    return sum_over_halves(n, threads, [&](std::ptrdiff_t b, std::ptrdiff_t e) {
      return lbfgs_detail::map_dot(q + b, [&](Eigen::Index i, double v) { return f(b + i, v); }, z ? z + b : nullptr,
                                   e - b);
    });
  };
  auto update = [&](double a, const double* x, const double* z) {  // q <- q + a x
    return pass([&](std::ptrdiff_t i, double v) { return v + a * x[i]; }, z);
  };
  // Each pass over q applies one pair's update and takes the dot product the
  // next pair needs, so q streams through memory once per pair, not twice.
  // First loop, newest pair to oldest: alpha_i = rho_i s_i.q, q <- q - alpha_i y_i.
  double dot = pass([&](std::ptrdiff_t i, double) { return g[i]; }, stored_ > 0 ? s_.col(column(0)).data() : nullptr);
  for (int k = 0; k < stored_; ++k) {
    const int c = column(k);
    const double a = alpha_[c] = rho_[c] * dot;
    const double* s_next = k + 1 < stored_ ? s_.col(column(k + 1)).data() : nullptr;
    dot = update(-a, y_.col(c).data(), s_next);
  }
  preconditioner(q);  // r = H0 q = h0_scale_ P q: the scale is applied in the pass that takes the next dot
  // Second loop, oldest to newest: beta_i = rho_i y_i.r, r <- r + (alpha_i - beta_i) s_i.
  if (stored_ > 0)
    dot = pass([&](std::ptrdiff_t, double v) { return h0_scale_ * v; }, y_.col(column(stored_ - 1)).data());
  for (int k = stored_ - 1; k >= 0; --k) {
    const int c = column(k);
    const double* y_next = k > 0 ? y_.col(column(k - 1)).data() : nullptr;
    dot = update(alpha_[c] - rho_[c] * dot, s_.col(c).data(), y_next);
  }
  // d = -r, and g.d.
  return pass([](std::ptrdiff_t, double v) { return -v; }, g);
}

}  // namespace arap
