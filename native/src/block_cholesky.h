// Sparse Cholesky of a symmetric positive definite matrix with a triangular
// solve that streams the factor once for three right-hand sides at a time
// (x, y, z of every vertex), instead of once per column as Eigen's solve does.
#pragma once

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <vector>

namespace arap {

class BlockCholesky {
 public:
  // A: both triangles stored. Orders with AMD, factors P A P^T = L L^T.
  // Returns false if A is not SPD.
  bool factor(const Eigen::SparseMatrix<double>& A);
  double ordering_ms() const { return ordering_ms_; }
  double factor_ms() const { return factor_ms_; }
  // x: rows() by 3 row-major, overwritten with A^-1 x. `work` is resized once.
  void solve_in_place(double* x, std::vector<double>& work) const;
  long nonzeros() const;

 private:
  Eigen::Index n_ = 0;
  Eigen::VectorXi perm_;  // row i of P A P^T is row perm_[i] of A
  Eigen::SimplicialLLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::NaturalOrdering<int>> llt_;
  std::vector<double> inv_diag_;
  double ordering_ms_ = 0, factor_ms_ = 0;
};

}  // namespace arap
