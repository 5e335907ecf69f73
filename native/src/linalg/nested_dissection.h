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
// On the bind's matrices of the procedural bars and spheres (a band of the
// surface free, the ends constrained) nested dissection gives 8-22% fewer
// factor entries from 50k vertices to 1M and 26-55% fewer multiply-adds
// (21.9 against 42.5 billion on the 1M sphere), and on closed spheres with one
// vertex constrained 14-23% fewer entries at 100k-1M; but on a box
// triangulated with all its diagonals one way (every edge weighted) it gives
// up to 50% more entries than AMD. Graphs with many hubs have wide levels and
// cut poorly too: with Volume::Infill's lattice nodes, each bound to the
// surface vertices of its cells, the 20k sphere's factor took 19% longer to
// apply than with AMD's order.
#pragma once

#include <Eigen/SparseCore>
#include <functional>
#include <vector>

namespace arap {

// From this many rows on, the bind (BlockCholesky's Ordering::Auto) orders by
// both and keeps the cheaper. Below, computing the second order costs more
// than it saves: Ordering::Fewest against Amd on the whole bind (CPU time,
// alternated) 1.10-1.17 at 50k vertices, 1.10-1.13 at 100k, 1.06 (sphere) and
// 1.15 (bar) at 250k; at 1M it pays: 0.87 (sphere) and 0.93 (bar).
constexpr long kDissectionRows = 200000;

// Parts of this many rows or fewer are not cut further: kept in the order the
// search met them. With 16 or 32 rows the ordering is a little faster, but
// the factor has 1-8% more entries than with 8 (250k-1M vertices), which
// every later triangular solve pays for.
constexpr int kDissectionLeafRows = 8;

// Orders `rows` of A (both triangles stored, symmetric pattern); returns them
// as indices into A. `order_uncut(rows)` orders a part that no level cuts
// into quarters (see above). Deterministic.
std::vector<int> nested_dissection_order(const Eigen::SparseMatrix<double>& A, const std::vector<int>& rows,
                                         int leaf_rows,
                                         const std::function<std::vector<int>(const std::vector<int>&)>& order_uncut);

}  // namespace arap
