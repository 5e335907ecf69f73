// Fill-reducing order for large matrices: nested dissection by breadth-first
// level structures (George 1973; George & Liu, "Computer Solution of Large
// Sparse Positive Definite Systems", 1981, ch. 8), with AMD on the small parts.
//
// A part of the matrix graph is cut in two by one breadth-first level: the
// smallest level that leaves at least a quarter of the part on each side,
// less its rows with no neighbour past it. Both sides are ordered the same
// way, recursively, and the separator comes after them. The search runs from
// one end of the part (the last row reached from its first row), and each
// side's from one end of the separator that cut it, so that successive cuts
// cross. On a surface mesh a level is a ring or an arc of about sqrt(rows)
// vertices, and the factor of a large mesh needs far fewer operations than
// with AMD's order alone (the 1M-vertex sphere: 22.6 against 42.5 billion
// multiply-adds, 48 M against 57 M entries).
#pragma once

#include <Eigen/SparseCore>
#include <functional>
#include <vector>

namespace arap {

// BlockCholesky orders a half of the matrix by nested dissection from this
// many rows on, down to parts of kDissectionLeafRows. A/B against AMD alone
// on the whole bind (CPU time, alternated): 0.79 on the 1M-vertex sphere and
// bar, 0.95-0.98 at 250k, no gain at 100k and 3-5% slower at 50k, where the
// breadth-first searches cost more than the operations they save.
constexpr long kNestedDissectionRows = 60000;
constexpr int kDissectionLeafRows = 3000;

// Orders `rows` of A (both triangles stored, symmetric pattern); returns them
// as indices into A. `order_leaf(rows)` orders a part at or below
// `leaf_rows` rows (AMD), and the separators. Deterministic.
std::vector<int> nested_dissection_order(const Eigen::SparseMatrix<double>& A, const std::vector<int>& rows,
                                         int leaf_rows,
                                         const std::function<std::vector<int>(const std::vector<int>&)>& order_leaf);

}  // namespace arap
