// Edge weights of the ARAP energy and the Laplacian built from them.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "arap/options.h"

namespace arap {

struct WeightedEdge {
  int i, j;     // i < j
  double w;     // w_ij = w_ji
};

// Undirected edges of the non-degenerate triangles with their weights:
//   Cotan:        w_ij = (cot a_ij + cot b_ij) / 2   (a, b: angles opposite the edge)
//   CotanClamped: the same with each negative cotangent replaced by 0
//   Uniform:      w_ij = 1
// An edge of k > 2 triangles (non-manifold) sums all k opposite cotangents.
// Sorted by (i, j); edges whose total weight is exactly 0 are kept (they still
// connect the mesh for the uniform graph). Counts go to the optional outputs:
// skipped zero-area triangles and edges shared by more than two triangles.
struct EdgeCounts {
  int degenerate_triangles = 0;
  int nonmanifold_edges = 0;
};
std::vector<WeightedEdge> edge_weights(
    const Eigen::Ref<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>& rest,
    const Eigen::Ref<const Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>>& triangles, Weights kind,
    EdgeCounts* counts = nullptr);

}  // namespace arap
