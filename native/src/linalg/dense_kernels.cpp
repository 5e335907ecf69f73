#include "dense_kernels.h"

#include <algorithm>
#include <cmath>
#include <cstddef>

// GCC and Clang on x86-64: the kernels are compiled for AVX2 + FMA whatever
// the flags of the rest of the build; elsewhere they are never called.
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define ARAP_AVX2_KERNELS 1
#else
#define ARAP_AVX2_KERNELS 0
#endif

namespace arap {

#if ARAP_AVX2_KERNELS
namespace {

// Four doubles: one AVX register inside the AVX2 function (GCC and Clang
// vector extensions); unaligned loads and stores go through v4u.
typedef double v4 __attribute__((vector_size(32)));
typedef double v4u __attribute__((vector_size(32), aligned(8), may_alias));

constexpr long kRows = 8, kColumns = 4;  // a tile of C: 8 accumulators of 4
constexpr long kInPlaceColumns = 16;     // products of up to this many columns read A in place

// One 8 by 4 tile of C: C(r, c) = sum_t a(r, t) b(c, t), with a(r, t) =
// a[r + t * a_step] (8 consecutive rows) and b(c, t) = b[c + t * b_step]
// (4 consecutive rows).
__attribute__((target("avx2,fma"), always_inline)) inline void tile_avx2(const double* a, long a_step, const double* b,
                                                                       long b_step, long w, double* c, long ldc) {
  v4 c0a = {0, 0, 0, 0}, c0b = c0a, c1a = c0a, c1b = c0a, c2a = c0a, c2b = c0a, c3a = c0a, c3b = c0a;
  for (long t = 0; t < w; ++t) {
    const v4 lo = *reinterpret_cast<const v4u*>(a + a_step * t);
    const v4 hi = *reinterpret_cast<const v4u*>(a + a_step * t + 4);
    const double* bt = b + b_step * t;
    v4 s = {bt[0], bt[0], bt[0], bt[0]};
    c0a += lo * s, c0b += hi * s;
    s = v4{bt[1], bt[1], bt[1], bt[1]};
    c1a += lo * s, c1b += hi * s;
    s = v4{bt[2], bt[2], bt[2], bt[2]};
    c2a += lo * s, c2b += hi * s;
    s = v4{bt[3], bt[3], bt[3], bt[3]};
    c3a += lo * s, c3b += hi * s;
  }
  *reinterpret_cast<v4u*>(c) = c0a, *reinterpret_cast<v4u*>(c + 4) = c0b;
  c += ldc;
  *reinterpret_cast<v4u*>(c) = c1a, *reinterpret_cast<v4u*>(c + 4) = c1b;
  c += ldc;
  *reinterpret_cast<v4u*>(c) = c2a, *reinterpret_cast<v4u*>(c + 4) = c2b;
  c += ldc;
  *reinterpret_cast<v4u*>(c) = c3a, *reinterpret_cast<v4u*>(c + 4) = c3b;
}

// Eight doubles: one AVX-512 register inside the AVX-512 functions.
typedef double v8 __attribute__((vector_size(64)));
typedef double v8u __attribute__((vector_size(64), aligned(8), may_alias));

// tile_avx2 for two groups of 8 rows (the second at a + group_step), one
// AVX-512 register per group and column: twice the rows for each load of the
// right-hand factor. Every entry is the same sequence of fused multiply-adds
// as in tile_avx2: the same result bit for bit.
__attribute__((target("avx512f,avx2,fma"))) void tile16_avx512(const double* a, long group_step, long a_step,
                                                               const double* b, long b_step, long w, double* c,
                                                               long ldc) {
  v8 c0a = {}, c0b = {}, c1a = {}, c1b = {}, c2a = {}, c2b = {}, c3a = {}, c3b = {};
  for (long t = 0; t < w; ++t) {
    const v8 lo = *reinterpret_cast<const v8u*>(a + a_step * t);
    const v8 hi = *reinterpret_cast<const v8u*>(a + group_step + a_step * t);
    const double* bt = b + b_step * t;
    v8 s = {bt[0], bt[0], bt[0], bt[0], bt[0], bt[0], bt[0], bt[0]};
    c0a += lo * s, c0b += hi * s;
    s = v8{bt[1], bt[1], bt[1], bt[1], bt[1], bt[1], bt[1], bt[1]};
    c1a += lo * s, c1b += hi * s;
    s = v8{bt[2], bt[2], bt[2], bt[2], bt[2], bt[2], bt[2], bt[2]};
    c2a += lo * s, c2b += hi * s;
    s = v8{bt[3], bt[3], bt[3], bt[3], bt[3], bt[3], bt[3], bt[3]};
    c3a += lo * s, c3b += hi * s;
  }
  *reinterpret_cast<v8u*>(c) = c0a, *reinterpret_cast<v8u*>(c + 8) = c0b;
  c += ldc;
  *reinterpret_cast<v8u*>(c) = c1a, *reinterpret_cast<v8u*>(c + 8) = c1b;
  c += ldc;
  *reinterpret_cast<v8u*>(c) = c2a, *reinterpret_cast<v8u*>(c + 8) = c2b;
  c += ldc;
  *reinterpret_cast<v8u*>(c) = c3a, *reinterpret_cast<v8u*>(c + 8) = c3b;
}

// The lower tiles of C = A A(0:k, :)^T, with A's rows in groups of 8: group g
// at rows + g * group_step, its column t a further t * column_step (8
// consecutive doubles). Groups from full_groups on are read from `tail`
// instead (column step 8): the last, partial group, copied and padded with
// zeros, so that no row past m is read. The right-hand factor's rows are
// half groups of the same storage. With avx512, pairs of whole groups go to
// tile16_avx512 (a call per tile: it cannot be inlined into AVX2 code).
__attribute__((target("avx2,fma"))) void tiles_avx2(const double* rows, long group_step, long column_step,
                                                   long full_groups, const double* tail, long m, long k, long w,
                                                   double* C, long ldc, bool avx512) {
  const long row_groups = product_rows(m) / kRows, column_groups = product_columns(k) / kColumns;
  for (long cg = 0; cg < column_groups; ++cg) {
    const long c0 = cg * kColumns, group = c0 / kRows;
    const bool b_in_tail = group >= full_groups;
    const double* b = b_in_tail ? tail + (c0 - full_groups * kRows) : rows + group * group_step + c0 % kRows;
    const long b_step = b_in_tail ? kRows : column_step;
    double* c_tile = C + c0 * ldc;
    long rg = group;  // tiles wholly above the diagonal are skipped
    if (avx512)
      for (; rg + 2 <= full_groups; rg += 2)
        tile16_avx512(rows + rg * group_step, group_step, column_step, b, b_step, w, c_tile + rg * kRows, ldc);
    for (; rg < row_groups; ++rg) {
      if (rg < full_groups)
        tile_avx2(rows + rg * group_step, column_step, b, b_step, w, c_tile + rg * kRows, ldc);
      else
        tile_avx2(tail, kRows, b, b_step, w, c_tile + rg * kRows, ldc);
    }
  }
}

// Eight rows of B at a time, column after column: row r of the result is
// b_c = (b_c - sum_{t<c} b_t L(c, t)) / L(c, c), with that group's solved
// columns still in the first-level cache. Lt: L transposed (row c of L
// contiguous), leading dimension w.
__attribute__((target("avx2,fma"))) void solve_avx2(double* B, long ldb, long rows, const double* Lt, long w) {
  long r = 0;
  for (; r + kRows <= rows; r += kRows) {
    long c = 0;
    for (; c + kColumns <= w; c += kColumns) {  // four columns share each load of a solved column
      v4 lo[kColumns], hi[kColumns];
      for (long j = 0; j < kColumns; ++j) {
        lo[j] = *reinterpret_cast<const v4u*>(B + r + (c + j) * ldb);
        hi[j] = *reinterpret_cast<const v4u*>(B + r + (c + j) * ldb + 4);
      }
      for (long t = 0; t < c; ++t) {
        const v4 blo = *reinterpret_cast<const v4u*>(B + r + t * ldb);
        const v4 bhi = *reinterpret_cast<const v4u*>(B + r + t * ldb + 4);
        for (long j = 0; j < kColumns; ++j) {
          const double l = Lt[t + (c + j) * w];
          const v4 s = {l, l, l, l};
          lo[j] -= blo * s, hi[j] -= bhi * s;
        }
      }
      for (long j = 0; j < kColumns; ++j) {
        for (long i = 0; i < j; ++i) {
          const double l = Lt[c + i + (c + j) * w];
          const v4 s = {l, l, l, l};
          lo[j] -= lo[i] * s, hi[j] -= hi[i] * s;
        }
        const double d = Lt[c + j + (c + j) * w];
        const v4 s = {d, d, d, d};
        lo[j] /= s, hi[j] /= s;
        *reinterpret_cast<v4u*>(B + r + (c + j) * ldb) = lo[j];
        *reinterpret_cast<v4u*>(B + r + (c + j) * ldb + 4) = hi[j];
      }
    }
    for (; c < w; ++c) {
      double* bc = B + r + c * ldb;
      v4 lo = *reinterpret_cast<const v4u*>(bc), hi = *reinterpret_cast<const v4u*>(bc + 4);
      for (long t = 0; t < c; ++t) {
        const double* bt = B + r + t * ldb;
        const double l = Lt[t + c * w];
        const v4 s = {l, l, l, l};
        lo -= *reinterpret_cast<const v4u*>(bt) * s, hi -= *reinterpret_cast<const v4u*>(bt + 4) * s;
      }
      const double d = Lt[c + c * w];
      const v4 s = {d, d, d, d};
      *reinterpret_cast<v4u*>(bc) = lo / s, *reinterpret_cast<v4u*>(bc + 4) = hi / s;
    }
  }
  for (; r < rows; ++r)
    for (long c = 0; c < w; ++c) {
      double b = B[r + c * ldb];
      for (long t = 0; t < c; ++t) b -= B[r + t * ldb] * Lt[t + c * w];
      B[r + c * ldb] = b / Lt[c + c * w];
    }
}

}  // namespace

bool have_avx2_fma() {
  static const bool yes = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return yes;
}

bool have_avx512f() {
  static const bool yes = have_avx2_fma() && __builtin_cpu_supports("avx512f");
  return yes;
}

long product_rows(long m) { return (m + kRows - 1) / kRows * kRows; }
long product_columns(long k) { return (k + kColumns - 1) / kColumns * kColumns; }

void lower_product_avx2(const double* A, long lda, long m, long k, long w, double* C, std::vector<double>& pack,
                        bool avx512) {
  const long ldc = product_rows(m);
  if (k <= kInPlaceColumns) {
    // Few tiles read each row of A: A is read where it is, and only its last
    // partial group of rows (which a tile of the right-hand factor may also reach) is copied.
    const long full_groups = m / kRows, tail_begin = full_groups * kRows;
    pack.resize(static_cast<std::size_t>(kRows * w));
    if (tail_begin < m)
      for (long t = 0; t < w; ++t)
        for (long i = 0; i < kRows; ++i) pack[i + t * kRows] = tail_begin + i < m ? A[tail_begin + i + t * lda] : 0.0;
    tiles_avx2(A, kRows, lda, full_groups, pack.data(), m, k, w, C, ldc, avx512);
    return;
  }
  // Many tiles read each row: A is packed once, each group of 8 rows column
  // after column, so that the tiles read it sequentially. (Read in place with
  // its long stride, the wide blocks slow the largest binds down:
  // docs/engine_internals.md.)
  const long row_groups = ldc / kRows;
  pack.resize(static_cast<std::size_t>(row_groups * kRows * w));
  double* p = pack.data();
  for (long rg = 0; rg < row_groups; ++rg)
    for (long t = 0; t < w; ++t)
      for (long i = 0; i < kRows; ++i, ++p) {
        const long r = rg * kRows + i;
        *p = r < m ? A[r + t * lda] : 0.0;
      }
  tiles_avx2(pack.data(), kRows * w, kRows, row_groups, nullptr, m, k, w, C, ldc, avx512);
}

void solve_transposed_avx2(double* B, long ldb, long rows, const double* L, long ldl, long w,
                           std::vector<double>& pack) {
  pack.resize(static_cast<std::size_t>(w * w));
  for (long c = 0; c < w; ++c)
    for (long t = 0; t <= c; ++t) pack[t + c * w] = L[c + t * ldl];
  solve_avx2(B, ldb, rows, pack.data(), w);
}

#else  // no AVX2 kernels on this platform

bool have_avx2_fma() { return false; }
bool have_avx512f() { return false; }
long product_rows(long m) { return m; }
long product_columns(long k) { return k; }
void lower_product_avx2(const double*, long, long, long, long, double*, std::vector<double>&, bool) {}
void solve_transposed_avx2(double*, long, long, const double*, long, long, std::vector<double>&) {}

#endif

bool small_cholesky_in_place(double* A, long lda, long w) {
  // Column by column (left-looking): L(k, k) = sqrt(A(k, k) - sum_p L(k, p)^2),
  // L(r, k) = (A(r, k) - sum_p L(r, p) L(k, p)) / L(k, k) for r > k, p < k.
  auto at = [&](long r, long c) -> double& { return A[r + c * lda]; };
  for (long k = 0; k < w; ++k) {
    double pivot = at(k, k);
    for (long p = 0; p < k; ++p) pivot -= at(k, p) * at(k, p);
    if (!(pivot > 0)) return false;
    const double diagonal = std::sqrt(pivot);
    at(k, k) = diagonal;
    const double inverse = 1.0 / diagonal;
    for (long r = k + 1; r < w; ++r) {
      double sum = at(r, k);
      for (long p = 0; p < k; ++p) sum -= at(r, p) * at(k, p);
      at(r, k) = sum * inverse;
    }
  }
  return true;
}

bool blocked_cholesky_avx2(double* A, long lda, long w, std::vector<double>& update, std::vector<double>& pack,
                           bool avx512) {
  for (long k0 = 0; k0 < w; k0 += kSmallCholesky) {
    const long panel = std::min(kSmallCholesky, w - k0), below = w - k0;
    double* top = A + k0 + k0 * lda;  // the panel's diagonal entry
    if (k0 > 0) {
      // A(k0:w, panel) -= L(k0:w, 0:k0) L(panel, 0:k0)^T, the lower part of the panel's square.
      const long ldc = product_rows(below);
      update.resize(static_cast<std::size_t>(ldc * product_columns(panel)));
      lower_product_avx2(A + k0, lda, below, panel, k0, update.data(), pack, avx512);
      for (long c = 0; c < panel; ++c)
        for (long r = c; r < below; ++r) top[r + c * lda] -= update[r + c * ldc];
    }
    if (!small_cholesky_in_place(top, lda, panel)) return false;
    if (below > panel) solve_transposed_avx2(top + panel, lda, below - panel, top, lda, panel, pack);
  }
  return true;
}

}  // namespace arap
