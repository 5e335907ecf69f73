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
// column at a time.
#pragma once

#include <Eigen/SparseCore>
#include <vector>

namespace arap {

// L by supernodes: supernode s holds the columns [first[s], first[s + 1]),
// whose rows are rows[row_start[s] .. row_start[s + 1]) (its own columns
// first, then the rows below, increasing); its values are a dense
// column-major block of (row count) by (column count) at value[value_start[s]]
// (the part above the diagonal unused). Column j's diagonal is in its
// supernode's row j - first[s], its entries below follow it. A factor with one
// column per supernode is plain compressed sparse columns.
struct SupernodalFactor {
  std::vector<int> first;  // m + 1 (n last)
  std::vector<long> row_start, value_start;  // m + 1
  std::vector<int> rows;
  std::vector<double> value;
  int supernodes() const { return first.empty() ? 0 : static_cast<int>(first.size()) - 1; }
  void clear() { *this = SupernodalFactor(); }
};

// Elimination tree of P A P^T (A: both triangles stored; order[new] = old,
// or the identity if empty): parent[j] > j, or -1 for a root.
std::vector<int> elimination_tree(const Eigen::SparseMatrix<double>& A, const std::vector<int>& order = {});

// An order of the columns in which every part [bounds[k], bounds[k+1]) stays
// where it is and, within it, the elimination tree is postordered (children
// before parents, each subtree contiguous); order[new] = old. Needs parents in
// the same or a later part, as for a matrix with no entry coupling two parts
// that precede the part that couples them.
std::vector<int> postorder_within_parts(const std::vector<int>& parent, const std::vector<int>& bounds);

// Factors A (both triangles stored, elimination tree postordered, see above).
// Supernodes never span two parts [bounds[k], bounds[k+1]). Returns false (L
// cleared) if A is not positive definite.
bool supernodal_cholesky(const Eigen::SparseMatrix<double>& A, const std::vector<int>& bounds, SupernodalFactor& L);

}  // namespace arap
