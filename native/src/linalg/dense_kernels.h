// Dense kernels of the supernodal Cholesky (the product of a column block of L
// with the transpose of its first rows; the triangular solve of the rows below
// a diagonal block), written for AVX2 + FMA and chosen at run time, so that a
// build for any x86-64 still uses the wider registers where the processor has
// them. Elsewhere (other processors, other architectures) the caller uses
// Eigen's products.
#pragma once

#include <vector>

namespace arap {

// True when this processor runs the AVX2 + FMA kernel below.
bool have_avx2_fma();
// True when it also runs AVX-512F, which lower_product_avx2 can use.
bool have_avx512f();

// C(r, c) = sum_t A(r, t) A(c, t) for c < k <= m and r >= c (tiles across
// the diagonal also get some r < c). A: m by w, column-major with leading
// dimension lda. C: column-major, leading dimension product_rows(m), at least
// product_columns(k) columns. `pack` is resized as needed. Only call when
// have_avx2_fma(); avx512 (only when have_avx512f()) takes two groups of 8
// rows per tile in AVX-512 registers, with the same result bit for bit.
long product_rows(long m);
long product_columns(long k);
void lower_product_avx2(const double* A, long lda, long m, long k, long w, double* C, std::vector<double>& pack,
                        bool avx512 = false);

// B = B L^-T in place: B rows by w (leading dimension ldb), L w by w lower
// triangular (leading dimension ldl). `pack` is resized as needed. Only call
// when have_avx2_fma().
void solve_transposed_avx2(double* B, long ldb, long rows, const double* L, long ldl, long w,
                           std::vector<double>& pack);

// A = L L^T in place for a small symmetric positive definite block (w <=
// kSmallCholesky): column-major, leading dimension lda, only the lower
// triangle read and written. Plain loops: for these sizes a general blocked
// factorization spends more time deciding than computing. False (A partly
// overwritten) when a pivot is not > 0 (not positive definite, or NaN).
constexpr long kSmallCholesky = 16;
bool small_cholesky_in_place(double* A, long lda, long w);

// A = L L^T in place for a larger block (any w), by panels of kSmallCholesky
// columns: each panel takes the product of the columns left of it
// (lower_product_avx2, which reads them in place), is factored by
// small_cholesky_in_place, and solves the rows below it
// (solve_transposed_avx2). `update` and `pack` are scratch; avx512 as for
// lower_product_avx2. Only call when have_avx2_fma(). False as
// small_cholesky_in_place. (Faster than Eigen's blocked LLT, which this build
// compiles for SSE2 only: docs/engine_internals.md.)
bool blocked_cholesky_avx2(double* A, long lda, long w, std::vector<double>& update, std::vector<double>& pack,
                           bool avx512 = false);

}  // namespace arap
