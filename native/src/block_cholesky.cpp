#include "block_cholesky.h"

#include <chrono>

#include <Eigen/OrderingMethods>

namespace arap {

bool BlockCholesky::factor(const Eigen::SparseMatrix<double>& A) {
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  n_ = A.rows();
  Eigen::AMDOrdering<int> amd;
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> Pinv;
  amd(A, Pinv);  // A holds both triangles; as in Eigen's own Cholesky, twist by the inverse
  const Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> P = Pinv.inverse();  // P.indices()[old] = new
  perm_.resize(n_);
  for (Eigen::Index old = 0; old < n_; ++old) perm_[P.indices()[old]] = static_cast<int>(old);
  Eigen::SparseMatrix<double> permuted;
  permuted = A.selfadjointView<Eigen::Lower>().twistedBy(P);
  const auto ordered = Clock::now();
  llt_.compute(permuted);
  ordering_ms_ = std::chrono::duration<double, std::milli>(ordered - start).count();
  factor_ms_ = std::chrono::duration<double, std::milli>(Clock::now() - ordered).count();
  if (llt_.info() != Eigen::Success) return false;
  // The up-looking factorization stores each column's diagonal first.
  const auto& L = llt_.matrixL().nestedExpression();
  inv_diag_.resize(n_);
  for (Eigen::Index j = 0; j < n_; ++j) {
    const int p = L.outerIndexPtr()[j];
    if (L.innerIndexPtr()[p] != j || !(L.valuePtr()[p] > 0)) return false;
    inv_diag_[j] = 1.0 / L.valuePtr()[p];
  }
  return true;
}

long BlockCholesky::nonzeros() const { return n_ ? static_cast<long>(llt_.matrixL().nestedExpression().nonZeros()) : 0; }

void BlockCholesky::solve_in_place(double* x, std::vector<double>& work) const {
  const auto& L = llt_.matrixL().nestedExpression();
  const int* outer = L.outerIndexPtr();
  const int* inner = L.innerIndexPtr();
  const double* value = L.valuePtr();
  work.resize(3 * n_);
  double* y = work.data();
  for (Eigen::Index i = 0; i < n_; ++i) {
    const double* src = x + 3 * perm_[i];
    y[3 * i] = src[0], y[3 * i + 1] = src[1], y[3 * i + 2] = src[2];
  }
  // Forward: L y = b, column by column, each entry applied to all three columns.
  for (Eigen::Index j = 0; j < n_; ++j) {
    double* yj = y + 3 * j;
    const double d = inv_diag_[j];
    const double a = yj[0] * d, b = yj[1] * d, c = yj[2] * d;
    yj[0] = a, yj[1] = b, yj[2] = c;
    for (int p = outer[j] + 1; p < outer[j + 1]; ++p) {
      double* yi = y + 3 * inner[p];
      const double l = value[p];
      yi[0] -= l * a, yi[1] -= l * b, yi[2] -= l * c;
    }
  }
  // Backward: L^T x = y; column j of L is row j of L^T.
  for (Eigen::Index j = n_ - 1; j >= 0; --j) {
    double a = y[3 * j], b = y[3 * j + 1], c = y[3 * j + 2];
    for (int p = outer[j] + 1; p < outer[j + 1]; ++p) {
      const double* yi = y + 3 * inner[p];
      const double l = value[p];
      a -= l * yi[0], b -= l * yi[1], c -= l * yi[2];
    }
    const double d = inv_diag_[j];
    y[3 * j] = a * d, y[3 * j + 1] = b * d, y[3 * j + 2] = c * d;
  }
  for (Eigen::Index i = 0; i < n_; ++i) {
    double* dst = x + 3 * perm_[i];
    dst[0] = y[3 * i], dst[1] = y[3 * i + 1], dst[2] = y[3 * i + 2];
  }
}

}  // namespace arap
