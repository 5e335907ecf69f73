// The stop on the pose: whether an iteration that converges linearly has come
// within a given distance of its limit. The energy test alone cannot say so
// where the energy is flat (soft modes: a small decrease, yet far to go).
// Steps of sizes s_k (the largest move of a vertex) that shrink at a rate rho
// leave at most sum_{j>k} s_j = s_k rho / (1 - rho) of the way. rho is the
// geometric mean over the last kWindow steps, (s_k / s_{k-W})^(1/W), as one
// quasi-Newton step alone may be long or short (a line search's cut); the
// largest step of the window stands for s_k.
#pragma once

#include <array>

namespace arap {

class PoseStop {
 public:
  static constexpr int kWindow = 4;

  // Forgets the steps (a new solve, or the iteration starting over). `tolerance`: the distance
  // left that counts as settled (internal units); 0 turns the stop off.
  void start(double tolerance) { tolerance_ = tolerance, count_ = 0; }
  bool on() const { return tolerance_ > 0; }
  // The size of the step just taken.
  void record(double step);
  // The estimated distance to the limit: infinite until kWindow + 1 steps are known or while they do not shrink.
  double distance_left() const;
  // Off, or within the tolerance of the limit.
  bool settled() const { return !on() || distance_left() <= tolerance_; }

 private:
  double tolerance_ = 0;
  std::array<double, kWindow + 1> steps_{};  // a ring; the newest at (count_ - 1) % size
  long count_ = 0;
};

// The largest Euclidean length of the rows of s (#rows by 3, row-major).
double largest_row(const double* s, long rows);

}  // namespace arap
