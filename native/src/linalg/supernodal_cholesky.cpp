#include "supernodal_cholesky.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "dense_kernels.h"
#include "runtime/prefault.h"
#include "runtime/worker_threads.h"

namespace arap {

namespace {

using Sparse = Eigen::SparseMatrix<double>;
using Block = Eigen::Map<Eigen::MatrixXd, 0, Eigen::OuterStride<>>;
using ConstBlock = Eigen::Map<const Eigen::MatrixXd, 0, Eigen::OuterStride<>>;

// End of the part holding each column.
std::vector<int> part_ends(const std::vector<int>& bounds, int n) {
  std::vector<int> end(n, n);
  for (size_t k = 0; k + 1 < bounds.size(); ++k)
    for (int j = bounds[k]; j < bounds[k + 1]; ++j) end[j] = bounds[k + 1];
  return end;
}

// First column of each supernode (and n last). Fundamental supernodes first:
// column j + 1 joins column j's when it is j's parent and L's column j is
// column j + 1 plus the diagonal. Then a supernode is merged into its parent,
// from the root down, when the parent follows it and the merge adds few zeros
// (the thresholds of CHOLMOD's relaxed amalgamation: always up to 4 columns,
// up to 80% zeros up to 16 columns, 10% up to 48, then 5%).
std::vector<int> supernodes(const std::vector<int>& parent, const std::vector<int>& count,
                            const std::vector<int>& part_end) {
  const int n = static_cast<int>(parent.size());
  std::vector<int> start;
  for (int j = 0; j < n; ++j)
    if (j == 0 || parent[j - 1] != j || count[j - 1] != count[j] + 1 || part_end[j - 1] != part_end[j])
      start.push_back(j);
  const int m = static_cast<int>(start.size());
  start.push_back(n);
  std::vector<int> super_of(n);
  for (int s = 0; s < m; ++s)
    for (int j = start[s]; j < start[s + 1]; ++j) super_of[j] = s;
  std::vector<long> cols(m), rows(m), zeros(m, 0);
  std::vector<char> joins_previous(m, 0);
  for (int s = 0; s < m; ++s) cols[s] = start[s + 1] - start[s], rows[s] = count[start[s]];
  for (int s = m - 2; s >= 0; --s) {
    const int last = start[s + 1] - 1;
    if (parent[last] < 0 || super_of[parent[last]] != s + 1 || part_end[last] != part_end[last + 1]) continue;
    const long c = cols[s] + cols[s + 1], r = cols[s] + rows[s + 1];
    const long z = zeros[s] + zeros[s + 1] + cols[s] * (r - rows[s]);
    const double fraction = static_cast<double>(z) / static_cast<double>(c * (c + 1) / 2 + c * (r - c));
    if (!(c <= 4 || (c <= 16 && fraction < 0.8) || (c <= 48 && fraction < 0.1) || fraction < 0.05)) continue;
    joins_previous[s + 1] = 1;
    cols[s] = c, rows[s] = r, zeros[s] = z;
  }
  std::vector<int> merged;
  for (int s = 0; s <= m; ++s)
    if (s == m || !joins_previous[s]) merged.push_back(start[s]);
  return merged;
}

}  // namespace

std::vector<int> column_counts(const Sparse& A, const std::vector<int>& parent) {
  const int n = static_cast<int>(A.rows());
  std::vector<int> size(n, 1), first(n), delta(n), max_first(n, -1), previous_leaf(n, -1), ancestor(n);
  for (int j = 0; j < n; ++j)
    if (parent[j] >= 0) size[parent[j]] += size[j];
  for (int j = 0; j < n; ++j) {
    first[j] = j - size[j] + 1;  // the first descendant, in postorder
    delta[j] = size[j] == 1;     // a leaf of the tree
    ancestor[j] = j;
  }
  for (int j = 0; j < n; ++j) {
    if (parent[j] >= 0) --delta[parent[j]];
    for (Sparse::InnerIterator it(A, j); it; ++it) {
      const int i = static_cast<int>(it.row());
      // j is a leaf of row i's subtree unless an earlier leaf descends from j.
      if (i <= j || first[j] <= max_first[i]) continue;
      max_first[i] = first[j];
      const int previous = previous_leaf[i];
      previous_leaf[i] = j;
      ++delta[j];
      if (previous < 0) continue;
      int lca = previous;  // least common ancestor of the two leaves
      while (lca != ancestor[lca]) lca = ancestor[lca];
      for (int k = previous; k != lca;) {
        const int next = ancestor[k];
        ancestor[k] = lca;
        k = next;
      }
      --delta[lca];
    }
    if (parent[j] >= 0) ancestor[j] = parent[j];
  }
  for (int j = 0; j < n; ++j)
    if (parent[j] >= 0) delta[parent[j]] += delta[j];
  return delta;
}

std::vector<int> elimination_tree(const Sparse& A, const std::vector<int>& order) {
  const int n = static_cast<int>(A.rows());
  std::vector<int> parent(n, -1), ancestor(n, -1), position;
  if (!order.empty()) {
    position.resize(n);
    for (int k = 0; k < n; ++k) position[order[k]] = k;
  }
  // Liu's algorithm: row k's entries left of the diagonal attach, through
  // path-compressed ancestors, the roots of their subtrees to k.
  for (int k = 0; k < n; ++k)
    for (Sparse::InnerIterator it(A, order.empty() ? k : order[k]); it; ++it)
      for (int i = order.empty() ? static_cast<int>(it.row()) : position[it.row()]; i >= 0 && i < k;) {
        const int next = ancestor[i];
        ancestor[i] = k;
        if (next < 0) parent[i] = k;
        i = next;
      }
  return parent;
}

std::vector<int> postorder_within_parts(const std::vector<int>& parent, const std::vector<int>& bounds) {
  const int n = static_cast<int>(parent.size());
  const std::vector<int> end = part_ends(bounds, n);
  // Children lists in increasing order; a column whose parent lies in a later part is a root here.
  std::vector<int> head(n, -1), next(n, -1), order, stack;
  order.reserve(n);
  for (int j = n - 1; j >= 0; --j)
    if (parent[j] >= 0 && parent[j] < end[j]) next[j] = head[parent[j]], head[parent[j]] = j;
  for (int root = 0; root < n; ++root) {
    if (parent[root] >= 0 && parent[root] < end[root]) continue;
    stack.push_back(root);
    while (!stack.empty()) {
      const int p = stack.back();
      const int child = head[p];
      if (child < 0) {
        stack.pop_back();
        order.push_back(p);
      } else {
        head[p] = next[child];
        stack.push_back(child);
      }
    }
  }
  return order;
}

namespace {

// The supernodes' columns and the row structure of each: its own columns,
// then (sorted) the rows below them of A's columns and of its children's
// structures. Supernode s's dense block (height x width, column-major) starts
// at value_start[s] of the values.
struct SupernodeLayout {
  std::vector<int> first;     // first column of each supernode, n last
  std::vector<int> super_of;  // column -> supernode
  std::vector<int> rows;      // supernode s's rows: [row_start[s], row_start[s + 1])
  std::vector<long> row_start, value_start;
  int count() const { return static_cast<int>(first.size()) - 1; }
  int width(int s) const { return first[s + 1] - first[s]; }
  long height(int s) const { return row_start[s + 1] - row_start[s]; }
};

SupernodeLayout supernode_layout(const Sparse& A, const std::vector<int>& parent, const std::vector<int>& count,
                                 const std::vector<int>& bounds) {
  const int n = static_cast<int>(A.rows());
  SupernodeLayout layout;
  std::vector<int>& first = layout.first;
  first = supernodes(parent, count, part_ends(bounds, n));
  const int m = layout.count();
  layout.super_of.resize(n);
  for (int s = 0; s < m; ++s)
    for (int j = first[s]; j < first[s + 1]; ++j) layout.super_of[j] = s;
  std::vector<int> child_head(m, -1), child_next(m, -1);
  for (int s = m - 1; s >= 0; --s) {
    const int p = parent[first[s + 1] - 1];
    if (p >= 0) child_next[s] = child_head[layout.super_of[p]], child_head[layout.super_of[p]] = s;
  }
  std::vector<long>& row_start = layout.row_start;
  std::vector<long>& value_start = layout.value_start;
  std::vector<int>& rows = layout.rows;
  row_start.assign(m + 1, 0);
  value_start.assign(m + 1, 0);
  std::vector<int> mark(n, -1);
  rows.reserve(2 * static_cast<size_t>(A.nonZeros()));
  for (int s = 0; s < m; ++s) {
    const int begin = first[s], end = first[s + 1];
    for (int j = begin; j < end; ++j) rows.push_back(j);
    const size_t below = rows.size();
    auto add = [&](int i) {
      if (i >= end && mark[i] != s) mark[i] = s, rows.push_back(i);
    };
    for (int j = begin; j < end; ++j)
      for (Sparse::InnerIterator it(A, j); it; ++it) add(static_cast<int>(it.row()));
    for (int c = child_head[s]; c >= 0; c = child_next[c])
      for (long k = row_start[c] + (first[c + 1] - first[c]); k < row_start[c + 1]; ++k) add(rows[k]);
    std::sort(rows.begin() + static_cast<long>(below), rows.end());
    row_start[s + 1] = static_cast<long>(rows.size());
    value_start[s + 1] = value_start[s] + (row_start[s + 1] - row_start[s]) * (end - begin);
  }
  return layout;
}

// Left-looking numeric factorization. Each factored supernode d waits in
// the list of the next supernode its rows reach (cursor[d]: its first row
// not yet used); when that supernode comes, d's update is
// C = L_d(rows from the cursor, :) L_d(rows inside the target, :)^T,
// subtracted through `map` (row -> position in the target's block).
// Each block is zeroed when its supernode comes (in cache, just before use), not all up front.
class LeftLooking {
 public:
  // What one thread needs of its own: the waiting lists it pushes to and scratch.
  struct Workspace {
    std::vector<int> map, waiting_head, relative;
    std::vector<double> update, pack;
  };

  LeftLooking(const Sparse& A, const SupernodeLayout& layout)
      : A_(A),
        layout_(layout),
        value_(static_cast<size_t>(layout.value_start[layout.count()])),
        waiting_next_(layout.count(), -1),
        cursor_(layout.count()) {
    prefault_buffer(value_);
  }

  Workspace make_workspace() const {
    Workspace w;
    w.map.resize(A_.rows());
    w.waiting_head.assign(layout_.count(), -1);
    return w;
  }

  // Factors supernodes [from, to); false at the first whose diagonal block is not positive definite.
  bool factor_range(int from, int to, Workspace& w) {
    for (int s = from; s < to; ++s)
      if (!factor_supernode(s, w)) return false;
    return true;
  }

  // Puts `second`'s waiting lists of supernodes [from, end) ahead of `main`'s,
  // as one thread factoring both ranges in turn would have left them.
  void join_waiting_lists(int from, Workspace& main, const Workspace& second) {
    for (int t = from; t < layout_.count(); ++t) {
      int head = second.waiting_head[t];
      if (head < 0) continue;
      int tail = head;
      while (waiting_next_[tail] >= 0) tail = waiting_next_[tail];
      waiting_next_[tail] = main.waiting_head[t];
      main.waiting_head[t] = head;
    }
  }

  LargeBuffer<double>& values() { return value_; }

 private:
  // Factors supernode s; false if its diagonal block is not positive definite.
  bool factor_supernode(int s, Workspace& w) {
    const int begin = layout_.first[s], width = layout_.width(s);
    const int* row = layout_.rows.data() + layout_.row_start[s];
    const long height = layout_.height(s);
    double* block = value_.data() + layout_.value_start[s];
    std::fill(block, block + height * width, 0.0);
    for (long k = 0; k < height; ++k) w.map[row[k]] = static_cast<int>(k);
    for (int j = begin; j < begin + width; ++j)
      for (Sparse::InnerIterator it(A_, j); it; ++it)
        if (it.row() >= j) block[(j - begin) * height + w.map[it.row()]] = it.value();
    for (int d = w.waiting_head[s]; d >= 0;) {
      const int next_d = waiting_next_[d];
      subtract_update(d, s, block, w);
      d = next_d;
    }
    if (!factor_block(block, height, width, w)) return false;
    if (height > width) {
      cursor_[s] = width;
      wait_for(s, layout_.super_of[row[width]], w);
    }
    return true;
  }

  // Subtracts supernode d's update from supernode s's block, then puts d in
  // the waiting list of the next supernode its rows reach.
  void subtract_update(int d, int s, double* block, Workspace& w) {
    const int begin = layout_.first[s], end = layout_.first[s + 1];
    const long height = layout_.height(s);
    const int* drow = layout_.rows.data() + layout_.row_start[d];
    const long dheight = layout_.height(d);
    const long p1 = cursor_[d];
    long p2 = p1;
    while (p2 < dheight && drow[p2] < end) ++p2;
    const long tall = dheight - p1, wide = p2 - p1;
    const ConstBlock Ld(value_.data() + layout_.value_start[d], dheight, layout_.width(d),
                        Eigen::OuterStride<>(dheight));
    // C, column-major with leading dimension ldc: only r >= c is read.
    std::vector<double>& update = w.update;
    long ldc = tall;
    if (avx2_) {
      ldc = product_rows(tall);
      if (update.size() < static_cast<size_t>(ldc * product_columns(wide))) update.resize(ldc * product_columns(wide));
      lower_product_avx2(Ld.data() + p1, dheight, tall, wide, Ld.cols(), update.data(), w.pack, avx512_);
    } else {
      if (update.size() < static_cast<size_t>(tall * wide)) update.resize(tall * wide);
      Eigen::Map<Eigen::MatrixXd> C(update.data(), tall, wide);
      C.noalias() = Ld.middleRows(p1, tall) * Ld.middleRows(p1, wide).transpose();
    }
    std::vector<int>& relative = w.relative;
    relative.resize(tall);
    for (long r = 0; r < tall; ++r) relative[r] = w.map[drow[p1 + r]];
    const bool contiguous = relative[tall - 1] - relative[0] == tall - 1;  // the usual case: no gather
    for (long c = 0; c < wide; ++c) {
      double* column = block + (drow[p1 + c] - begin) * height;
      const double* u = update.data() + c * ldc;
      if (contiguous) {
        double* target = column + relative[0];
        for (long r = c; r < tall; ++r) target[r] -= u[r];
      } else {
        for (long r = c; r < tall; ++r) column[relative[r]] -= u[r];
      }
    }
    cursor_[d] = p2;
    if (p2 < dheight) wait_for(d, layout_.super_of[drow[p2]], w);
  }

  // L11 L11^T = A11 (dense Cholesky), then L21 = A21 L11^-T; false if A11 is not positive definite.
  bool factor_block(double* block, long height, int width, Workspace& w) {
    Block diagonal(block, width, width, Eigen::OuterStride<>(height));
    if (width <= kSmallCholesky) {
      if (!small_cholesky_in_place(block, height, width)) return false;
    } else if (avx2_) {
      if (!blocked_cholesky_avx2(block, height, width, w.update, w.pack, avx512_)) return false;
    } else {
      Eigen::Ref<Eigen::MatrixXd> diagonal_ref(diagonal);
      // Eigen::LLT's own in-place factorization, without the L1 norm LLT computes first (for rcond()).
      if (Eigen::internal::llt_inplace<double, Eigen::Lower>::blocked(diagonal_ref) != -1) return false;
    }
    if (height > width) {
      if (avx2_) {
        solve_transposed_avx2(block + width, height, height - width, block, height, width, w.pack);
      } else {
        Block below(block + width, height - width, width, Eigen::OuterStride<>(height));
        diagonal.triangularView<Eigen::Lower>().transpose().solveInPlace<Eigen::OnTheRight>(below);
      }
    }
    return true;
  }

  void wait_for(int d, int t, Workspace& w) { waiting_next_[d] = w.waiting_head[t], w.waiting_head[t] = d; }

  const Sparse& A_;
  const SupernodeLayout& layout_;
  LargeBuffer<double> value_;
  std::vector<int> waiting_next_;
  std::vector<long> cursor_;
  const bool avx2_ = have_avx2_fma() && !std::getenv("ARAP_NO_AVX2");
  const bool avx512_ = avx2_ && have_avx512f() && !std::getenv("ARAP_NO_AVX512");
};

// With two halves and a separator (no entry couples the halves), the halves
// are independent until the separator: they may run side by side, each
// pushing to its own waiting lists. The separator's lists are then joined
// as one thread would have left them (the second half's pushes above the
// first's), so the updates are added in the same order: the same result.
bool factor_all(LeftLooking& factorization, const SupernodeLayout& layout, const std::vector<int>& bounds,
                int threads) {
  const std::vector<int>& first = layout.first;
  const int m = layout.count();
  LeftLooking::Workspace main_work = factorization.make_workspace();
  int split = m, separator = m;  // first supernode of the second half and of the separator
  if (bounds.size() == 4) {
    split = static_cast<int>(std::lower_bound(first.begin(), first.end() - 1, bounds[1]) - first.begin());
    separator = static_cast<int>(std::lower_bound(first.begin(), first.end() - 1, bounds[2]) - first.begin());
  }
  if (!(threads > 1 && split > 0 && separator > split)) return factorization.factor_range(0, m, main_work);
  LeftLooking::Workspace second_work = factorization.make_workspace();
  bool ok_first = false, ok_second = false;
  run_side_by_side(
      true, [&] { ok_first = factorization.factor_range(0, split, main_work); },
      [&] { ok_second = factorization.factor_range(split, separator, second_work); });
  if (!(ok_first && ok_second)) return false;
  factorization.join_waiting_lists(separator, main_work, second_work);
  return factorization.factor_range(separator, m, main_work);
}

// Compressed columns without the zeros amalgamation added (an entry outside
// L's structure is a sum of products each with an exact zero: exactly zero),
// written over the blocks' own storage: an entry never moves forward. False
// (L cleared) if a pivot is not a finite number > 0.
bool compress_columns(const SupernodeLayout& layout, const std::vector<int>& count, LargeBuffer<double>& value,
                      SparseFactor& L) {
  const std::vector<int>& first = layout.first;
  const int m = layout.count(), n = first[m];
  L.outer.assign(n + 1, 0);
  long stored = 0;
  for (int s = 0; s < m; ++s) {
    const long width = layout.width(s), height = layout.height(s);
    stored += width * height - width * (width - 1) / 2;
  }
  L.inner.resize(static_cast<size_t>(stored));  // an upper bound, cut below
  long structural = 0;  // L's own entries, the most that is kept: only those pages are mapped ahead
  for (int c : count) structural += c;
  prefault_buffer(L.inner, static_cast<size_t>(std::min(structural, stored)));
  int* inner = L.inner.data();
  long p = 0;
  for (int s = 0; s < m; ++s) {
    const int* row = layout.rows.data() + layout.row_start[s];
    const long height = layout.height(s);
    for (int c = 0; c < layout.width(s); ++c) {
      const double* column = value.data() + layout.value_start[s] + c * height;
      if (!(column[c] > 0) || !std::isfinite(column[c])) return L.clear(), false;
      if (height - c == count[first[s] + c]) {
        // No row of the block is outside the column's structure (no merge added
        // any): copied whole, without the test that chains each entry to the last.
        std::copy(row + c, row + height, inner + p);
        std::copy(column + c, column + height, value.data() + p);  // moves back or stays: a forward copy is safe
        p += height - c;
        L.outer[first[s] + c + 1] = p;
        continue;
      }
      inner[p] = row[c], value[p++] = column[c];
      for (long r = c + 1; r < height; ++r) {
        const double v = column[r];
        inner[p] = row[r], value[p] = v;  // kept only if nonzero: p moves on
        p += v != 0;
      }
      L.outer[first[s] + c + 1] = p;
    }
  }
  L.inner.resize(static_cast<size_t>(p));
  value.resize(static_cast<size_t>(p));
  L.value = std::move(value);
  return true;
}

}  // namespace

bool supernodal_cholesky(const Sparse& A, const std::vector<int>& parent, const std::vector<int>& count,
                         const std::vector<int>& bounds, SparseFactor& L, int threads) {
  L.clear();
  const SupernodeLayout layout = supernode_layout(A, parent, count, bounds);
  LeftLooking factorization(A, layout);
  if (!factor_all(factorization, layout, bounds, threads)) return L.clear(), false;
  return compress_columns(layout, count, factorization.values(), L);
}

}  // namespace arap
