// Sparse matrices and right-hand sides made in code for the Cholesky and
// ordering tests.
#pragma once

#include <Eigen/SparseCore>
#include <random>
#include <vector>

#include "arap/tools/procedural.h"

namespace arap_test {

using Sparse = Eigen::SparseMatrix<double>;

// A weighted graph Laplacian of a procedural mesh's edges (random positive
// weights) plus `shift` on the diagonal, both triangles stored: SPD for shift > 0.
inline Sparse mesh_matrix(const arap::procedural::TriMesh& mesh, double shift, unsigned seed) {
  const int n = static_cast<int>(mesh.vertices.rows());
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> weight(0.1, 2.0);
  std::vector<Eigen::Triplet<double>> t;
  for (Eigen::Index f = 0; f < mesh.triangles.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = mesh.triangles(f, k), b = mesh.triangles(f, (k + 1) % 3);
      if (a > b) continue;  // each edge once (closed mesh: the other triangle has b -> a)
      const double w = weight(rng);
      t.emplace_back(a, b, -w), t.emplace_back(b, a, -w), t.emplace_back(a, a, w), t.emplace_back(b, b, w);
    }
  for (int i = 0; i < n; ++i) t.emplace_back(i, i, shift);
  Sparse A(n, n);
  A.setFromTriplets(t.begin(), t.end());
  return A;
}

inline Eigen::MatrixXd random_rhs(Eigen::Index n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  Eigen::MatrixXd b(n, 3);
  for (Eigen::Index i = 0; i < b.size(); ++i) b.data()[i] = u(rng);
  return b;
}

}  // namespace arap_test
