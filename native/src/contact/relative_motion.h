// How far two surface vertices can have moved relative to each other since the
// near-pair list was made: the list then holds for moves that carry whole
// regions along together (a limb swinging, the mesh dragged), not only for
// moves shorter than the list's margin.
//
// The surface vertices are split into clusters (subtrees of the contact BVH).
// For a straight move P0 -> P1, with D_v = P_v - R_v the motion of vertex v
// since the reference R and T_C the mean motion of cluster C,
//   |D_a - D_b| <= s_a + s_b + |T_C(a) - T_C(b)|,   s_v = |D_v - T_C(v)|,
// and each term is convex along the move, so its largest value on the move is
// at one of the ends. A pair of primitives that was not listed was at least
// `margin` beyond the activation distance, and at least its clusters' box
// distance apart; while every cluster pair's bound stays below that room, no
// unlisted pair can come within the activation distance.
#pragma once

#include <cstddef>
#include <vector>

namespace arap::contact {

class RelativeMotion {
 public:
  // `cluster_of`: per vertex, its cluster (-1: not on the surface).
  void bind(std::vector<int> cluster_of, int clusters, const std::vector<int>& surface_vertices);

  // Each cluster pair's room for the reference positions P (3 per vertex, where
  // the list is made): max(margin, box distance at P - activation), a
  // cluster's box holding every triangle (3 vertex indices each) that touches
  // one of its vertices.
  void set_reference(const double* P, const int* triangles, long triangle_count, double margin, double activation);

  // Whether the straight move P0 -> P1 stays within every cluster pair's room
  // (P0 == P1: a state), motions measured from `reference` (the positions
  // given to set_reference). Then bound(a, b) holds anywhere on the move.
  bool holds(const double* reference, const double* P0, const double* P1);
  double bound(int a, int b) const {
    return spread_[a] + spread_[b] + shift_[static_cast<std::size_t>(cluster_of_[a]) * clusters_ + cluster_of_[b]];
  }
  // No bound(a, b) exceeds this.
  double largest_bound() const { return largest_bound_; }

 private:
  void mean_motion(const double* reference, const double* P, double* into);  // T_C, 3 per cluster

  std::vector<int> cluster_of_, surface_vertices_, cluster_size_;
  int clusters_ = 0;
  std::vector<double> room_;           // clusters^2
  std::vector<double> shift_;          // clusters^2: largest |T_C - T_D| on the move
  std::vector<double> spread_;         // per vertex: largest s_v on the move
  std::vector<double> cluster_spread_; // per cluster: its vertices' largest s_v
  std::vector<double> motion0_, motion1_, box_;  // scratch: T_C at both ends; boxes (6 per cluster)
  double largest_bound_ = 0;
};

}  // namespace arap::contact
