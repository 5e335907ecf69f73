#include "contact/relative_motion.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace arap::contact {

void RelativeMotion::bind(std::vector<int> cluster_of, int clusters, const std::vector<int>& surface_vertices) {
  cluster_of_ = std::move(cluster_of);
  clusters_ = clusters;
  surface_vertices_ = surface_vertices;
  cluster_size_.assign(clusters_, 0);
  for (int v : surface_vertices_) ++cluster_size_[cluster_of_[v]];
  const size_t pairs = static_cast<size_t>(clusters_) * clusters_;
  room_.assign(pairs, 0.0);
  shift_.assign(pairs, 0.0);
  spread_.assign(cluster_of_.size(), 0.0);
  cluster_spread_.assign(clusters_, 0.0);
  motion0_.assign(3 * clusters_, 0.0);
  motion1_.assign(3 * clusters_, 0.0);
  box_.assign(6 * clusters_, 0.0);
}

void RelativeMotion::set_reference(const double* P, const int* triangles, long triangle_count, double margin,
                                   double activation) {
  const double inf = std::numeric_limits<double>::infinity();
  for (int k = 0; k < clusters_; ++k)
    for (int c = 0; c < 3; ++c) box_[6 * k + c] = inf, box_[6 * k + 3 + c] = -inf;
  // A cluster's box holds every triangle touching one of its vertices: a primitive
  // with a vertex in the cluster lies inside it.
  for (long f = 0; f < triangle_count; ++f) {
    const int* t = triangles + 3 * f;
    for (int i = 0; i < 3; ++i) {
      double* b = &box_[6 * cluster_of_[t[i]]];
      for (int j = 0; j < 3; ++j)
        for (int c = 0; c < 3; ++c) {
          const double x = P[3 * t[j] + c];
          b[c] = std::min(b[c], x), b[3 + c] = std::max(b[3 + c], x);
        }
    }
  }
  for (int a = 0; a < clusters_; ++a)
    for (int b = a; b < clusters_; ++b) {
      double gap2 = 0;
      for (int c = 0; c < 3; ++c) {
        const double g = std::max(box_[6 * a + c] - box_[6 * b + 3 + c], box_[6 * b + c] - box_[6 * a + 3 + c]);
        if (g > 0) gap2 += g * g;
      }
      const double room = std::max(margin, std::sqrt(gap2) - activation);
      room_[static_cast<size_t>(a) * clusters_ + b] = room_[static_cast<size_t>(b) * clusters_ + a] = room;
    }
}

void RelativeMotion::mean_motion(const double* reference, const double* P, double* into) {
  std::fill(into, into + 3 * clusters_, 0.0);
  for (int v : surface_vertices_)
    for (int c = 0; c < 3; ++c) into[3 * cluster_of_[v] + c] += P[3 * v + c] - reference[3 * v + c];
  for (int k = 0; k < clusters_; ++k)
    for (int c = 0; c < 3; ++c) into[3 * k + c] /= std::max(1, cluster_size_[k]);
}

bool RelativeMotion::holds(const double* reference, const double* P0, const double* P1) {
  const bool moving = P0 != P1;
  mean_motion(reference, P0, motion0_.data());
  if (moving) mean_motion(reference, P1, motion1_.data());
  const double* T1 = moving ? motion1_.data() : motion0_.data();
  std::fill(cluster_spread_.begin(), cluster_spread_.end(), 0.0);
  double largest_spread = 0;
  for (int v : surface_vertices_) {
    const int k = cluster_of_[v];
    double s0 = 0, s1 = 0;
    for (int c = 0; c < 3; ++c) {
      const double r = reference[3 * v + c];
      const double d0 = P0[3 * v + c] - r - motion0_[3 * k + c], d1 = P1[3 * v + c] - r - T1[3 * k + c];
      s0 += d0 * d0, s1 += d1 * d1;
    }
    spread_[v] = std::sqrt(std::max(s0, s1));
    cluster_spread_[k] = std::max(cluster_spread_[k], spread_[v]);
    largest_spread = std::max(largest_spread, spread_[v]);
  }
  double largest_shift = 0;
  for (int a = 0; a < clusters_; ++a)
    for (int b = a; b < clusters_; ++b) {
      double e0 = 0, e1 = 0;
      for (int c = 0; c < 3; ++c) {
        const double d0 = motion0_[3 * a + c] - motion0_[3 * b + c], d1 = T1[3 * a + c] - T1[3 * b + c];
        e0 += d0 * d0, e1 += d1 * d1;
      }
      const double shift = std::sqrt(std::max(e0, e1));
      const size_t ab = static_cast<size_t>(a) * clusters_ + b, ba = static_cast<size_t>(b) * clusters_ + a;
      shift_[ab] = shift_[ba] = shift;
      largest_shift = std::max(largest_shift, shift);
      if (!(cluster_spread_[a] + cluster_spread_[b] + shift < room_[ab])) return false;
    }
  largest_bound_ = 2 * largest_spread + largest_shift;
  return true;
}

}  // namespace arap::contact
