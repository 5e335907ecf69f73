#include <gtest/gtest.h>

#include <random>

#include <Eigen/Geometry>

#include "arap/rotation_fit.h"

namespace {

double objective(const Eigen::Matrix3d& R, const Eigen::Matrix3d& A) { return R.cwiseProduct(A).sum(); }

void expect_rotation(const Eigen::Matrix3d& R) {
  EXPECT_LT((R.transpose() * R - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
}

TEST(RotationFit, RecoversAKnownRotation) {
  const Eigen::Matrix3d R0 = Eigen::AngleAxisd(0.9, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  // A = sum_j e'_j e_j^T with e'_j = R0 e_j for a few spokes.
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  const Eigen::Vector3d spokes[4] = {{1, 0, 0}, {0, 1, 0.2}, {-0.3, 0.5, 1}, {0.7, -0.1, 0.4}};
  for (const auto& e : spokes) A += (R0 * e) * e.transpose();
  Eigen::Matrix3d R;
  EXPECT_FALSE(arap::fit_rotation(A, R));
  EXPECT_LT((R - R0).norm(), 1e-10);
}

TEST(RotationFit, MatchesSvdOnRandomFlatAndReflectedCells) {
  std::mt19937 rng(7);
  std::normal_distribution<double> g;
  int fallbacks = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    Eigen::Matrix3d A;
    for (int i = 0; i < 9; ++i) A(i / 3, i % 3) = g(rng);
    if (trial % 3 == 1) A.col(2).setZero();               // flat cell: rank 2
    if (trial % 3 == 2) A.row(0) *= -1.0;                  // reflection
    if (trial % 7 == 0) A *= 1e-6;                          // scale does not matter
    Eigen::Matrix3d R;
    fallbacks += arap::fit_rotation(A, R);
    const Eigen::Matrix3d Rs = arap::fit_rotation_svd(A);
    expect_rotation(R);
    // Same optimum of <R, A> (the rotation itself is unique when singular values are distinct).
    EXPECT_NEAR(objective(R, A), objective(Rs, A), 1e-12 * A.norm()) << "trial " << trial;
  }
  EXPECT_LT(fallbacks, 30);  // the fast path handles almost every cell
}

TEST(RotationFit, DegenerateCellsStillGiveRotations) {
  Eigen::Matrix3d R;
  arap::fit_rotation(Eigen::Matrix3d::Zero(), R);
  expect_rotation(R);
  Eigen::Matrix3d rank1 = Eigen::Vector3d(1, 2, 3) * Eigen::Vector3d(0, 1, 0).transpose();
  arap::fit_rotation(rank1, R);
  expect_rotation(R);
  EXPECT_NEAR(objective(R, rank1), objective(arap::fit_rotation_svd(rank1), rank1), 1e-10);
  arap::fit_rotation(Eigen::Matrix3d::Identity(), R);
  EXPECT_LT((R - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  arap::fit_rotation(-Eigen::Matrix3d::Identity(), R);  // pure reflection: any rotation by pi
  expect_rotation(R);
  EXPECT_NEAR(objective(R, -Eigen::Matrix3d::Identity()), 1.0, 1e-12);  // s1 + s2 - s3
}

}  // namespace
