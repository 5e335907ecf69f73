// Generalized winding number of a triangle soup (Jacobson et al. 2013,
// "Robust Inside-Outside Segmentation using Generalized Winding Numbers"):
// w(q) = 1/(4 pi) sum_t Omega_t(q), Omega_t the signed solid angle of triangle
// t seen from q. It is 1 inside and 0 outside a closed, outward-oriented
// surface, and degrades gracefully on open, non-manifold or self-intersecting
// ones (about 1/2 across a hole). Evaluated in O(log #F) per point with a
// bounding-volume tree whose far clusters are replaced by a dipole
// (Barill et al. 2018, "Fast Winding Numbers for Soups and Clouds", order 0).
#pragma once

#include <vector>

#include <Eigen/Core>

#include "arap/types.h"

namespace arap {

class WindingNumber {
 public:
  // positions: #V by 3; which: the triangles of `triangles` to use. Reads
  // positions and triangles while it lives: they must outlive it.
  WindingNumber(const Eigen::Ref<const Points>& positions, const Eigen::Ref<const Triangles>& triangles,
                const std::vector<int>& which);
  double operator()(const Eigen::Vector3d& q) const;

 private:
  struct Node {
    Eigen::Vector3d lo, hi;
    Eigen::Vector3d centre;  // area-weighted centroid of its triangles
    Eigen::Vector3d area;    // sum of the vector areas (1/2 (b - a) x (c - a))
    double total_area = 0;   // sum of the triangles' areas
    double radius = 0;       // from `centre` to the farthest corner of the box
    int first = 0, count = 0;  // leaf: triangles [first, first + count) of faces_
    int child = -1;            // inner: children child and child + 1
  };
  int build(int first, int count, int depth);
  double solid_angles(int node, const Eigen::Vector3d& q) const;

  // Corner k of the triangle in place t of the tree's order.
  Eigen::Vector3d corner(int t, int k) const { return positions_.row(triangles_(faces_[t], k)).transpose(); }

  Eigen::Ref<const Points> positions_;
  Eigen::Ref<const Triangles> triangles_;
  std::vector<int> faces_;  // the triangles in the tree's order
  std::vector<Node> nodes_;
};

}  // namespace arap
