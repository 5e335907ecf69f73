// The L-BFGS two-loop recursion (lbfgs.h) against the inverse-Hessian update
// written out densely (Nocedal & Wright, eq. 6.17 applied to each stored pair
// in turn from H0 = scale * P), and the scale of H0 only once a pair is stored.
#include <gtest/gtest.h>

#include <random>

#include <Eigen/Dense>

#include "lbfgs.h"

namespace {

constexpr int kDimension = 7;

Eigen::VectorXd random_vector(std::mt19937& rng) {
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  Eigen::VectorXd v(kDimension);
  for (int i = 0; i < kDimension; ++i) v[i] = uniform(rng);
  return v;
}

// A diagonal "preconditioner" P, applied in place as the solver applies L^-1.
struct Diagonal {
  Eigen::VectorXd p;
  void operator()(double* v) const {
    for (int i = 0; i < p.size(); ++i) v[i] *= p[i];
  }
};

// H_{k+1} = (I - rho s y^T) H_k (I - rho y s^T) + rho s s^T, rho = 1 / (s.y), oldest pair first.
Eigen::MatrixXd dense_inverse_hessian(const Eigen::MatrixXd& H0, const std::vector<Eigen::VectorXd>& s,
                                      const std::vector<Eigen::VectorXd>& y) {
  Eigen::MatrixXd H = H0;
  const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(H0.rows(), H0.cols());
  for (size_t k = 0; k < s.size(); ++k) {
    const double rho = 1.0 / s[k].dot(y[k]);
    H = (I - rho * s[k] * y[k].transpose()) * H * (I - rho * y[k] * s[k].transpose()) + rho * s[k] * s[k].transpose();
  }
  return H;
}

TEST(Lbfgs, DirectionIsMinusTheUpdatedInverseHessianTimesTheGradientWithAScaledH0) {
  std::mt19937 rng(7);
  Diagonal P{random_vector(rng).cwiseAbs().array() + 0.5};
  std::vector<Eigen::VectorXd> s, y;
  arap::LbfgsHistory history;
  history.reset(3, kDimension);
  for (int k = 0; k < 3; ++k) {
    s.push_back(random_vector(rng));
    // y = B s with B symmetric positive definite: s.y > 0, as commit() requires.
    y.push_back((Eigen::VectorXd::Constant(kDimension, 2.0) + k * Eigen::VectorXd::LinSpaced(kDimension, 0, 1))
                    .cwiseProduct(s.back()));
    Eigen::Map<Eigen::VectorXd>(history.next_s(), kDimension) = s.back();
    Eigen::Map<Eigen::VectorXd>(history.next_y(), kDimension) = y.back();
    ASSERT_TRUE(history.commit(s.back().dot(y.back()), s.back().squaredNorm(), y.back().squaredNorm()));
  }
  const Eigen::VectorXd g = random_vector(rng);
  for (const double scale : {1.0, 1.7}) {
    Eigen::VectorXd d(kDimension);
    history.set_h0_scale(scale);
    const double slope = history.direction(g.data(), d.data(), P);
    const Eigen::MatrixXd H0 = scale * Eigen::MatrixXd(P.p.asDiagonal());
    const Eigen::VectorXd expected = -dense_inverse_hessian(H0, s, y) * g;
    EXPECT_LT((d - expected).norm(), 1e-12 * expected.norm()) << "scale " << scale;
    EXPECT_NEAR(slope, g.dot(d), 1e-12 * std::abs(slope));
  }
  // The secant condition of the newest pair holds whatever H0 is: H y = s.
  Eigen::VectorXd d(kDimension);
  history.direction(y.back().data(), d.data(), P);  // the scale is still 1.7
  EXPECT_LT((d + s.back()).norm(), 1e-12 * s.back().norm());
}

TEST(Lbfgs, WithNoPairStoredTheDirectionIsThePreconditionedStepWhateverTheScale) {
  std::mt19937 rng(11);
  Diagonal P{random_vector(rng).cwiseAbs().array() + 0.5};
  arap::LbfgsHistory history;
  history.reset(4, kDimension);
  const Eigen::VectorXd g = random_vector(rng);
  Eigen::VectorXd d(kDimension);
  history.set_h0_scale(1.7);
  history.direction(g.data(), d.data(), P);
  EXPECT_EQ(d, Eigen::VectorXd(-P.p.cwiseProduct(g)));
}

TEST(Lbfgs, ClearingTheHistoryResetsTheScale) {
  std::mt19937 rng(13);
  Diagonal P{random_vector(rng).cwiseAbs().array() + 0.5};
  arap::LbfgsHistory scaled, fresh;
  for (arap::LbfgsHistory* h : {&scaled, &fresh}) h->reset(2, kDimension);
  scaled.set_h0_scale(1.7);
  scaled.clear();
  // The same pair in both: the direction is the same only if clear() forgot the scale.
  const Eigen::VectorXd s = random_vector(rng), y = 2.0 * s, g = random_vector(rng);
  for (arap::LbfgsHistory* h : {&scaled, &fresh}) {
    Eigen::Map<Eigen::VectorXd>(h->next_s(), kDimension) = s;
    Eigen::Map<Eigen::VectorXd>(h->next_y(), kDimension) = y;
    ASSERT_TRUE(h->commit(s.dot(y), s.squaredNorm(), y.squaredNorm()));
  }
  Eigen::VectorXd a(kDimension), b(kDimension);
  scaled.direction(g.data(), a.data(), P);
  fresh.direction(g.data(), b.data(), P);
  EXPECT_EQ(a, b);
}

}  // namespace
