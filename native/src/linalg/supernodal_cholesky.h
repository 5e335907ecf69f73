// Supernodal numeric Cholesky factorization A = L L^T of a sparse symmetric
// positive definite matrix, already ordered (no permutation here).
//
// Columns of L with the same row structure below the diagonal (a chain of the
// elimination tree) are grouped into supernodes, stored as dense column-major
// blocks, and small supernodes are merged with their parent when that adds few
// explicit zeros (relaxed amalgamation). The factorization is left-looking:
// each supernode gathers the updates of the supernodes below it as dense
// matrix products (C = L_d L_d^T on the rows they share), scatters them into
// its block, then factors its diagonal block and solves its off-diagonal rows,
// so nearly all the arithmetic runs in dense kernels instead of one sparse
// column at a time: dense_kernels.h's AVX2 + FMA ones where the processor has
// them (unless ARAP_NO_AVX2 is set in the environment), Eigen's otherwise; the
// products take AVX-512 registers where the processor also has those (unless
// ARAP_NO_AVX512 is set), with the same result as AVX2 bit for bit. The result
// is deterministic on a given processor; the AVX2 and Eigen paths round differently.
#pragma once

#include <Eigen/SparseCore>
#include <vector>

#include "runtime/large_buffer.h"

namespace arap {

// L in compressed sparse columns, the diagonal first in each column and the
// rows of a column in increasing order; the explicit zeros amalgamation
// introduced are dropped.
struct SparseFactor {
  std::vector<long> outer;  // n + 1 column starts
  LargeBuffer<int> inner;  // row of each entry
  LargeBuffer<double> value;
  void clear() { *this = SparseFactor(); }
};

// Elimination tree of P A P^T (A: both triangles stored; order[new] = old,
// or the identity if empty): parent[j] > j, or -1 for a root.
std::vector<int> elimination_tree(const Eigen::SparseMatrix<double>& A, const std::vector<int>& order = {});

// Number of entries in each column of L, the diagonal included, without
// forming L: Gilbert, Ng and Peyton's method ("An efficient algorithm to
// compute row and column counts for sparse Cholesky factorization", 1994).
// Row i of L is the subtree of the elimination tree spanned by the columns j
// with A(i, j) != 0, j < i; a column's count is the number of row subtrees
// holding it, summed over the tree from differences at each subtree's leaves
// and least common ancestors. Needs a postordered tree. A: the lower triangle of the
// ordered matrix (only entries below the diagonal are read).
std::vector<int> column_counts(const Eigen::SparseMatrix<double>& A, const std::vector<int>& parent);

// An order of the columns in which every part [bounds[k], bounds[k+1]) stays
// where it is and, within it, the elimination tree is postordered (children
// before parents, each subtree contiguous); order[new] = old. Needs parents in
// the same or a later part, as for a matrix with no entry coupling two parts
// that precede the part that couples them.
std::vector<int> postorder_within_parts(const std::vector<int>& parent, const std::vector<int>& bounds);

// Factors A (only its lower triangle is read; `parent`: its elimination tree, which
// must be postordered, see above; `count`: column_counts(A, parent)). Supernodes never span two parts
// [bounds[k], bounds[k+1]). With three parts (two halves that no entry
// couples, then their separator) and threads > 1 the halves are factored side
// by side; the result is the same bit for bit. Returns false (L cleared) if A
// is not positive definite.
bool supernodal_cholesky(const Eigen::SparseMatrix<double>& A, const std::vector<int>& parent,
                         const std::vector<int>& count, const std::vector<int>& bounds, SparseFactor& L,
                         int threads = 1);

}  // namespace arap
