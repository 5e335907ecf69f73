#include "spd_solve.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>

#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>

#include "nested_dissection.h"
#include "runtime/prefault.h"
#include "runtime/vector_halves.h"
#include "runtime/worker_threads.h"
#include "sorted_column.h"

namespace arap {

namespace {


// AMD order of the rows `rows` of A (both triangles), as indices into A.
// A's pattern is already symmetric, so Eigen's AMD runs on it directly,
// without AMDOrdering's A + A^T. AMD only reads the pattern and works in
// place with some elbow room: its input is a pattern-only copy (one byte per
// value) allocated with that room, so AMD does not reallocate and copy it.
// Index: the pattern's index type, which Eigen's AMD also sums indices in (below).
template <class Index>
std::vector<int> amd_order_in(const Eigen::SparseMatrix<double>& A, const std::vector<int>& rows,
                              std::vector<int>& local) {
  const int m = static_cast<int>(rows.size());
  const bool whole = m == A.rows();  // the whole matrix, rows in order
  for (int k = 0; k < m && !whole; ++k) local[rows[k]] = k;
  long entries = 0;
  for (int k = 0; k < m; ++k) entries += A.outerIndexPtr()[rows[k] + 1] - A.outerIndexPtr()[rows[k]];
  Eigen::SparseMatrix<char, Eigen::ColMajor, Index> pattern(m, m);
  pattern.reserve(entries + entries / 5 + 2 * m);  // Eigen's AMD grows the storage to this
  Index* inner = pattern.innerIndexPtr();
  Index* outer = pattern.outerIndexPtr();
  prefault(inner, sizeof(Index) * entries);
  long p = 0;
  outer[0] = 0;
  for (int k = 0; k < m; ++k) {
    const int* first = A.innerIndexPtr() + A.outerIndexPtr()[rows[k]];
    const int* last = A.innerIndexPtr() + A.outerIndexPtr()[rows[k] + 1];
    if (whole) {
      p = std::copy(first, last, inner + p) - inner;
    } else {  // rows within the part, renumbered: the order of A's rows is kept when `rows` is increasing
      const long begin = p;
      for (const int* i = first; i != last; ++i)
        if (local[*i] >= 0) inner[p++] = local[*i];
      std::sort(inner + begin, inner + p);
    }
    outer[k + 1] = static_cast<Index>(p);
  }
  pattern.resizeNonZeros(p);
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, Index> Pinv;
  Eigen::internal::minimum_degree_ordering(pattern, Pinv);  // Pinv.indices()[new] = old
  std::vector<int> out(m);
  for (int k = 0; k < m; ++k) out[k] = rows[static_cast<size_t>(Pinv.indices()[k])];
  for (int k = 0; k < m && !whole; ++k) local[rows[k]] = -1;
  return out;
}

// Eigen's AMD hashes each node by the sum of its neighbours' indices, in the
// pattern's index type, before taking it modulo the rows: with 32-bit indices
// a long list (a hub's, such as Volume Infill's lattice nodes on a mesh of a
// million vertices) overflows into a negative bucket and writes out of
// bounds. From 46 341 rows, where rows * rows passes 2^31, the pattern has
// 64-bit indices; the sums are then exact and the order is the same as with
// 32-bit indices wherever those did not overflow.
std::vector<int> amd_order(const Eigen::SparseMatrix<double>& A, const std::vector<int>& rows,
                           std::vector<int>& local) {
  if (rows.empty()) return {};
  const double m = static_cast<double>(rows.size());
  return m * m < 2147483648.0 ? amd_order_in<int>(A, rows, local) : amd_order_in<std::int64_t>(A, rows, local);
}

// A separator wider than this many times sqrt(rows) is not used: the matrix
// stays whole. On a surface a level is a ring of about 1-2 sqrt(rows) rows;
// hubs make levels wide (Volume Infill's lattice nodes, each joined to the
// surface vertices of its cells, give about 30 sqrt(rows)), and a wide
// separator ordered after both halves fills the factor many times over
// (docs/engine_internals.md).
constexpr double kWidestSeparator = 4;

// The rows of A not `last` (all of them when `last` is empty), split into two
// halves and a separator: breadth-first levels over those rows from the first
// (and from the first unreached row of every further component); the level at
// which half of the rows are reached is the separator, since edges only join
// rows of the same or adjacent levels. All go to part[0] when that level is
// wider than kWidestSeparator sqrt(rows), or when there are fewer than kSplitRows.
void split(const Eigen::SparseMatrix<double>& A, const std::vector<char>& last, std::vector<int> part[3]) {
  const int n = static_cast<int>(A.rows());
  auto kept = [&](Eigen::Index v) { return last.empty() || !last[v]; };
  int rows = 0;
  for (int v = 0; v < n; ++v) rows += kept(v);
  auto whole = [&] {
    for (int v = 0; v < n; ++v)
      if (kept(v)) part[0].push_back(v);
  };
  if (rows < kSplitRows) return whole();
  std::vector<int> level(n, -1), queue;
  queue.reserve(rows);
  for (int start = 0; start < n; ++start) {
    if (level[start] >= 0 || !kept(start)) continue;
    level[start] = 0;
    queue.push_back(start);
    for (size_t k = queue.size() - 1; k < queue.size(); ++k)
      for (Eigen::SparseMatrix<double>::InnerIterator it(A, queue[k]); it; ++it)
        if (level[it.row()] < 0 && kept(it.row()))
          level[it.row()] = level[queue[k]] + 1, queue.push_back(static_cast<int>(it.row()));
  }
  const int levels = *std::max_element(level.begin(), level.end()) + 1;
  std::vector<int> count(levels, 0);
  for (int l : level)
    if (l >= 0) ++count[l];
  int cut = 0;
  for (int below = 0; cut < levels && below + count[cut] < rows / 2; ++cut) below += count[cut];
  if (cut < levels && count[cut] > kWidestSeparator * std::sqrt(static_cast<double>(rows))) return whole();
  for (int v = 0; v < n; ++v)
    if (kept(v)) part[level[v] < cut ? 0 : level[v] > cut ? 1 : 2].push_back(v);
}

// The lower triangle of P A P^T (row i of it is row perm[i] of A; A
// symmetric, both triangles stored), the rows of each column in increasing
// order: column j is column perm[j] of A renumbered, its rows below the
// diagonal kept in increasing order as they come (insert_sorted; a long
// column is sorted once), so the writes are sequential. Half of the full permuted matrix, which the
// factorization does not read.
Eigen::SparseMatrix<double> permuted_lower(const Eigen::SparseMatrix<double>& A, const Eigen::VectorXi& perm) {
  const int n = static_cast<int>(A.rows());
  const int* outer = A.outerIndexPtr();
  const int* inner = A.innerIndexPtr();
  const double* value = A.valuePtr();
  std::vector<int> position(n);  // old -> new
  for (int i = 0; i < n; ++i) position[perm[i]] = i;
  Eigen::SparseMatrix<double> L(n, n);
  // Room for all of A's entries; about half are kept (all of them with the
  // diagonal, for a symmetric pattern): only those pages are mapped ahead.
  L.resizeNonZeros(A.nonZeros());
  int* start = L.outerIndexPtr();
  int* rows = L.innerIndexPtr();
  double* values = L.valuePtr();
  prefault(rows, sizeof(int) * ((A.nonZeros() + n) / 2));
  prefault(values, sizeof(double) * ((A.nonZeros() + n) / 2));
  int p = 0;
  std::vector<std::pair<int, double>> scratch;
  for (int j = 0; j < n; ++j) {
    start[j] = p;
    const bool long_column = outer[perm[j] + 1] - outer[perm[j]] >= kInsertionColumn;
    for (int q = outer[perm[j]]; q < outer[perm[j] + 1]; ++q) {
      const int i = position[inner[q]];
      if (i < j) continue;
      if (long_column)
        rows[p] = i, values[p++] = value[q];
      else
        insert_sorted(rows, values, start[j], p, i, value[q]);
    }
    if (long_column) sort_column(rows, values, start[j], p, scratch);
  }
  start[n] = p;
  L.resizeNonZeros(p);  // no reallocation: only the count shrinks
  return L;
}

// An order of A ready to factor: the permutation (perm[new] = old), with the
// elimination tree postordered within each part (an equivalent order: the
// same fill), the tree in that order, the permuted lower triangle and the
// factor's column counts.
struct OrderedMatrix {
  Eigen::VectorXi perm;
  std::vector<int> parent;
  Eigen::SparseMatrix<double> lower;
  std::vector<int> count;
};

OrderedMatrix ordered_matrix(const Eigen::SparseMatrix<double>& A, const std::vector<int>& order,
                             const std::vector<int>& bounds) {
  const int n = static_cast<int>(A.rows());
  const std::vector<int> tree = elimination_tree(A, order);
  const std::vector<int> post = postorder_within_parts(tree, bounds);
  OrderedMatrix m;
  m.perm.resize(n);
  m.parent.resize(n);
  std::vector<int> position(n);
  for (int i = 0; i < n; ++i) m.perm[i] = order[post[i]], position[post[i]] = i;
  for (int i = 0; i < n; ++i) m.parent[i] = tree[post[i]] < 0 ? -1 : position[tree[post[i]]];
  m.lower = permuted_lower(A, m.perm);
  m.count = column_counts(m.lower, m.parent);
  return m;
}

// What the numeric factorization allocates per entry of the factor: the
// supernodes' dense blocks (the factor's values, the upper triangles of the
// diagonal blocks and the zeros amalgamation adds), their row lists and the
// factor's row indices, with the update scratch (measured: docs/robustness.md).
constexpr double kNumericBytesPerEntry = 16;

// Multiply-adds of the factorization: the sum of the factor's column counts squared.
double factor_operations(const OrderedMatrix& m) {
  double operations = 0;
  for (int count : m.count) operations += static_cast<double>(count) * count;
  return operations;
}

}  // namespace

bool BlockCholesky::factor(const Eigen::SparseMatrix<double>& A, Kernel kernel, int threads, Ordering ordering,
                           const BeforeNumeric& before_numeric, const std::vector<int>& last_rows) {
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  n_ = A.rows();
  L_.clear();
  std::vector<char> last;
  if (!last_rows.empty()) {
    last.assign(n_, 0);
    for (int r : last_rows) last[r] = 1;
  }
  std::vector<int> part[3];
  split(A, last, part);
  half_[0] = static_cast<Eigen::Index>(part[0].size());
  half_[1] = static_cast<Eigen::Index>(part[1].size());
  separator_ = half_[0] + half_[1];
  const std::vector<int> bounds = {0, static_cast<int>(half_[0]), static_cast<int>(separator_), static_cast<int>(n_)};
  // The halves are ordered side by side on two threads (each with its own scratch); the order is deterministic.
  std::vector<int> local(n_, -1), second_local;
  const bool parallel = threads > 1 && !part[0].empty() && !part[1].empty();
  if (parallel) second_local.assign(n_, -1);
  // The three parts' orders, one after the other: by AMD, or by nested
  // dissection with AMD only for what it cannot cut.
  auto order_parts = [&](bool dissect) {
    auto order_part = [&](const std::vector<int>& rows, std::vector<int>& scratch) {
      auto by_amd = [&](const std::vector<int>& uncut) { return amd_order(A, uncut, scratch); };
      return dissect ? nested_dissection_order(A, rows, kDissectionLeafRows, by_amd) : by_amd(rows);
    };
    std::vector<int> part_order[3];
    run_side_by_side(
        parallel, [&] { part_order[0] = order_part(part[0], local); },
        [&] { part_order[1] = order_part(part[1], parallel ? second_local : local); });
    part_order[2] = order_part(part[2], local);
    std::vector<int> order;
    order.reserve(n_);
    for (const auto& ordered_part : part_order) order.insert(order.end(), ordered_part.begin(), ordered_part.end());
    order.insert(order.end(), last_rows.begin(), last_rows.end());
    return order;
  };
  OrderedMatrix chosen = ordered_matrix(A, order_parts(false), bounds);
  // Nested dissection's order is kept only if its factorization needs fewer
  // multiply-adds than AMD's (which is fewer depends on the mesh: nested_dissection.h).
  if (ordering == Ordering::Fewest || (ordering == Ordering::Auto && n_ >= kDissectionRows)) {
    OrderedMatrix dissected = ordered_matrix(A, order_parts(true), bounds);
    if (factor_operations(dissected) < factor_operations(chosen)) chosen = std::move(dissected);
  }
  if (before_numeric) {
    double entries = 0;
    for (int c : chosen.count) entries += c;
    before_numeric(kNumericBytesPerEntry * entries);
  }
  perm_ = std::move(chosen.perm);
  const Eigen::SparseMatrix<double>& permuted = chosen.lower;
  const auto ordered = Clock::now();
  auto factored = ordered;
  bool ok;
  if (kernel == Kernel::Supernodal) {
    ok = supernodal_cholesky(permuted, chosen.parent, chosen.count, bounds, L_, threads);
    factored = Clock::now();
  } else {
    Eigen::SimplicialLLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::NaturalOrdering<int>> llt(permuted);
    factored = Clock::now();  // the copy below is not part of Eigen's factorization
    ok = llt.info() == Eigen::Success;
    if (ok) {  // the up-looking factorization stores each column's diagonal first
      const auto& L = llt.matrixL().nestedExpression();
      L_.outer.assign(L.outerIndexPtr(), L.outerIndexPtr() + n_ + 1);
      L_.inner.assign(L.innerIndexPtr(), L.innerIndexPtr() + L.nonZeros());
      L_.value.assign(L.valuePtr(), L.valuePtr() + L.nonZeros());
    }
  }
  ordering_ms_ = std::chrono::duration<double, std::milli>(ordered - start).count();
  factor_ms_ = std::chrono::duration<double, std::milli>(factored - ordered).count();
  if (!ok) return L_.clear(), false;
  inv_diag_.resize(n_);
  for (Eigen::Index j = 0; j < n_; ++j) {
    const long p = L_.outer[j];
    if (L_.inner[p] != j || !(L_.value[p] > 0)) return L_.clear(), false;
    inv_diag_[j] = 1.0 / L_.value[p];
  }
  return true;
}

long BlockCholesky::nonzeros() const { return n_ && !L_.outer.empty() ? L_.outer[n_] : 0; }

void BlockCholesky::forward(double* y, Eigen::Index begin, Eigen::Index end, double* separator) const {
  const long* outer = L_.outer.data();
  const int* inner = L_.inner.data();
  const double* value = L_.value.data();
  // L y = b column by column, each entry applied to all three columns.
  for (Eigen::Index j = begin; j < end; ++j) {
    double* yj = y + 3 * j;
    const double d = inv_diag_[j];
    const double a = yj[0] * d, b = yj[1] * d, c = yj[2] * d;
    yj[0] = a, yj[1] = b, yj[2] = c;
    for (long p = outer[j] + 1; p < outer[j + 1]; ++p) {
      const Eigen::Index i = inner[p];
      double* yi = i < separator_ || !separator ? y + 3 * i : separator + 3 * (i - separator_);
      const double l = value[p];
      yi[0] -= l * a, yi[1] -= l * b, yi[2] -= l * c;
    }
  }
}

void BlockCholesky::backward(double* y, Eigen::Index begin, Eigen::Index end) const {
  const long* outer = L_.outer.data();
  const int* inner = L_.inner.data();
  const double* value = L_.value.data();
  // L^T x = y; column j of L is row j of L^T.
  for (Eigen::Index j = end - 1; j >= begin; --j) {
    double a = y[3 * j], b = y[3 * j + 1], c = y[3 * j + 2];
    for (long p = outer[j] + 1; p < outer[j + 1]; ++p) {
      const double* yi = y + 3 * inner[p];
      const double l = value[p];
      a -= l * yi[0], b -= l * yi[1], c -= l * yi[2];
    }
    const double d = inv_diag_[j];
    y[3 * j] = a * d, y[3 * j + 1] = b * d, y[3 * j + 2] = c * d;
  }
}

void BlockCholesky::solve_in_place(double* x, std::vector<double>& work, int threads) const {
  const Eigen::Index separator_rows = n_ - separator_;
  work.resize(3 * (n_ + 2 * separator_rows));
  double* y = work.data();
  double* partial[2] = {y + 3 * n_, y + 3 * (n_ + separator_rows)};  // each half's updates to the separator
  // Rows [begin, end) of y = P x, and back.
  auto gather = [&](Eigen::Index begin, Eigen::Index end) {
    for (Eigen::Index i = begin; i < end; ++i) {
      const double* src = x + 3 * perm_[i];
      y[3 * i] = src[0], y[3 * i + 1] = src[1], y[3 * i + 2] = src[2];
    }
  };
  auto scatter = [&](Eigen::Index begin, Eigen::Index end) {
    for (Eigen::Index i = begin; i < end; ++i) {
      double* dst = x + 3 * perm_[i];
      dst[0] = y[3 * i], dst[1] = y[3 * i + 1], dst[2] = y[3 * i + 2];
    }
  };
  // Each half permutes its own rows in and out beside its substitutions, so
  // that on two threads only the separator's work is serial.
  auto forward_half = [&](int h, Eigen::Index begin, Eigen::Index end) {
    gather(begin, end);
    std::fill(partial[h], partial[h] + 3 * separator_rows, 0.0);
    forward(y, begin, end, partial[h]);
  };
  auto backward_half = [&](Eigen::Index begin, Eigen::Index end) {
    backward(y, begin, end);
    scatter(begin, end);
  };
  const bool parallel = threads > 1 && half_[1] > 0;
  // The halves never touch each other's rows; their updates to the separator are
  // summed afterwards in a fixed order, whatever ran them.
  run_side_by_side(
      parallel,
      [&] {
        forward_half(0, 0, half_[0]);
        gather(separator_, n_);
      },
      [&] { forward_half(1, half_[0], separator_); });
  for (Eigen::Index k = 0; k < 3 * separator_rows; ++k) y[3 * separator_ + k] += partial[0][k] + partial[1][k];
  forward(y, separator_, n_, nullptr);
  backward(y, separator_, n_);
  run_side_by_side(
      parallel,
      [&] {
        backward_half(0, half_[0]);
        scatter(separator_, n_);
      },
      [&] { backward_half(half_[0], separator_); });
}

}  // namespace arap
