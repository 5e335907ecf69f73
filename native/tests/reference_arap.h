// An independent, deliberately plain ARAP implementation for the tests:
// dense-ish textbook local/global with Eigen's own solver and JacobiSVD,
// sharing no code with the library beyond the weight computation.
#pragma once

#include <Eigen/SVD>
#include <Eigen/SparseCholesky>
#include <map>
#include <vector>

#include "arap/weights.h"

namespace arap_test {

struct ReferenceArap {
  arap::Points rest;
  std::vector<std::vector<std::pair<int, double>>> ring;  // neighbours and weights
  std::vector<int> constrained;

  ReferenceArap(const arap::Points& V, const arap::Triangles& F, const std::vector<int>& c, arap::Weights w)
      : rest(V), ring(V.rows()), constrained(c) {
    for (const auto& e : arap::edge_weights(V, F, w)) {
      ring[e.i].push_back({e.j, e.w});
      ring[e.j].push_back({e.i, e.w});
    }
  }

  std::vector<Eigen::Matrix3d> rotations(const arap::Points& P, double* energy) const {
    std::vector<Eigen::Matrix3d> R(rest.rows());
    double total = 0;
    for (Eigen::Index i = 0; i < rest.rows(); ++i) {
      Eigen::Matrix3d S = Eigen::Matrix3d::Zero();  // sum w e e'^T (the paper's S_i)
      for (auto [j, w] : ring[i])
        S += w * (rest.row(i) - rest.row(j)).transpose() * (P.row(i) - P.row(j));
      Eigen::JacobiSVD<Eigen::Matrix3d> svd(S, Eigen::ComputeFullU | Eigen::ComputeFullV);
      Eigen::Matrix3d U = svd.matrixU();
      R[i] = svd.matrixV() * U.transpose();
      if (R[i].determinant() < 0) {
        U.col(2) *= -1;
        R[i] = svd.matrixV() * U.transpose();
      }
      for (auto [j, w] : ring[i])
        total += w * ((P.row(i) - P.row(j)).transpose() - R[i] * (rest.row(i) - rest.row(j)).transpose()).squaredNorm();
    }
    if (energy) *energy = total;
    return R;
  }

  // Plain local/global from P (constrained rows already at their targets);
  // returns the energy after each iteration.
  std::vector<double> run(arap::Points& P, int iterations) const {
    const int n = static_cast<int>(rest.rows());
    std::vector<char> fixed(n, 0);
    for (int v : constrained) fixed[v] = 1;
    std::map<int, int> row;
    for (int v = 0; v < n; ++v)
      if (!fixed[v]) row[v] = static_cast<int>(row.size());
    std::vector<Eigen::Triplet<double>> t;
    for (auto [v, r] : row)
      for (auto [j, w] : ring[v]) {
        t.emplace_back(r, r, w);
        if (!fixed[j]) t.emplace_back(r, row[j], -w);
      }
    Eigen::SparseMatrix<double> L(row.size(), row.size());
    L.setFromTriplets(t.begin(), t.end());
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(L);
    std::vector<double> energies;
    for (int it = 0; it < iterations; ++it) {
      const auto R = rotations(P, nullptr);
      Eigen::MatrixXd b = Eigen::MatrixXd::Zero(row.size(), 3);
      for (auto [v, r] : row)
        for (auto [j, w] : ring[v]) {
          b.row(r) += (0.5 * w * (R[v] + R[j]) * (rest.row(v) - rest.row(j)).transpose()).transpose();
          if (fixed[j]) b.row(r) += w * P.row(j);
        }
      const Eigen::MatrixXd x = solver.solve(b);
      for (auto [v, r] : row) P.row(v) = x.row(r);
      double e;
      rotations(P, &e);
      energies.push_back(e);
    }
    return energies;
  }
};

}  // namespace arap_test
