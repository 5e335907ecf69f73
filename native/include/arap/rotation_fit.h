// The 3x3 rotation fit of the local step: the rotation R maximising
// <R, A> = trace(R^T A) for a cell covariance A = sum_j w_ij e'_ij e_ij^T.
// This is the rotation of A's polar decomposition with the reflection fixed
// (U diag(1, 1, det(U V^T)) V^T from the SVD A = U S V^T).
#pragma once

#include <Eigen/Core>

namespace arap {

// Fast path: the largest eigenvector of Davenport's 4x4 symmetric matrix
// K(A) (q^T K q = <R(q), A> for unit quaternions q), its eigenvalue found by
// Newton's method on the characteristic polynomial and the eigenvector taken
// from the adjugate of K - lambda I. Falls back to a full SVD when the
// eigenvalue is (nearly) repeated; returns true when it did.
// `lambda_hint` (optional, in/out): the top eigenvalue found for this cell last
// time. Newton starts there when it is provably above the root (the polynomial
// and its first three derivatives are positive there), which saves most of the
// iterations between local steps; the new eigenvalue is written back.
bool fit_rotation(const Eigen::Matrix3d& A, Eigen::Matrix3d& R, double* lambda_hint = nullptr);

// Reference: Eigen's JacobiSVD with the reflection fixed.
Eigen::Matrix3d fit_rotation_svd(const Eigen::Matrix3d& A);

}  // namespace arap
