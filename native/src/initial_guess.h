// First guesses for the local/global iteration.
#pragma once

#include <vector>

#include <Eigen/SparseCore>

#include "bound_mesh.h"
#include "linalg/spd_solve.h"

namespace arap {

// Laplacian editing with identity rotations: one global step,
// L_ff p_f = (L p)_f - L_fc p_c, i.e. rhs_i = 1/2 (s_i G_i + sum_j s_j g_ij) + sum of
// w~_ij p_j over constrained j (= G_i + ... when every stiffness is 1).
void laplacian_guess(const BoundMesh& m, const BlockCholesky& laplacian, const double* coupled, Points& P,
                     std::vector<double>& rhs, std::vector<double>& work);

// Lipman et al. 2004: the uniform-Laplacian coordinates delta = M p_rest kept in
// the least-squares sense, min |M p - delta|^2, with the constrained vertices as
// hard equalities: (M_f^T M_f) p_f = M_f^T (delta - M_c p_c). Its factor is made
// on first use and kept.
class DifferentialGuess {
 public:
  void prepare(const BoundMesh& m, const Triangles& triangles);
  bool prepared() const { return prepared_; }
  // P: constrained rows already hold their targets; free rows are overwritten.
  void solve(const BoundMesh& m, Points& P, std::vector<double>& work) const;

 private:
  bool prepared_ = false;
  Eigen::SparseMatrix<double> m_free_, m_constrained_;  // columns of M for free / constrained vertices
  Eigen::Matrix<double, Eigen::Dynamic, 3> delta_;
  BlockCholesky normal_;
};

}  // namespace arap
