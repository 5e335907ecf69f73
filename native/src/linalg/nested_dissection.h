// Fill-reducing order of the bind's matrix: nested dissection by breadth-first
// level structures (George 1973; George & Liu, "Computer Solution of Large
// Sparse Positive Definite Systems", 1981, ch. 8), down to parts of a few rows.
//
// A part of the matrix graph is cut in two by one breadth-first level: the
// smallest level that leaves at least a quarter of the part on each side,
// less its rows with no neighbour past it. Both sides are ordered the same
// way, recursively, and the separator comes after them. The search runs from
// one end of the part (the last row reached from its first row), and each
// side's from one end of the separator that cut it, so that successive cuts
// cross. On a surface mesh a level is a ring or an arc of about sqrt(rows)
// vertices. A part no level cuts into quarters (a hub with many neighbours,
// a clique) is handed to a general order (AMD).
//
// Which of this order and AMD's needs fewer operations depends on the mesh,
// so BlockCholesky computes both and keeps the cheaper (Ordering::Fewest).
// Nested dissection wins on the large bars and spheres; AMD on a box
// triangulated with all its diagonals one way, and on graphs with many hubs,
// whose levels are wide (Volume::Infill's lattice nodes, each bound to the
// surface vertices of its cells). The measurements: docs/engine_internals.md.
#pragma once

#include <Eigen/SparseCore>
#include <functional>
#include <vector>

namespace arap {

// From this many rows on, the bind (BlockCholesky's Ordering::Auto) orders by
// both and keeps the cheaper. Below, computing the second order costs more
// than it saves (the whole bind, Ordering::Fewest against Amd:
// docs/engine_internals.md).
constexpr long kDissectionRows = 200000;

// Parts of this many rows or fewer are not cut further: kept in the order the
// search met them. Larger leaves order a little faster but leave more entries
// in the factor, which every later triangular solve pays for.
constexpr int kDissectionLeafRows = 8;

// Orders `rows` of A (both triangles stored, symmetric pattern); returns them
// as indices into A. `order_uncut(rows)` orders a part that no level cuts
// into quarters (see above). Deterministic.
std::vector<int> nested_dissection_order(const Eigen::SparseMatrix<double>& A, const std::vector<int>& rows,
                                         int leaf_rows,
                                         const std::function<std::vector<int>(const std::vector<int>&)>& order_uncut);

}  // namespace arap
