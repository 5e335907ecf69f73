#include "arap/rotation_fit.h"

#include <cmath>

#include <Eigen/LU>
#include <Eigen/SVD>

namespace arap {

Eigen::Matrix3d fit_rotation_svd(const Eigen::Matrix3d& A) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(A, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d U = svd.matrixU();
  const Eigen::Matrix3d& V = svd.matrixV();
  Eigen::Matrix3d R = U * V.transpose();
  if (R.determinant() < 0) {
    // Reflection: flip the column of the smallest singular value (Eigen sorts them descending).
    U.col(2) *= -1.0;
    R = U * V.transpose();
  }
  return R;
}

namespace {

// The adjugate of a 4x4 matrix from its twelve 2x2 minors (rows 0-1 and rows 2-3),
// the same expansion as det4 below; adj(M) = det(M) inverse(M).
void adjugate4(const double a[4][4], double adj[4][4]) {
  const double s0 = a[0][0] * a[1][1] - a[1][0] * a[0][1], s1 = a[0][0] * a[1][2] - a[1][0] * a[0][2];
  const double s2 = a[0][0] * a[1][3] - a[1][0] * a[0][3], s3 = a[0][1] * a[1][2] - a[1][1] * a[0][2];
  const double s4 = a[0][1] * a[1][3] - a[1][1] * a[0][3], s5 = a[0][2] * a[1][3] - a[1][2] * a[0][3];
  const double c5 = a[2][2] * a[3][3] - a[3][2] * a[2][3], c4 = a[2][1] * a[3][3] - a[3][1] * a[2][3];
  const double c3 = a[2][1] * a[3][2] - a[3][1] * a[2][2], c2 = a[2][0] * a[3][3] - a[3][0] * a[2][3];
  const double c1 = a[2][0] * a[3][2] - a[3][0] * a[2][2], c0 = a[2][0] * a[3][1] - a[3][0] * a[2][1];
  adj[0][0] = a[1][1] * c5 - a[1][2] * c4 + a[1][3] * c3;
  adj[0][1] = -a[0][1] * c5 + a[0][2] * c4 - a[0][3] * c3;
  adj[0][2] = a[3][1] * s5 - a[3][2] * s4 + a[3][3] * s3;
  adj[0][3] = -a[2][1] * s5 + a[2][2] * s4 - a[2][3] * s3;
  adj[1][0] = -a[1][0] * c5 + a[1][2] * c2 - a[1][3] * c1;
  adj[1][1] = a[0][0] * c5 - a[0][2] * c2 + a[0][3] * c1;
  adj[1][2] = -a[3][0] * s5 + a[3][2] * s2 - a[3][3] * s1;
  adj[1][3] = a[2][0] * s5 - a[2][2] * s2 + a[2][3] * s1;
  adj[2][0] = a[1][0] * c4 - a[1][1] * c2 + a[1][3] * c0;
  adj[2][1] = -a[0][0] * c4 + a[0][1] * c2 - a[0][3] * c0;
  adj[2][2] = a[3][0] * s4 - a[3][1] * s2 + a[3][3] * s0;
  adj[2][3] = -a[2][0] * s4 + a[2][1] * s2 - a[2][3] * s0;
  adj[3][0] = -a[1][0] * c3 + a[1][1] * c1 - a[1][2] * c0;
  adj[3][1] = a[0][0] * c3 - a[0][1] * c1 + a[0][2] * c0;
  adj[3][2] = -a[3][0] * s3 + a[3][1] * s1 - a[3][2] * s0;
  adj[3][3] = a[2][0] * s3 - a[2][1] * s1 + a[2][2] * s0;
}

double det4(const double M[4][4]) {
  // Laplace expansion along rows (0, 1) against rows (2, 3) with 2x2 minors.
  auto s = [&](int a, int b) { return M[0][a] * M[1][b] - M[0][b] * M[1][a]; };
  auto c = [&](int a, int b) { return M[2][a] * M[3][b] - M[2][b] * M[3][a]; };
  return s(0, 1) * c(2, 3) - s(0, 2) * c(1, 3) + s(0, 3) * c(1, 2) + s(1, 2) * c(0, 3) - s(1, 3) * c(0, 2) +
         s(2, 3) * c(0, 1);
}

}  // namespace

bool fit_rotation(const Eigen::Matrix3d& A, Eigen::Matrix3d& R, double* lambda_hint) {
  const double norm2 = A.squaredNorm();
  if (!(norm2 > 1e-300)) {
    R.setIdentity();  // an empty cell: any rotation is optimal
    return false;
  }
  // Davenport's matrix: q^T K q = <R(q), A> for unit quaternions q = (w, x, y, z).
  double K[4][4];
  K[0][0] = A(0, 0) + A(1, 1) + A(2, 2);
  K[1][1] = A(0, 0) - A(1, 1) - A(2, 2);
  K[2][2] = -A(0, 0) + A(1, 1) - A(2, 2);
  K[3][3] = -A(0, 0) - A(1, 1) + A(2, 2);
  K[0][1] = K[1][0] = A(2, 1) - A(1, 2);
  K[0][2] = K[2][0] = A(0, 2) - A(2, 0);
  K[0][3] = K[3][0] = A(1, 0) - A(0, 1);
  K[1][2] = K[2][1] = A(0, 1) + A(1, 0);
  K[1][3] = K[3][1] = A(0, 2) + A(2, 0);
  K[2][3] = K[3][2] = A(1, 2) + A(2, 1);

  // det(K - l I) = l^4 + c2 l^2 + c1 l + c0 (K is traceless). Its largest root is
  // s1 + s2 + sign(det A) s3 <= sqrt(3) |A|_F; Newton's method from that upper
  // bound decreases monotonically onto it because all roots are real.
  const double c2 = -2.0 * norm2;
  const double c1 = -8.0 * A.determinant();
  const double c0 = det4(K);
  const double start = std::sqrt(3.0 * norm2);
  double lambda = start;
  if (lambda_hint && *lambda_hint > 0) {
    // l is above every root of f iff f, f', f'' and f''' (= 24 l) are all positive there.
    for (const double margin : {1e-6, 1e-2}) {
      const double l = std::min(start, *lambda_hint * (1 + margin));
      const double l2 = l * l;
      if ((l2 + c2) * l2 + c1 * l + c0 > 0 && (4.0 * l2 + 2.0 * c2) * l + c1 > 0 && 6.0 * l2 + c2 > 0) {
        lambda = l;
        break;
      }
    }
  }
  bool newton_converged = false;
  for (int it = 0; it < 60; ++it) {
    const double l2 = lambda * lambda;
    const double f = (l2 + c2) * l2 + c1 * lambda + c0;
    const double df = (4.0 * l2 + 2.0 * c2) * lambda + c1;
    if (!(df > 0)) break;
    const double step = f / df;
    lambda -= step;
    if (std::abs(step) <= 1e-13 * start) {
      newton_converged = true;
      break;
    }
  }

  // For a simple eigenvalue, adj(K - l I) = c q q^T: take its largest column.
  double M[4][4];
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) M[i][j] = K[i][j] - (i == j ? lambda : 0.0);
  double adj[4][4];
  adjugate4(M, adj);
  int best = 0;
  double best_value = 0;
  for (int k = 0; k < 4; ++k) {
    const double d = std::abs(adj[k][k]);
    if (d > best_value) best_value = d, best = k;
  }
  // A (near) repeated top eigenvalue makes the adjugate vanish: use the SVD.
  if (!newton_converged || !(best_value > 1e-9 * start * start * start)) {
    R = fit_rotation_svd(A);
    if (lambda_hint) *lambda_hint = 0;
    return true;
  }
  if (lambda_hint) *lambda_hint = lambda;
  double q[4];
  for (int i = 0; i < 4; ++i) q[i] = adj[i][best];
  const double inv = 1.0 / std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  const double w = q[0] * inv, x = q[1] * inv, y = q[2] * inv, z = q[3] * inv;
  R << w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y),  //
      2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x),     //
      2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z;
  return false;
}

}  // namespace arap
