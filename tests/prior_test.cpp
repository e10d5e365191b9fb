// The tolerance prior of step 2 (issue 25): its evidence against the marginal
// likelihood written out over the measurements, and what it does in calibrate.
#include "identification/search/prior.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "hapticcal/study/simulation.hpp"
#include "hapticcal/study/study.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

// y = X b + e with b_j ~ N(0, (s t_j)^2), e ~ N(0, sigma^2): y ~ N(0, sigma^2 I
// + s^2 X T^2 X^T). The log marginal likelihood at lambda = sigma^2 / s^2 with
// sigma^2 at its optimum (y^T C^-1 y / n, C = I + X T^2 X^T / lambda), over the
// n x n covariance itself (constants dropped).
double brute_profile(const Eigen::MatrixXd& X, const Eigen::VectorXd& t, const Eigen::VectorXd& y,
                     double lambda) {
  const Eigen::Index n = y.size();
  const Eigen::MatrixXd XT = X * t.asDiagonal();
  const Eigen::MatrixXd C = Eigen::MatrixXd::Identity(n, n) + XT * XT.transpose() / lambda;
  const Eigen::LLT<Eigen::MatrixXd> llt(C);
  const double sigma2 = y.dot(llt.solve(y)) / static_cast<double>(n);
  const double log_det = 2 * Eigen::MatrixXd(llt.matrixL()).diagonal().array().log().sum();
  return -0.5 * static_cast<double>(n) * std::log(sigma2) - 0.5 * log_det;
}

struct LinearCase {
  Eigen::MatrixXd X;
  Eigen::VectorXd t, y;
};

// n rows, k columns, tolerances t, truth b ~ N(0, (scale t)^2), noise sd sigma.
LinearCase linear_case(int n, int k, double scale, double sigma, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0, 1);
  LinearCase c;
  c.X = Eigen::MatrixXd::NullaryExpr(n, k, [&]() { return normal(rng); });
  c.t = Eigen::VectorXd::LinSpaced(k, 1e-3, 4e-3);
  Eigen::VectorXd b(k);
  for (int j = 0; j < k; ++j) b[j] = scale * c.t[j] * normal(rng);
  c.y = c.X * b;
  for (int i = 0; i < n; ++i) c.y[i] += sigma * normal(rng);
  return c;
}

// The stack of the linear case at b = 0: residuals X b - y, Jacobian X.
detail::Stack stack_of(const LinearCase& c) {
  detail::Stack s;
  s.r = -c.y;
  s.J = c.X;
  s.rss = s.r.squaredNorm();
  s.residuals = s.r.size();
  return s;
}

// The evidence's lambda maximises the marginal likelihood computed over the
// measurements (n x n), its value differs from it by a constant, and the
// noise sd and scale it reports are that optimum's.
TEST(TolerancePrior, EvidenceIsTheMarginalLikelihoodOfTheMeasurements) {
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    const LinearCase c = linear_case(40, 6, 2.0, 1e-3, seed);
    std::vector<int> slots = {0, 1, 2, 3, 4, 5};
    const std::optional<detail::PriorChoice> choice =
        detail::choose_prior(stack_of(c), slots, c.t, Eigen::VectorXd::Zero(6), 40.0, std::nullopt);
    ASSERT_TRUE(choice.has_value());
    // A fine grid over log10(lambda) of the brute-force profile.
    double best = 0, best_value = -1e300;
    for (double x = -10; x <= 6; x += 1e-3) {
      const double v = brute_profile(c.X, c.t, c.y, std::pow(10.0, x));
      if (v > best_value) {
        best_value = v;
        best = x;
      }
    }
    EXPECT_NEAR(std::log10(choice->lambda), best, 2e-3) << seed;
    // The same function up to a constant: differences between points of the
    // reported curve equal the brute-force ones.
    const auto& curve = choice->curve;
    ASSERT_GT(curve.size(), 40u);
    for (size_t a : {size_t{5}, curve.size() / 2, curve.size() - 5}) {
      const auto [xa, va] = curve[a];
      const auto [xb, vb] = curve[a - 3];
      const double brute = brute_profile(c.X, c.t, c.y, std::pow(10.0, xa)) -
                           brute_profile(c.X, c.t, c.y, std::pow(10.0, xb));
      EXPECT_NEAR(va - vb, brute, 1e-5 * (1 + std::abs(brute))) << seed << " at " << xa;
    }
    const double l1 = choice->lambda;
    const double sigma2 = c.y.dot((Eigen::MatrixXd::Identity(40, 40) +
                                   c.X * c.t.cwiseAbs2().asDiagonal() * c.X.transpose() / l1)
                                      .llt()
                                      .solve(c.y)) /
                          40;
    EXPECT_NEAR(choice->sigma, std::sqrt(sigma2), 1e-9 * std::sqrt(sigma2)) << seed;
    EXPECT_NEAR(choice->scale, choice->sigma / std::sqrt(choice->lambda), 1e-12) << seed;
    // Every column is seen by 40 rows: the data, not the prior, set them.
    EXPECT_GT(choice->data_share.minCoeff(), 0.9) << seed;
    EXPECT_LE(choice->data_share.maxCoeff(), 1.0) << seed;
  }
}

// A column the data do not see is set by the prior (data share 0), and a free
// column (infinite tolerance) is the data's alone (share 1).
TEST(TolerancePrior, UnseenColumnIsThePriorsAndFreeColumnTheDatas) {
  LinearCase c = linear_case(30, 4, 1.0, 1e-3, 7);
  c.X.col(2).setZero();
  Eigen::VectorXd t = c.t;
  t[3] = std::numeric_limits<double>::infinity();
  const std::optional<detail::PriorChoice> choice = detail::choose_prior(
      stack_of(c), {0, 1, 2, 3}, t, Eigen::VectorXd::Zero(4), 30.0, std::nullopt);
  ASSERT_TRUE(choice.has_value());
  EXPECT_NEAR(choice->data_share[2], 0.0, 1e-12);
  EXPECT_DOUBLE_EQ(choice->data_share[3], 1.0);
  EXPECT_GT(choice->data_share[0], 0.5);
  // Singular free columns: no evidence.
  c.X.col(3).setZero();
  EXPECT_FALSE(detail::choose_prior(stack_of(c), {0, 1, 2, 3}, t, Eigen::VectorXd::Zero(4), 30.0,
                                    std::nullopt)
                   .has_value());
}

// A given scale: lambda = sigma^2 / scale^2 with sigma re-estimated for it.
TEST(TolerancePrior, GivenScaleSetsTheWeightWithTheNoiseReestimated) {
  const LinearCase c = linear_case(50, 5, 1.0, 2e-3, 3);
  const std::optional<detail::PriorChoice> choice =
      detail::choose_prior(stack_of(c), {0, 1, 2, 3, 4}, c.t, Eigen::VectorXd::Zero(5), 50.0, 0.5);
  ASSERT_TRUE(choice.has_value());
  EXPECT_DOUBLE_EQ(choice->scale, 0.5);
  // lambda (0.5)^2 = sigma^2, sigma^2 = |y - X b|^2 / (n - gamma) at the MAP b.
  const double lambda = choice->lambda;
  const Eigen::MatrixXd XT = c.X * c.t.asDiagonal();
  const Eigen::MatrixXd M = XT.transpose() * XT + lambda * Eigen::MatrixXd::Identity(5, 5);
  const Eigen::VectorXd u = M.llt().solve(XT.transpose() * c.y);
  const double gamma = 5 - lambda * M.inverse().trace();
  const double sigma2 = (c.y - XT * u).squaredNorm() / (50 - gamma);
  EXPECT_NEAR(lambda * 0.25, sigma2, 1e-8 * sigma2);
}

TEST(TolerancePrior, ToleranceItemsAreCheckedAndNamed) {
  Tolerances t;
  add_tolerance(t, "length=0.001");
  add_tolerance(t, "angle=2e-3");
  add_tolerance(t, "j2.a=3e-4");
  EXPECT_DOUBLE_EQ(t.length, 1e-3);
  EXPECT_DOUBLE_EQ(t.angle, 2e-3);
  EXPECT_DOUBLE_EQ(t.by_name.at("j2.a"), 3e-4);
  for (const char* bad : {"length", "length=", "=1", "length=-1", "angle=nan", "j2.a=1mm",
                          "length=inf", "length=0"}) {
    EXPECT_THROW(add_tolerance(t, bad), InputError) << bad;
  }
  t.by_name["j9.zz"] = 1e-3;
  EXPECT_THROW(detail::slot_tolerances(testing::meca500(), t), InputError);
  // Finite but beyond the evidence's range (1e160 m once looped for ever): refused.
  const Log log = testing::meca500_log("cal", testing::kMeca500Sets[0]);
  for (const char* item : {"length=1e160", "angle=1e-20", "j2.a=5000"}) {
    CalibrationOptions o;
    add_tolerance(o.tolerances, item);
    EXPECT_THROW(calibrate(testing::meca500(), log, o), InputError) << item;
  }
  CalibrationOptions huge;
  huge.tolerances.scale = 1e300;
  EXPECT_THROW(calibrate(testing::meca500(), log, huge), InputError);
}

// The real Meca500 (laser tracker; each set's validation log held out: 10
// poses of 3 readings a set). The default (the model search) against the
// significance cut, least squares and an oracle that picks, set by set, the
// best of the prior at five scales, the cut and least squares by the
// validation log itself (0.0446 mm: the error left is per pose). The search
// keeps what the held-out poses of each calibration log prefer, which on
// these sets is least squares or the cut about equally; the 70 validation
// poses cannot tell its choice from the cut's (a paired t below 2 on their
// squared errors; docs/calibrate.md, "The model search"), and every set stays below 0.07 mm.
TEST(TolerancePrior, Meca500DefaultIsWithinTheValidationNoiseOfTheCut) {
  const DeviceModel nominal = testing::meca500();
  std::vector<CalibrationOptions> options(4);
  options[1].select = true;
  options[1].search = false;  // one model
  options[2].keep_all = true;
  options[2].search = false;  // one model
  const char* label[] = {"default", "select", "keep-all", "oracle"};
  double sum[4] = {0, 0, 0, 0}, worst[4] = {0, 0, 0, 0};
  std::vector<double> difference;  // per validation pose: default - cut squared error
  for (const char* set : testing::kMeca500Sets) {
    const Log cal = testing::meca500_log("cal", set), val = testing::meca500_log("val", set);
    double v[4];
    Eigen::VectorXd errors[3];
    for (int k = 0; k < 3; ++k) {
      const CalibrationResult r = calibrate(nominal, cal, options[k]);
      ASSERT_EQ(r.status, CalibrationStatus::kConverged) << set;
      if (k == 0) {
        EXPECT_TRUE(r.kinematics.search.ran) << set;
      }
      const Evaluation e = evaluate(r.calibrated, val);
      v[k] = e.figure("position")->stats.rms;
      errors[k] = e.figure("position")->error.array().square();
    }
    for (Eigen::Index row = 0; row + 2 < errors[0].size(); row += 3) {
      difference.push_back(errors[0].segment(row, 3).mean() - errors[1].segment(row, 3).mean());
    }
    v[3] = std::min(v[1], v[2]);
    for (double scale : {0.25, 0.5, 1.0, 2.0, 4.0}) {
      CalibrationOptions o;
      o.tolerances.scale = scale;
      o.search = false;  // the prior itself, not the choice
      v[3] = std::min(
          v[3], evaluate(calibrate(nominal, cal, o).calibrated, val).figure("position")->stats.rms);
    }
    for (int k = 0; k < 4; ++k) {
      sum[k] += v[k];
      worst[k] = std::max(worst[k], v[k]);
    }
    std::printf("%-32s validation RMS: default %.4f, select %.4f, keep-all %.4f, oracle %.4f mm\n",
                set, v[0] * 1e3, v[1] * 1e3, v[2] * 1e3, v[3] * 1e3);
  }
  for (int k = 0; k < 4; ++k) {
    std::printf("%-8s 7-set mean %.5f mm, worst %.4f mm\n", label[k], sum[k] / 7 * 1e3,
                worst[k] * 1e3);
  }
  const double n = static_cast<double>(difference.size());
  double mean = 0, var = 0;
  for (double d : difference) mean += d / n;
  for (double d : difference) var += (d - mean) * (d - mean) / (n - 1);
  const double t = mean / std::sqrt(var / n);
  std::printf("default - cut, %g validation poses: %.3g mm^2 mean squared error, t = %.2f\n", n,
              mean * 1e6, t);
  EXPECT_LT(t, 2.0);
  EXPECT_LT(worst[0], 0.07e-3);
  EXPECT_LT(sum[0] / 7, 0.048e-3);
  EXPECT_GT(sum[3] / 7, 0.042e-3);  // issue 25's target is out of reach (see above)
}

// The paper's simulation study (the built-in device, 200 noisy distances a
// trial, every parameter deviating as in the paper): the default predicts the
// true device's distances at 300 poses it did not see (noise-free) within 2 %
// of least squares (issue 25's acceptance), mean over 10 trials.
TEST(TolerancePrior, PaperStudyDefaultPredictsAsWellAsLeastSquares) {
  const Scenario sc = default_scenario(testing::source_path("data/devices/baser-7dof.yaml"));
  SimulationNoise exact = sc.noise;
  exact.sigma_distance = exact.sigma_position = 0;
  exact.sigma_ext = 0;
  exact.motor_counts_per_rev = 0;
  double sum_default = 0, sum_all = 0;
  CalibrationOptions all;
  all.keep_all = true;
  all.search = false;  // one model
  for (int t = 0; t < 10; ++t) {
    const Log log = simulate_log(sc.actual, 200, sc.noise, trial_seed(sc.seed, t));
    const Log check = simulate_log(sc.actual, 300, exact, trial_seed(sc.seed + 1, t));
    const CalibrationResult d = calibrate(sc.nominal, log, {});
    const CalibrationResult a = calibrate(sc.nominal, log, all);
    ASSERT_EQ(d.status, CalibrationStatus::kConverged) << d.status_reason;
    const double ed = evaluate(d.calibrated, check).figure("distance")->stats.rms;
    const double ea = evaluate(a.calibrated, check).figure("distance")->stats.rms;
    std::printf("trial %d: default (%s) %.2f um, least squares %.2f um\n", t,
                d.kinematics.choice.c_str(), ed * 1e6, ea * 1e6);
    sum_default += ed;
    sum_all += ea;
  }
  std::printf("mean over 10 trials: default %.2f um, least squares %.2f um\n",
              sum_default / 10 * 1e6, sum_all / 10 * 1e6);
  EXPECT_LE(sum_default, 1.02 * sum_all);
}

}  // namespace
}  // namespace hapticcal
