// Anderson acceleration of the local/global fixed-point map x -> G(x) on the
// free vertex positions (Peng et al. 2018, "Anderson Acceleration for Geometry
// Optimization and Physics Simulation"). The caller guards each accelerated
// point with the ARAP energy and falls back to G(x) when it is not lower.
#pragma once

#include <Eigen/Core>
#include <vector>

namespace arap {

class AndersonAccelerator {
 public:
  void reset(int window, Eigen::Index dimension);
  // x: the point G was evaluated at, g = G(x); writes the next point to `next`:
  // next = g - dG theta with theta = argmin |f - dF theta|, f = g - x, over the
  // last `window` differences of f and g.
  void step(const double* x, const double* g, double* next);

 private:
  int window_ = 0;
  int stored_ = 0;   // differences held (<= window)
  int newest_ = -1;  // column of the newest difference
  bool has_previous_ = false;
  Eigen::VectorXd previous_f_, previous_g_, f_;
  Eigen::MatrixXd delta_f_, delta_g_;  // dimension by window, used as a ring
  // Small dense parts live on the stack (window <= kMaxWindow): an iteration allocates nothing.
  static constexpr int kMaxWindow = 20;
  using Small = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxWindow, kMaxWindow>;
  using SmallVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxWindow, 1>;
  Small gram_;  // dF^T dF, updated one column at a time
};

}  // namespace arap
