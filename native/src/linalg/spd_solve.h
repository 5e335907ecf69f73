// The sparse symmetric positive definite solve (the global step's Laplacian,
// the differential guess's normal equations): the one header of linalg/ that
// the ARAP code includes. The rest of linalg/ is its inside: the orderings
// (nested_dissection.h, Eigen's AMD), the numeric factorization
// (supernodal_cholesky.h) and its dense kernels (dense_kernels.h).
//
// BlockCholesky: sparse Cholesky of a symmetric positive definite matrix with
// a triangular solve that streams the factor once for three right-hand sides at
// a time (x, y, z of every vertex), instead of once per column as Eigen's solve does.
//
// Large matrices are split in two by a separator (one breadth-first level of
// the matrix graph): each half is ordered on its own (by AMD, or for the
// largest matrices by nested dissection: see Ordering) and the separator
// comes last, so the factor has no entry coupling the halves and the two
// halves of each triangular solve can run on two threads. A level much wider
// than a surface's ring (hubs, such as Volume Infill's lattice nodes) would
// fill the factor: such a matrix stays whole, unless its hubs are given to be
// ordered last (factor's last_rows), when the rest is split without them. The
// split does not depend on the thread count: the result is the same bit for bit.
//
// The numeric factorization is supernodal (supernodal_cholesky.h); Eigen's
// simplicial one, column by column, stays selectable for comparison.
#pragma once

#include <Eigen/SparseCore>
#include <functional>
#include <vector>

#include "sorted_column.h"  // insert_sorted, for writing the matrix that factor() takes
#include "supernodal_cholesky.h"

namespace arap {

class BlockCholesky {
 public:
  enum class Kernel { Supernodal, Simplicial };
  // Amd; Fewest: AMD's order or nested dissection's (nested_dissection.h),
  // whichever needs fewer multiply-adds to factor; Auto: Fewest from
  // kDissectionRows rows on, Amd below.
  enum class Ordering { Amd, Fewest, Auto };
  // Called once the order is known with the bytes the numeric factorization
  // is about to allocate (an estimate from the factor's column counts), before
  // it allocates them: it may throw to refuse.
  using BeforeNumeric = std::function<void(double bytes)>;
  // A: both triangles stored. Orders (see above), factors P A P^T = L L^T.
  // threads > 1 orders and (supernodal kernel) factors the two halves side by
  // side: the same factor bit for bit. Returns false if A is not SPD.
  // last_rows (distinct rows of A, e.g. hubs): ordered after all the others,
  // in the order given, with the separator; the others are split and ordered
  // as a matrix of their own (without last_rows, the order is unchanged).
  bool factor(const Eigen::SparseMatrix<double>& A, Kernel kernel = Kernel::Supernodal, int threads = 1,
              Ordering ordering = Ordering::Amd, const BeforeNumeric& before_numeric = nullptr,
              const std::vector<int>& last_rows = {});
  double ordering_ms() const { return ordering_ms_; }
  double factor_ms() const { return factor_ms_; }
  // x: rows() by 3 row-major, overwritten with A^-1 x. `work` is resized once.
  // threads > 1 solves the two halves side by side.
  void solve_in_place(double* x, std::vector<double>& work, int threads = 1) const;
  long nonzeros() const;
  // Columns of the first half, the second half and the separator.
  Eigen::Index first_half() const { return half_[0]; }
  Eigen::Index second_half() const { return half_[1]; }

 private:
  // Forward / backward substitution over columns [begin, end) of L; forward
  // updates to rows >= separator_ go to `separator` (3 per row) instead of y.
  void forward(double* y, Eigen::Index begin, Eigen::Index end, double* separator) const;
  void backward(double* y, Eigen::Index begin, Eigen::Index end) const;

  Eigen::Index n_ = 0;
  Eigen::Index half_[2] = {0, 0};
  Eigen::Index separator_ = 0;  // first separator column (= half_[0] + half_[1])
  Eigen::VectorXi perm_;  // row i of P A P^T is row perm_[i] of A
  SparseFactor L_;  // of P A P^T, the diagonal first in each column
  std::vector<double> inv_diag_;
  double ordering_ms_ = 0, factor_ms_ = 0;
};

}  // namespace arap
