// The bind's sparse Cholesky (linalg/spd_solve.h, supernodal_cholesky.h): its
// solve against Eigen's on procedural matrices, small (one part) and split
// (two halves and a separator, >= 20k rows), one thread against two (solve
// and factor), and a clean refusal of matrices that are not positive definite.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/SparseCholesky>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "arap/tools/procedural.h"
#include "linalg/dense_kernels.h"
#include "linalg/spd_solve.h"
#include "linalg/supernodal_cholesky.h"
#include "test_matrices.h"

namespace {

using Sparse = Eigen::SparseMatrix<double>;
using arap_test::mesh_matrix;
using arap_test::random_rhs;

// x = A^-1 b through BlockCholesky::solve_in_place (x, y, z per row).
Eigen::MatrixXd solve(const arap::BlockCholesky& chol, const Eigen::MatrixXd& b, int threads) {
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> x = b;
  std::vector<double> work;
  chol.solve_in_place(x.data(), work, threads);
  return x;
}

void expect_solves_like_eigen(const Sparse& A) {
  const Eigen::MatrixXd b = random_rhs(A.rows(), 7);
  Eigen::SimplicialLDLT<Sparse> reference(A);
  ASSERT_EQ(reference.info(), Eigen::Success);
  const Eigen::MatrixXd expected = reference.solve(b);
  arap::BlockCholesky chol;
  ASSERT_TRUE(chol.factor(A));
  const Eigen::MatrixXd x = solve(chol, b, 1);
  EXPECT_LT((x - expected).norm(), 1e-10 * expected.norm());
  EXPECT_LT((A * x - b).norm(), 1e-10 * b.norm());
  // The same factor, the same solution bit for bit on two threads.
  EXPECT_EQ(solve(chol, b, 2), x);
  // Eigen's simplicial factorization of the same ordered matrix: the same solution.
  arap::BlockCholesky simplicial;
  ASSERT_TRUE(simplicial.factor(A, arap::BlockCholesky::Kernel::Simplicial));
  EXPECT_LT((solve(simplicial, b, 1) - x).norm(), 1e-10 * x.norm());
}

TEST(BlockCholesky, SmallMeshMatrixSolvesLikeEigen) {
  const Sparse A = mesh_matrix(arap::procedural::make_sphere(3000), 1e-3, 1);
  expect_solves_like_eigen(A);
}

TEST(BlockCholesky, SplitMeshMatrixSolvesLikeEigen) {
  const Sparse A = mesh_matrix(arap::procedural::make_bar_with_vertices(24000), 1e-4, 2);
  ASSERT_GE(A.rows(), 20000);
  arap::BlockCholesky chol;
  ASSERT_TRUE(chol.factor(A));
  EXPECT_GT(chol.first_half(), 0);  // really split in two halves and a separator
  EXPECT_GT(chol.second_half(), 0);
  EXPECT_LT(chol.first_half() + chol.second_half(), A.rows());
  expect_solves_like_eigen(A);
}

// Two threads order and factor the halves side by side: the factor is the
// one-thread factor bit for bit (the same solution to the last bit), and a
// matrix that is not positive definite in either half is refused.
TEST(BlockCholesky, TwoThreadFactorIsTheOneThreadFactor) {
  for (const Sparse& A : {mesh_matrix(arap::procedural::make_bar_with_vertices(24000), 1e-4, 11),
                          mesh_matrix(arap::procedural::make_sphere(30000), 1e-4, 12)}) {
    arap::BlockCholesky one, two;
    ASSERT_TRUE(one.factor(A, arap::BlockCholesky::Kernel::Supernodal, 1));
    ASSERT_TRUE(two.factor(A, arap::BlockCholesky::Kernel::Supernodal, 2));
    ASSERT_GT(two.first_half(), 0);
    ASSERT_GT(two.second_half(), 0);
    EXPECT_EQ(two.first_half(), one.first_half());
    EXPECT_EQ(two.nonzeros(), one.nonzeros());
    const Eigen::MatrixXd b = random_rhs(A.rows(), 13);
    const Eigen::MatrixXd x1 = solve(one, b, 1), x2 = solve(two, b, 1);
    EXPECT_EQ(std::memcmp(x1.data(), x2.data(), sizeof(double) * x1.size()), 0);
    EXPECT_LT((A * x2 - b).norm(), 1e-6 * b.norm());
  }
  const Sparse A = mesh_matrix(arap::procedural::make_bar_with_vertices(24000), 1e-4, 14);
  const Eigen::Index n = A.rows();
  // Rows near both ends of the bar (the split's breadth-first levels start at row 0, so the
  // first lies in the first half and the last in the second) and one in the middle.
  for (Eigen::Index row : {Eigen::Index(3), n / 2, n - 3}) {
    Sparse broken = A;
    broken.coeffRef(row, row) = -1;
    arap::BlockCholesky two;
    EXPECT_FALSE(two.factor(broken, arap::BlockCholesky::Kernel::Supernodal, 2)) << row;
    EXPECT_EQ(two.nonzeros(), 0) << row;
  }
  arap::BlockCholesky two;
  EXPECT_FALSE(two.factor(mesh_matrix(arap::procedural::make_bar_with_vertices(24000), -0.05, 15),
                          arap::BlockCholesky::Kernel::Supernodal, 2));
}

// A dense block (a clique of 300 rows) gives wide supernodes: the dense
// kernels' tiles, edges and remainders all run.
TEST(BlockCholesky, DenseBlockSolvesLikeEigen) {
  const int n = 700, clique = 300;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Eigen::Triplet<double>> t;
  for (int i = 0; i < n; ++i) t.emplace_back(i, i, i < clique ? clique : 4.0);
  auto couple = [&](int a, int b) {
    const double w = 0.9 * u(rng);
    t.emplace_back(a, b, w), t.emplace_back(b, a, w);
  };
  for (int i = 0; i < clique; ++i)
    for (int j = i + 1; j < clique; ++j) couple(i, j);
  for (int i = clique; i + 1 < n; ++i) couple(i, i + 1), couple(i, (i * 7) % clique);
  Sparse A(n, n);
  A.setFromTriplets(t.begin(), t.end());
  expect_solves_like_eigen(A);
}

// Eigen's AMD hashes a node by the sum of its neighbours' indices. Here four
// hubs of 6 000 neighbours each, all among the last rows of a 400 000-row
// chain, give sums past 2^31 (a 32-bit sum overflows: UBSan stops the
// sanitizer build there); row 0, joined to every row, makes each
// breadth-first level wide, so the whole matrix is ordered at once.
TEST(BlockCholesky, HubsInAMatrixOfHundredsOfThousandsOfRowsAreOrderedSafely) {
  const int chain = 400000, hubs = 4, spokes = 6000;
  const int n = chain + hubs;
  std::vector<Eigen::Triplet<double>> t;
  auto couple = [&](int a, int b, double w) {
    t.emplace_back(a, b, -w), t.emplace_back(b, a, -w), t.emplace_back(a, a, w), t.emplace_back(b, b, w);
  };
  for (int i = 0; i + 1 < chain; ++i) couple(i, i + 1, 1.0);
  for (int i = 2; i < n; ++i) couple(0, i, 1e-3);
  for (int h = 0; h < hubs; ++h)
    for (int k = 0; k < spokes; ++k) couple(chain + h, chain - hubs * spokes + h * spokes + k, 0.5);
  for (int i = 0; i < n; ++i) t.emplace_back(i, i, 1e-2);
  Sparse A(n, n);
  A.setFromTriplets(t.begin(), t.end());
  arap::BlockCholesky chol;
  ASSERT_TRUE(chol.factor(A));
  EXPECT_EQ(chol.first_half(), n);  // not split
  const Eigen::MatrixXd b = random_rhs(n, 21);
  const Eigen::MatrixXd x = solve(chol, b, 1);
  EXPECT_LT((A * x - b).norm(), 1e-10 * b.norm());
}

// Hubs given as last_rows (as Volume Infill's lattice nodes are): the other
// rows are split and ordered as a matrix of their own, the hubs come after
// the separator, and the factor solves like Eigen's on one thread and two.
TEST(BlockCholesky, LastRowsComeAfterTheSplitSurface) {
  const Sparse surface = mesh_matrix(arap::procedural::make_bar_with_vertices(24000), 1e-4, 16);
  const int m = static_cast<int>(surface.rows()), hubs = 20;
  const int n = m + hubs;
  std::vector<Eigen::Triplet<double>> t;
  for (int j = 0; j < m; ++j)
    for (Sparse::InnerIterator it(surface, j); it; ++it) t.emplace_back(it.row(), j, it.value());
  auto couple = [&](int a, int b, double w) {
    t.emplace_back(a, b, -w), t.emplace_back(b, a, -w), t.emplace_back(a, a, w), t.emplace_back(b, b, w);
  };
  // Hub h bound to a run of m / hubs rows, and to the next hub.
  for (int h = 0; h < hubs; ++h) {
    for (int k = 0; k < m / hubs; ++k) couple(m + h, h * (m / hubs) + k, 0.3);
    if (h + 1 < hubs) couple(m + h, m + h + 1, 1.0);
  }
  Sparse A(n, n);
  A.setFromTriplets(t.begin(), t.end());
  std::vector<int> last(hubs);
  for (int h = 0; h < hubs; ++h) last[h] = m + h;
  arap::BlockCholesky whole, split;
  ASSERT_TRUE(whole.factor(A));
  EXPECT_EQ(whole.first_half(), n);  // the hubs make every level wide: not split
  ASSERT_TRUE(split.factor(A, arap::BlockCholesky::Kernel::Supernodal, 1, arap::BlockCholesky::Ordering::Amd,
                           nullptr, last));
  EXPECT_GT(split.first_half(), 0);
  EXPECT_GT(split.second_half(), 0);
  EXPECT_LT(split.first_half() + split.second_half() + hubs, n);
  const Eigen::MatrixXd b = random_rhs(n, 17);
  Eigen::SimplicialLDLT<Sparse> reference(A);
  ASSERT_EQ(reference.info(), Eigen::Success);
  const Eigen::MatrixXd x = solve(split, b, 1);
  EXPECT_LT((x - reference.solve(b)).norm(), 1e-9 * x.norm());
  EXPECT_EQ(solve(split, b, 2), x);
  arap::BlockCholesky two;
  ASSERT_TRUE(two.factor(A, arap::BlockCholesky::Kernel::Supernodal, 2, arap::BlockCholesky::Ordering::Amd,
                         nullptr, last));
  EXPECT_EQ(two.nonzeros(), split.nonzeros());
  EXPECT_EQ(solve(two, b, 1), x);
}

TEST(BlockCholesky, RefusesMatricesThatAreNotPositiveDefinite) {
  arap::BlockCholesky chol;
  // A graph Laplacian shifted down: indefinite, yet every diagonal entry positive.
  Sparse indefinite = mesh_matrix(arap::procedural::make_sphere(3000), -0.05, 4);
  for (int k = 0; k < indefinite.outerSize(); ++k) ASSERT_GT(indefinite.coeff(k, k), 0);
  EXPECT_FALSE(chol.factor(indefinite));
  // The same, large enough to be split.
  EXPECT_FALSE(chol.factor(mesh_matrix(arap::procedural::make_bar_with_vertices(24000), -0.05, 5)));
  // One negative diagonal entry of an otherwise SPD matrix.
  Sparse negative = mesh_matrix(arap::procedural::make_sphere(3000), 1e-3, 6);
  negative.coeffRef(1234, 1234) = -1;
  EXPECT_FALSE(chol.factor(negative));
  // A NaN.
  Sparse nan = mesh_matrix(arap::procedural::make_sphere(3000), 1e-3, 7);
  nan.coeffRef(10, 10) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(chol.factor(nan));
  // After all that, an SPD matrix factors again.
  EXPECT_TRUE(chol.factor(mesh_matrix(arap::procedural::make_sphere(3000), 1e-3, 8)));
}

// Every vertex constrained leaves an empty free block: it factors, and solves nothing.
TEST(BlockCholesky, EmptyMatrix) {
  arap::BlockCholesky chol;
  ASSERT_TRUE(chol.factor(Sparse(0, 0)));
  EXPECT_EQ(chol.nonzeros(), 0);
  std::vector<double> x, work;
  chol.solve_in_place(x.data(), work, 2);
}

// Merged supernodes store explicit zeros; the factor keeps none of them: it has
// the entries of Eigen's simplicial factor of the same ordered matrix, no more.
TEST(BlockCholesky, MergedSupernodesLeaveNoZeros) {
  for (int vertices : {3000, 24000}) {
    const Sparse A = mesh_matrix(arap::procedural::make_bar_with_vertices(vertices), 1e-3, 9);
    arap::BlockCholesky simplicial, supernodal;
    ASSERT_TRUE(simplicial.factor(A, arap::BlockCholesky::Kernel::Simplicial));
    ASSERT_TRUE(supernodal.factor(A));
    EXPECT_EQ(supernodal.nonzeros(), simplicial.nonzeros()) << vertices;
  }
}

// The postorder keeps each part in place and puts children before parents.
TEST(BlockCholesky, PostorderStaysWithinParts) {
  const Sparse A = mesh_matrix(arap::procedural::make_sphere(2000), 1e-3, 10);
  const int n = static_cast<int>(A.rows());
  const std::vector<int> bounds = {0, n / 3, n / 2, n};
  const std::vector<int> parent = arap::elimination_tree(A);
  const std::vector<int> order = arap::postorder_within_parts(parent, bounds);
  ASSERT_EQ(static_cast<int>(order.size()), n);
  std::vector<int> position(n, -1);
  for (int k = 0; k < n; ++k) position[order[k]] = k;
  for (int j = 0; j < n; ++j) {
    ASSERT_GE(position[j], 0);
    const int part = j < bounds[1] ? 0 : j < bounds[2] ? 1 : 2;
    EXPECT_GE(position[j], bounds[part]);
    EXPECT_LT(position[j], bounds[part + 1]);
    if (parent[j] >= 0 && parent[j] < bounds[part + 1]) {
      EXPECT_LT(position[j], position[parent[j]]);
    }
  }
}

// The AVX2 kernel against a plain product, on sizes that hit every remainder.
// The product reads A in place: rows between m and lda hold NaN, which must
// not reach the result, and with lda == m the buffer ends at the last row
// (the sanitizer build would see a read past it). Where the processor has
// AVX-512, its tiles must give the same entries bit for bit.
TEST(DenseKernels, LowerProductAndTriangularSolveMatchPlainLoops) {
  if (!arap::have_avx2_fma()) GTEST_SKIP() << "no AVX2 + FMA on this processor: the portable path runs instead";
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> pack;
  for (long m : {1L, 5L, 8L, 12L, 13L, 16L, 37L})
    for (long k = 1; k <= m; k += 3)
      for (long w : {1L, 4L, 7L})
        for (long lda : {m, m + 3}) {
          std::vector<double> A(lda * w);
          for (long t = 0; t < w; ++t)
            for (long r = 0; r < lda; ++r) A[r + t * lda] = r < m ? u(rng) : NAN;
          std::vector<double> C(arap::product_rows(m) * arap::product_columns(k), NAN);
          arap::lower_product_avx2(A.data(), lda, m, k, w, C.data(), pack);
          if (arap::have_avx512f()) {  // the AVX-512 tiles: the same entries bit for bit
            std::vector<double> C512(C.size(), NAN);
            arap::lower_product_avx2(A.data(), lda, m, k, w, C512.data(), pack, true);
            for (long c = 0; c < k; ++c)
              for (long r = c; r < m; ++r)
                ASSERT_EQ(C512[r + c * arap::product_rows(m)], C[r + c * arap::product_rows(m)])
                    << m << " " << k << " " << w << " " << lda;
          }
          for (long c = 0; c < k; ++c)
            for (long r = c; r < m; ++r) {
              double expected = 0;
              for (long t = 0; t < w; ++t) expected += A[r + t * lda] * A[c + t * lda];
              EXPECT_NEAR(C[r + c * arap::product_rows(m)], expected, 1e-13) << m << " " << k << " " << w << " " << lda;
            }
          // B L^-T with L lower triangular, well conditioned.
          Eigen::MatrixXd L = Eigen::MatrixXd::Random(w, w).triangularView<Eigen::Lower>();
          L.diagonal().array() = 2 + L.diagonal().array().abs();
          Eigen::MatrixXd B = Eigen::MatrixXd::Random(m, w), X = B;
          arap::solve_transposed_avx2(X.data(), m, m, L.data(), w, w, pack);
          EXPECT_LT((X * L.transpose() - B).norm(), 1e-12 * B.norm()) << m << " " << w;
        }
}

// The small diagonal blocks' Cholesky against Eigen's LLT, inside a taller
// column-major block as the supernodes store them: only the w by w lower
// triangle changes; a matrix that is not positive definite, or holds a NaN, is refused.
TEST(DenseKernels, SmallCholeskyMatchesEigenAndRefusesIndefinite) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  for (long w = 1; w <= arap::kSmallCholesky; ++w) {
    Eigen::MatrixXd M(w, w);
    for (long c = 0; c < w; ++c)
      for (long r = 0; r < w; ++r) M(r, c) = u(rng);
    const Eigen::MatrixXd A = M * M.transpose() + w * Eigen::MatrixXd::Identity(w, w);
    const long lda = w + 3;
    Eigen::MatrixXd block = Eigen::MatrixXd::Constant(lda, w, 7.0);  // 7: the entries that must stay
    block.topRows(w).triangularView<Eigen::Lower>() = A;
    ASSERT_TRUE(arap::small_cholesky_in_place(block.data(), lda, w)) << w;
    const Eigen::MatrixXd L = block.topRows(w).triangularView<Eigen::Lower>();
    const Eigen::MatrixXd expected = Eigen::LLT<Eigen::MatrixXd>(A).matrixL();
    EXPECT_LT((L - expected).norm(), 1e-13 * expected.norm()) << w;
    EXPECT_LT((L * L.transpose() - A).norm(), 1e-13 * A.norm()) << w;
    for (long c = 0; c < w; ++c) {
      for (long r = 0; r < c; ++r) EXPECT_EQ(block(r, c), 7.0) << "upper triangle written, w " << w;
      for (long r = w; r < lda; ++r) EXPECT_EQ(block(r, c), 7.0) << "rows below the block written, w " << w;
    }
    // The last pivot made negative; then a NaN on the diagonal.
    Eigen::MatrixXd bad = A;
    bad(w - 1, w - 1) = -1.0;
    EXPECT_FALSE(arap::small_cholesky_in_place(bad.data(), w, w)) << w;
    bad = A;
    bad(0, 0) = NAN;
    EXPECT_FALSE(arap::small_cholesky_in_place(bad.data(), w, w)) << w;
  }
}

// The panel-by-panel factorization of the larger diagonal blocks against
// Eigen's LLT, on sizes around the panel width and well beyond it; refusal as above.
TEST(DenseKernels, BlockedCholeskyMatchesEigenAndRefusesIndefinite) {
  if (!arap::have_avx2_fma()) GTEST_SKIP() << "no AVX2 + FMA on this processor: Eigen's LLT runs instead";
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> update, pack;
  for (long w : {1L, 15L, 16L, 17L, 31L, 32L, 33L, 50L, 97L, 200L, 257L, 600L}) {
    Eigen::MatrixXd M(w, w);
    for (long c = 0; c < w; ++c)
      for (long r = 0; r < w; ++r) M(r, c) = u(rng);
    const Eigen::MatrixXd A = M * M.transpose() + w * Eigen::MatrixXd::Identity(w, w);
    const long lda = w + 5;
    Eigen::MatrixXd block = Eigen::MatrixXd::Constant(lda, w, 7.0);
    block.topRows(w).triangularView<Eigen::Lower>() = A;
    ASSERT_TRUE(arap::blocked_cholesky_avx2(block.data(), lda, w, update, pack)) << w;
    const Eigen::MatrixXd L = block.topRows(w).triangularView<Eigen::Lower>();
    const Eigen::MatrixXd expected = Eigen::LLT<Eigen::MatrixXd>(A).matrixL();
    EXPECT_LT((L - expected).norm(), 1e-13 * expected.norm()) << w;
    for (long c = 0; c < w; ++c) {
      for (long r = 0; r < c; ++r) EXPECT_EQ(block(r, c), 7.0) << "upper triangle written, w " << w;
      for (long r = w; r < lda; ++r) EXPECT_EQ(block(r, c), 7.0) << "rows below the block written, w " << w;
    }
    Eigen::MatrixXd bad = A;
    bad(w - 1, w - 1) = -1.0;
    EXPECT_FALSE(arap::blocked_cholesky_avx2(bad.data(), w, w, update, pack)) << w;
    bad = A;
    bad(w / 2, w / 2) = NAN;
    EXPECT_FALSE(arap::blocked_cholesky_avx2(bad.data(), w, w, update, pack)) << w;
  }
}

}  // namespace

// The portable path (Eigen's dense products, what a processor without AVX2
// runs), chosen here through the ARAP_NO_AVX2 switch.
TEST(BlockCholesky, PortablePathSolvesLikeEigen) {
  setenv("ARAP_NO_AVX2", "1", 1);
  expect_solves_like_eigen(mesh_matrix(arap::procedural::make_bar_with_vertices(24000), 1e-4, 12));
  unsetenv("ARAP_NO_AVX2");
}
