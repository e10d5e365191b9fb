// The information module against independent computations: singular values by
// Eigen's JacobiSVD, the covariance by a direct inverse, and the two-step bound
// by simulating the linear two-step estimator it describes.
#include "hapticcal/identification/information.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

namespace hapticcal {
namespace {

Eigen::MatrixXd random_matrix(int rows, int cols, std::mt19937_64& rng) {
  std::normal_distribution<double> n(0, 1);
  Eigen::MatrixXd M(rows, cols);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) M(r, c) = n(rng);
  return M;
}

TEST(Information, CovarianceAndConditioningMatchDirectComputations) {
  std::mt19937_64 rng(3);
  const Eigen::MatrixXd J =
      random_matrix(40, 5, rng) * Eigen::Vector<double, 5>(1, 2, 3, 0.5, 9).asDiagonal();
  const double sigma = 0.01;
  const Eigen::MatrixXd direct = sigma * sigma * (J.transpose() * J).inverse();
  EXPECT_LT((parameter_covariance(J, sigma) - direct).norm(), 1e-12 * direct.norm());
  EXPECT_LT((fisher_information(J, sigma) - direct.inverse()).norm(),
            1e-9 * direct.inverse().norm());
  const Eigen::VectorXd s = Eigen::JacobiSVD<Eigen::MatrixXd>(J).singularValues();
  const Conditioning c = conditioning(J, 40);
  EXPECT_NEAR(c.condition_number, s[0] / s[4], 1e-9 * s[0] / s[4]);
  EXPECT_NEAR(c.observability.O1, std::pow(s.prod(), 1.0 / 5) / std::sqrt(40.0), 1e-12);
  EXPECT_NEAR(c.observability.O3, s[4], 1e-12);
  EXPECT_NEAR(c.observability.O4, s[4] * s[4] / s[0], 1e-12);
  // A direction the rows do not see: infinite variance, not a huge number.
  Eigen::MatrixXd blind = J;
  blind.col(2).setZero();
  EXPECT_TRUE(std::isinf(parameter_covariance(blind, sigma)(2, 2)));
}

// The linear two-step estimator: step 1 fits x1 from e = Je x1 + noise_e; step 2
// fits x2 from y = Jk x2 + Jt x1 + noise_m using the step-1 estimate of x1. Its
// covariance, by simulation, is the bound's.
TEST(Information, TwoStepBoundIsTheTwoStepEstimatorsCovariance) {
  std::mt19937_64 rng(5);
  const int m = 60, np = 2, k = 3;
  StepOneSensitivity st;
  st.names = {"t.a", "t.b"};
  st.encoder = random_matrix(m, np + 1, rng);
  st.measurement = 0.5 * random_matrix(m, np, rng);
  const Eigen::MatrixXd Jk = random_matrix(m, k, rng);
  const double se = 0.02, sm = 0.01;
  const TwoStepBound bound = two_step_crlb(Jk, {"k1", "k2", "k3"}, sm, {st}, se);
  ASSERT_EQ(bound.names.size(), 5u);
  EXPECT_EQ(bound.names[0], "t.a");
  EXPECT_EQ(bound.names[4], "k3");

  std::normal_distribution<double> n(0, 1);
  const int trials = 40000;
  Eigen::MatrixXd estimates(trials, np + k);
  const auto solve1 = st.encoder.colPivHouseholderQr();
  const auto solve2 = Jk.colPivHouseholderQr();
  for (int t = 0; t < trials; ++t) {
    Eigen::VectorXd noise_e(m), noise_m(m);
    for (int r = 0; r < m; ++r) {
      noise_e[r] = se * n(rng);
      noise_m[r] = sm * n(rng);
    }
    const Eigen::VectorXd x1 = solve1.solve(noise_e);  // truth 0
    const Eigen::VectorXd x2 = solve2.solve(noise_m - st.measurement * x1.head(np));
    estimates.row(t) << x1.head(np).transpose(), x2.transpose();
  }
  for (int c = 0; c < np + k; ++c) {
    const double variance = estimates.col(c).squaredNorm() / trials;
    EXPECT_NEAR(variance / bound.variance[c], 1.0, 0.03) << bound.names[c];
  }
}

}  // namespace
}  // namespace hapticcal
