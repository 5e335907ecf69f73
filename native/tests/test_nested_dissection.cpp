// The nested dissection order of the bind's matrices (nested_dissection.h):
// every row ordered once, components one after the other, parts it cannot cut
// handed to the general order, fewer operations than AMD alone on a large
// mesh, and BlockCholesky's solve with the halves so ordered.
#include <gtest/gtest.h>

#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cstring>
#include <numeric>
#include <set>
#include <vector>

#include "arap/tools/procedural.h"
#include "linalg/nested_dissection.h"
#include "linalg/spd_solve.h"
#include "test_matrices.h"

namespace {

using Sparse = Eigen::SparseMatrix<double>;
using arap_test::mesh_matrix;
using arap_test::random_rhs;

// The rows of A as indices 0 .. n-1.
std::vector<int> all_rows(const Sparse& A) {
  std::vector<int> rows(A.rows());
  std::iota(rows.begin(), rows.end(), 0);
  return rows;
}

// Eigen's AMD order of the rows `rows` of A (their induced submatrix), as indices into A.
std::vector<int> amd_of(const Sparse& A, const std::vector<int>& rows) {
  std::vector<int> local(A.rows(), -1);
  for (size_t k = 0; k < rows.size(); ++k) local[rows[k]] = static_cast<int>(k);
  std::vector<Eigen::Triplet<double>> t;
  for (size_t k = 0; k < rows.size(); ++k)
    for (Sparse::InnerIterator it(A, rows[k]); it; ++it)
      if (local[it.row()] >= 0) t.emplace_back(local[it.row()], static_cast<int>(k), it.value());
  Sparse S(static_cast<Eigen::Index>(rows.size()), static_cast<Eigen::Index>(rows.size()));
  S.setFromTriplets(t.begin(), t.end());
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> inverse;
  Eigen::AMDOrdering<int>()(S, inverse);  // inverse.indices()[new] = old
  std::vector<int> out(rows.size());
  for (size_t k = 0; k < rows.size(); ++k) out[k] = rows[inverse.indices()[k]];
  return out;
}

// Multiply-adds of the Cholesky factorization of A in `order`: the sum over
// the factor's columns of their entry counts squared.
double factorization_operations(const Sparse& A, const std::vector<int>& order) {
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> P(A.rows());
  for (size_t k = 0; k < order.size(); ++k) P.indices()[order[k]] = static_cast<int>(k);  // old -> new
  Sparse permuted;
  permuted = A.twistedBy(P);
  Eigen::SimplicialLLT<Sparse, Eigen::Lower, Eigen::NaturalOrdering<int>> llt(permuted);
  EXPECT_EQ(llt.info(), Eigen::Success);
  const Sparse& L = llt.matrixL().nestedExpression();
  double operations = 0;
  for (Eigen::Index j = 0; j < L.outerSize(); ++j) {
    const double count = L.outerIndexPtr()[j + 1] - L.outerIndexPtr()[j];
    operations += count * count;
  }
  return operations;
}

TEST(NestedDissection, OrdersEveryRowOnce) {
  const Sparse A = mesh_matrix(arap::procedural::make_sphere(20000), 1e-3, 21);
  // The whole matrix, then a perforated subset (every fourth row left out).
  std::vector<int> subset;
  for (int i = 0; i < A.rows(); ++i)
    if (i % 4 != 0) subset.push_back(i);
  for (const std::vector<int>& rows : {all_rows(A), subset}) {
    const std::set<int> wanted(rows.begin(), rows.end());
    size_t largest_uncut = 0;
    const std::vector<int> order =
        arap::nested_dissection_order(A, rows, arap::kDissectionLeafRows, [&](const std::vector<int>& part) {
          for (int v : part) EXPECT_TRUE(wanted.count(v)) << v << " is not a row to order";
          largest_uncut = std::max(largest_uncut, part.size());
          return amd_of(A, part);
        });
    ASSERT_EQ(order.size(), rows.size());
    EXPECT_EQ(std::set<int>(order.begin(), order.end()), wanted);
    // A mesh is cut down to small parts: what no level cuts into quarters is small.
    EXPECT_LT(largest_uncut, 100u);
  }
}

// A hub joined to every other row (and those in a ring) has no level that
// leaves a quarter on each side: the general order takes it, which puts the
// hub last. Kept in the order met, the hub first would fill the factor in.
TEST(NestedDissection, HandsWhatItCannotCutToTheGeneralOrder) {
  const int n = 2000;
  std::vector<Eigen::Triplet<double>> t;
  for (int i = 1; i < n; ++i) {
    const int next = i + 1 < n ? i + 1 : 1;
    for (const auto& [a, b] : {std::pair<int, int>(0, i), std::pair<int, int>(i, next)})
      t.emplace_back(a, b, -1.0), t.emplace_back(b, a, -1.0), t.emplace_back(a, a, 1.0), t.emplace_back(b, b, 1.0);
  }
  for (int i = 0; i < n; ++i) t.emplace_back(i, i, 1e-3);
  Sparse A(n, n);
  A.setFromTriplets(t.begin(), t.end());
  int calls = 0;
  const std::vector<int> order = arap::nested_dissection_order(A, all_rows(A), arap::kDissectionLeafRows,
                                                               [&](const std::vector<int>& part) {
                                                                 ++calls;
                                                                 return amd_of(A, part);
                                                               });
  EXPECT_EQ(calls, 1);
  ASSERT_EQ(order.size(), static_cast<size_t>(n));
  EXPECT_EQ(std::set<int>(order.begin(), order.end()).size(), static_cast<size_t>(n));
  EXPECT_LT(factorization_operations(A, order), 20.0 * n);  // a full factor would take n^3 / 3
}

TEST(NestedDissection, OrdersComponentsOneAfterTheOther) {
  // Two spheres, the second's rows after the first's: one block-diagonal matrix.
  const arap::procedural::TriMesh sphere = arap::procedural::make_sphere(6000);
  const Sparse one = mesh_matrix(sphere, 1e-3, 22);
  const Eigen::Index n = one.rows();
  std::vector<Eigen::Triplet<double>> t;
  for (int copy = 0; copy < 2; ++copy)
    for (Eigen::Index j = 0; j < n; ++j)
      for (Sparse::InnerIterator it(one, j); it; ++it) t.emplace_back(it.row() + copy * n, j + copy * n, it.value());
  Sparse A(2 * n, 2 * n);
  A.setFromTriplets(t.begin(), t.end());
  // Interleaved rows: the order must still keep each sphere's rows together.
  std::vector<int> rows;
  for (int i = 0; i < n; ++i) rows.push_back(i), rows.push_back(i + static_cast<int>(n));
  const std::vector<int> order = arap::nested_dissection_order(
      A, rows, arap::kDissectionLeafRows, [&](const std::vector<int>& part) { return amd_of(A, part); });
  ASSERT_EQ(order.size(), rows.size());
  int switches = 0;
  for (size_t k = 1; k < order.size(); ++k) switches += (order[k] < n) != (order[k - 1] < n);
  EXPECT_EQ(switches, 1);
  EXPECT_EQ(std::set<int>(order.begin(), order.end()).size(), rows.size());
}

TEST(NestedDissection, NeedsFewerOperationsThanAmdOnALargeMesh) {
  const Sparse A = mesh_matrix(arap::procedural::make_ellipsoid(40000, Eigen::Vector3d(1, 1, 2)), 1e-3, 23);
  const std::vector<int> rows = all_rows(A);
  const std::vector<int> dissected = arap::nested_dissection_order(
      A, rows, arap::kDissectionLeafRows, [&](const std::vector<int>& part) { return amd_of(A, part); });
  const double by_dissection = factorization_operations(A, dissected);
  const double by_amd = factorization_operations(A, amd_of(A, rows));
  EXPECT_LT(by_dissection, 0.9 * by_amd) << by_dissection << " against AMD's " << by_amd;
}

// Ordering::Fewest on a split matrix where nested dissection needs fewer
// operations than AMD: its order is kept for both halves; the solve, and the
// same factor on two threads.
TEST(NestedDissection, BlockCholeskyWithDissectedHalvesSolves) {
  using arap::BlockCholesky;
  const Sparse A = mesh_matrix(arap::procedural::make_ellipsoid(30000, Eigen::Vector3d(1, 1, 2)), 1e-4, 24);
  ASSERT_GE(A.rows(), 20000);
  BlockCholesky one, two, amd;
  ASSERT_TRUE(one.factor(A, BlockCholesky::Kernel::Supernodal, 1, BlockCholesky::Ordering::Fewest));
  ASSERT_TRUE(two.factor(A, BlockCholesky::Kernel::Supernodal, 2, BlockCholesky::Ordering::Fewest));
  ASSERT_TRUE(amd.factor(A, BlockCholesky::Kernel::Supernodal, 1, BlockCholesky::Ordering::Amd));
  ASSERT_GT(one.first_half(), 0);
  ASSERT_GT(one.second_half(), 0);
  EXPECT_EQ(two.nonzeros(), one.nonzeros());
  EXPECT_LT(one.nonzeros(), amd.nonzeros());  // dissected: fewer entries than AMD's
  const Eigen::MatrixXd b = random_rhs(A.rows(), 25);
  Eigen::SimplicialLDLT<Sparse> reference(A);
  ASSERT_EQ(reference.info(), Eigen::Success);
  const Eigen::MatrixXd expected = reference.solve(b);
  for (int threads : {1, 2}) {
    Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> x1 = b, x2 = b;
    std::vector<double> work;
    one.solve_in_place(x1.data(), work, threads);
    two.solve_in_place(x2.data(), work, threads);
    EXPECT_LT((Eigen::MatrixXd(x1) - expected).norm(), 1e-10 * expected.norm());
    EXPECT_EQ(std::memcmp(x1.data(), x2.data(), sizeof(double) * x1.size()), 0);
  }
}

// Where AMD's order needs fewer operations (this triangulated box, its
// diagonals all one way), Ordering::Fewest keeps it: the same factor as AMD's.
TEST(NestedDissection, BlockCholeskyKeepsAmdWhereItNeedsFewerOperations) {
  using arap::BlockCholesky;
  const Sparse A = mesh_matrix(arap::procedural::make_bar_with_vertices(30000, 6.0), 1e-4, 26);
  BlockCholesky fewest, amd;
  ASSERT_TRUE(fewest.factor(A, BlockCholesky::Kernel::Supernodal, 1, BlockCholesky::Ordering::Fewest));
  ASSERT_TRUE(amd.factor(A, BlockCholesky::Kernel::Supernodal, 1, BlockCholesky::Ordering::Amd));
  EXPECT_EQ(fewest.nonzeros(), amd.nonzeros());
  const Eigen::MatrixXd b = random_rhs(A.rows(), 27);
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> x1 = b, x2 = b;
  std::vector<double> work;
  fewest.solve_in_place(x1.data(), work, 1);
  amd.solve_in_place(x2.data(), work, 1);
  EXPECT_EQ(std::memcmp(x1.data(), x2.data(), sizeof(double) * x1.size()), 0);
}

}  // namespace
