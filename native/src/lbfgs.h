// Limited-memory BFGS directions (Nocedal & Wright, "Numerical Optimization",
// algorithm 7.4, the two-loop recursion) whose initial inverse Hessian is a
// caller-given preconditioner. With the factored Laplacian as that
// preconditioner this is the quasi-Newton method of Liu, Bouaziz & Kavan 2017
// ("Quasi-Newton methods for real-time simulation of hyperelastic materials"):
// with an empty history the direction is exactly the local/global step.
#pragma once

#include <algorithm>

#include <Eigen/Core>

#include "vector_halves.h"

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

  // d = -H g, H the L-BFGS inverse Hessian on H0 = h0_scale * P, P applied by
  // preconditioner(v) (in place: v <- P v); h0_scale only counts once a pair is
  // stored (with none, d = -P g exactly). Returns g.d, the directional
  // derivative of half the energy. Long vectors are streamed in two halves, on
  // two threads if `threads` > 1 (the same result either way, see vector_halves.h).
  template <class Preconditioner>
  double direction(const double* g, double* d, const Preconditioner& preconditioner, int threads = 1,
                   double h0_scale = 1.0);

 private:
  int column(int k) const { return (newest_ - k + capacity_) % capacity_; }  // k = 0: newest
  int capacity_ = 0, stored_ = 0, newest_ = -1;
  Eigen::MatrixXd s_, y_;        // dimension by capacity, used as rings
  Eigen::VectorXd rho_, alpha_;  // 1 / (s.y) per pair; first-loop coefficients
};

namespace lbfgs_detail {

// q <- q + a x, and returns z.q of the updated q (z may be null: returns 0).
// Four partial sums in a fixed order: the compiler may vectorise the loop
// without reassociating, and the result does not depend on it.
inline double axpy_dot(double* q, double a, const double* x, const double* z, Eigen::Index n) {
  double d0 = 0, d1 = 0, d2 = 0, d3 = 0;
  Eigen::Index i = 0;
  if (z) {
    for (; i + 4 <= n; i += 4) {
      q[i] += a * x[i], q[i + 1] += a * x[i + 1], q[i + 2] += a * x[i + 2], q[i + 3] += a * x[i + 3];
      d0 += z[i] * q[i], d1 += z[i + 1] * q[i + 1], d2 += z[i + 2] * q[i + 2], d3 += z[i + 3] * q[i + 3];
    }
    for (; i < n; ++i) q[i] += a * x[i], d0 += z[i] * q[i];
  } else {
    for (; i < n; ++i) q[i] += a * x[i];
  }
  return (d0 + d1) + (d2 + d3);
}

// q <- c q, and returns z.q of the scaled q; the same fixed order of partial sums.
inline double scale_dot(double* q, double c, const double* z, Eigen::Index n) {
  double d0 = 0, d1 = 0, d2 = 0, d3 = 0;
  Eigen::Index i = 0;
  for (; i + 4 <= n; i += 4) {
    q[i] *= c, q[i + 1] *= c, q[i + 2] *= c, q[i + 3] *= c;
    d0 += z[i] * q[i], d1 += z[i + 1] * q[i + 1], d2 += z[i + 2] * q[i + 2], d3 += z[i + 3] * q[i + 3];
  }
  for (; i < n; ++i) q[i] *= c, d0 += z[i] * q[i];
  return (d0 + d1) + (d2 + d3);
}

}  // namespace lbfgs_detail

template <class Preconditioner>
double LbfgsHistory::direction(const double* g, double* d, const Preconditioner& preconditioner, int threads,
                               double h0_scale) {
  const Eigen::Index n = s_.rows();
  double* q = d;
  // q <- q + a x and z.q, over the halves (z may be null).
  auto update = [&](double a, const double* x, const double* z) {
    return sum_over_halves(n, threads, [&](std::ptrdiff_t b, std::ptrdiff_t e) {
      return lbfgs_detail::axpy_dot(q + b, a, x + b, z ? z + b : nullptr, e - b);
    });
  };
  // Each pass over q applies one pair's update and takes the dot product the
  // next pair needs, so q streams through memory once per pair, not twice.
  // First loop, newest pair to oldest: alpha_i = rho_i s_i.q, q <- q - alpha_i y_i.
  for_each_half(n, threads, [&](std::ptrdiff_t b, std::ptrdiff_t e, int) { std::copy(g + b, g + e, q + b); });
  double dot = stored_ > 0 ? update(0.0, g, s_.col(column(0)).data()) : 0.0;
  for (int k = 0; k < stored_; ++k) {
    const int c = column(k);
    const double a = alpha_[c] = rho_[c] * dot;
    const double* s_next = k + 1 < stored_ ? s_.col(column(k + 1)).data() : nullptr;
    dot = update(-a, y_.col(c).data(), s_next);
  }
  preconditioner(q);  // r = H0 q = h0_scale P q: the scale is applied in the pass that takes the next dot
  // Second loop, oldest to newest: beta_i = rho_i y_i.r, r <- r + (alpha_i - beta_i) s_i.
  if (stored_ > 0) {
    const double* z = y_.col(column(stored_ - 1)).data();
    dot = sum_over_halves(n, threads, [&](std::ptrdiff_t b, std::ptrdiff_t e) {
      return lbfgs_detail::scale_dot(q + b, h0_scale, z + b, e - b);
    });
  }
  for (int k = stored_ - 1; k >= 0; --k) {
    const int c = column(k);
    const double* y_next = k > 0 ? y_.col(column(k - 1)).data() : nullptr;
    dot = update(alpha_[c] - rho_[c] * dot, s_.col(c).data(), y_next);
  }
  // d = -r, and g.d.
  for_each_half(n, threads, [&](std::ptrdiff_t b, std::ptrdiff_t e, int) {
    for (std::ptrdiff_t i = b; i < e; ++i) q[i] = -q[i];
  });
  return update(0.0, g, g);
}

}  // namespace arap
