// The nested dissection order of large matrices (nested_dissection.h): every
// row ordered once, components one after the other, fewer operations than
// AMD alone on a large mesh, and BlockCholesky's solve when its halves are
// large enough to be ordered this way.
#include <gtest/gtest.h>

#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cstring>
#include <numeric>
#include <set>
#include <vector>

#include "arap/procedural.h"
#include "block_cholesky.h"
#include "nested_dissection.h"
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

TEST(NestedDissection, OrdersEveryRowOnceAndCutsLargeParts) {
  const Sparse A = mesh_matrix(arap::procedural::make_sphere(20000), 1e-3, 21);
  // The whole matrix, then a perforated subset (every fourth row left out).
  std::vector<int> subset;
  for (int i = 0; i < A.rows(); ++i)
    if (i % 4 != 0) subset.push_back(i);
  for (const std::vector<int>& rows : {all_rows(A), subset}) {
    const std::set<int> wanted(rows.begin(), rows.end());
    std::set<int> given_to_leaves;
    int leaf_calls = 0;
    const std::vector<int> order =
        arap::nested_dissection_order(A, rows, 500, [&](const std::vector<int>& part) {
          ++leaf_calls;
          for (int v : part) {
            EXPECT_TRUE(wanted.count(v)) << v << " is not a row to order";
            EXPECT_TRUE(given_to_leaves.insert(v).second) << v << " in two parts";
          }
          return amd_of(A, part);
        });
    ASSERT_EQ(order.size(), rows.size());
    EXPECT_EQ(std::set<int>(order.begin(), order.end()), wanted);
    EXPECT_EQ(given_to_leaves, wanted);
    // Really dissected: a part of at most 500 rows per leaf, and a separator per cut.
    EXPECT_GE(leaf_calls, 2 * static_cast<int>(rows.size()) / 500);
  }
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
  const std::vector<int> order =
      arap::nested_dissection_order(A, rows, 300, [&](const std::vector<int>& part) { return amd_of(A, part); });
  ASSERT_EQ(order.size(), rows.size());
  int switches = 0;
  for (size_t k = 1; k < order.size(); ++k) switches += (order[k] < n) != (order[k - 1] < n);
  EXPECT_EQ(switches, 1);
  EXPECT_EQ(std::set<int>(order.begin(), order.end()).size(), rows.size());
}

TEST(NestedDissection, NeedsFewerOperationsThanAmdOnALargeMesh) {
  const Sparse A = mesh_matrix(arap::procedural::make_ellipsoid(40000, Eigen::Vector3d(1, 1, 2)), 1e-3, 23);
  const std::vector<int> rows = all_rows(A);
  const std::vector<int> dissected =
      arap::nested_dissection_order(A, rows, 1000, [&](const std::vector<int>& part) { return amd_of(A, part); });
  const double by_dissection = factorization_operations(A, dissected);
  const double by_amd = factorization_operations(A, amd_of(A, rows));
  EXPECT_LT(by_dissection, 0.9 * by_amd) << by_dissection << " against AMD's " << by_amd;
}

// From 2 * kNestedDissectionRows rows both halves of BlockCholesky are
// ordered by nested dissection: the solve, and the same factor on two threads.
TEST(NestedDissection, BlockCholeskyWithDissectedHalvesSolves) {
  const Sparse A = mesh_matrix(arap::procedural::make_sphere(2 * arap::kNestedDissectionRows + 12000), 1e-4, 24);
  arap::BlockCholesky one, two;
  ASSERT_TRUE(one.factor(A, arap::BlockCholesky::Kernel::Supernodal, 1));
  ASSERT_TRUE(two.factor(A, arap::BlockCholesky::Kernel::Supernodal, 2));
  ASSERT_GE(one.first_half(), arap::kNestedDissectionRows);
  ASSERT_GE(one.second_half(), arap::kNestedDissectionRows);
  EXPECT_EQ(two.nonzeros(), one.nonzeros());
  const Eigen::MatrixXd b = random_rhs(A.rows(), 25);
  for (int threads : {1, 2}) {
    Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> x1 = b, x2 = b;
    std::vector<double> work;
    one.solve_in_place(x1.data(), work, threads);
    two.solve_in_place(x2.data(), work, threads);
    EXPECT_LT((A * Eigen::MatrixXd(x1) - b).norm(), 1e-8 * b.norm());
    EXPECT_EQ(std::memcmp(x1.data(), x2.data(), sizeof(double) * x1.size()), 0);
  }
}

}  // namespace
