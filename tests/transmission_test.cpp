// Transmission models: closed forms, home reference, and every derivative
// against central differences.
#include "hapticcal/model/transmission.hpp"

#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

#include "hapticcal/identification/derivative_check.hpp"

namespace hapticcal {
namespace {

constexpr double kDeg = std::numbers::pi / 180;

// Paper Table 2, capstan 1 (radii in metres), R = 10, D = 5 mm.
Capstan table2_capstan1() {
  Capstan c;
  c.ratio = 10;
  c.drum_distance = 0.005;
  c.ratio_error = -0.025;
  c.r_out = 0.2e-3;
  c.beta_out = -105 * kDeg;
  c.r_in = 0.005e-3;
  c.beta_in = -15 * kDeg;
  c.offset = 0.01;  // never part of error()
  return c;
}

// L1 = L3 = 0.05, L2 = L4 = 0.21, with Table 2's dL1, dL2.
Parallelogram table2_parallelogram() { return {0.05 - 0.0005, 0.21 - 0.0007, 0.05, 0.21}; }

Polynomial chebyshev10() {
  Polynomial p;
  p.lower = -std::numbers::pi / 4;
  p.upper = std::numbers::pi / 4;
  for (int k = 0; k <= 10; ++k) p.coefficients.push_back(std::pow(-0.5, k) * 1e-3);
  return p;
}

Polynomial paper_table2_monomial() {
  Polynomial p;
  p.basis = PolynomialBasis::kMonomial;
  p.coefficients = {0.000043, -0.005159, 0.040587,  -0.100185, -0.391253, 0.508398,
                    1.436945, -0.983788, -2.185038, 0.633845,  1.191804};
  return p;
}

Transmission joint4_chain() {
  Capstan c = table2_capstan1();
  c.ratio_error = 0.02;
  c.r_out = 0.1e-3;
  c.beta_out = -40 * kDeg;
  c.r_in = 0.002e-3;
  c.beta_in = -120 * kDeg;
  return Transmission(Chain{{Transmission(c), Transmission(table2_parallelogram())}});
}

std::vector<std::pair<std::string, Transmission>> models() {
  return {{"capstan", Transmission(table2_capstan1())},
          {"parallelogram", Transmission(table2_parallelogram())},
          {"chebyshev", Transmission(chebyshev10())},
          {"monomial", Transmission(paper_table2_monomial())},
          {"chain", joint4_chain()}};
}

TEST(Transmission, EveryModelIsZeroAtHome) {
  for (const auto& [name, t] : models()) {
    EXPECT_EQ(t.error(0.0), 0.0) << name;
    EXPECT_LT(std::abs(PreparedTransmission(t).error(0.0)), 1e-17) << name;
  }
}

TEST(Transmission, IdealParallelogramHasNoErrorOverPlusMinus45Degrees) {
  const Transmission ideal(Parallelogram{0.05, 0.21, 0.05, 0.21});
  for (int i = -450; i <= 450; ++i) {
    const double q = i * 0.1 * kDeg;
    EXPECT_LT(std::abs(ideal.error(q)), 1e-14) << q;
    EXPECT_LT(std::abs(ideal.derivative(q)), 1e-12) << q;
  }
  // A real deviation does give an error (the test above can fail).
  EXPECT_GT(std::abs(Transmission(table2_parallelogram()).error(0.5)), 1e-4);
}

TEST(Transmission, CapstanMatchesPaperEquation1TermByTerm) {
  const Capstan c = table2_capstan1();
  const double q = 0.7, R = c.ratio, D = c.drum_distance;
  auto ecc = [&](double r, double u) { return std::atan(r * std::sin(u) / (D - r * std::cos(u))); };
  const double expected = -c.ratio_error / (c.ratio_error + R) * q + ecc(c.r_out, q + c.beta_out) -
                          ecc(c.r_out, c.beta_out) + ecc(c.r_in, R * q + c.beta_in) -
                          ecc(c.r_in, c.beta_in);
  EXPECT_NEAR(Transmission(c).error(q), expected, 1e-16);
}

// hapticcal::check_reading_derivative: step 1e-6 rad, tolerance 1e-8 relative to 1 + |d|.
TEST(Transmission, DerivativeWithRespectToReadingMatchesCentralDifferences) {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(-std::numbers::pi / 4, std::numbers::pi / 4);
  for (const auto& [name, t] : models()) {
    for (int i = 0; i < 50; ++i) {
      const double q = u(rng);
      EXPECT_LT(check_reading_derivative(t, q, 1e-6).max_error, 1e-8) << name << " q=" << q;
    }
  }
}

// hapticcal::check_parameter_jacobian: step 1e-6 relative, tolerance 1e-7 relative.
TEST(Transmission, ParameterDerivativesMatchCentralDifferences) {
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> u(-std::numbers::pi / 4, std::numbers::pi / 4);
  for (const auto& [name, t] : models()) {
    ASSERT_EQ(t.parameters().size(), t.num_parameters());
    ASSERT_EQ(static_cast<int>(t.parameter_names().size()), t.num_parameters());
    for (int i = 0; i < 20; ++i) {
      const double q = u(rng);
      const DerivativeCheck check = check_parameter_jacobian(t, q, 1e-6);
      EXPECT_LT(check.max_error, 1e-7) << name << "." << check.worst << " q=" << q;
    }
  }
}

// The public checker's central differences against a closed form.
TEST(Transmission, CentralDifferenceMatchesAClosedForm) {
  const Eigen::Vector2d x(0.3, -1.2);
  const Eigen::MatrixXd J = central_difference(
      [](const Eigen::VectorXd& v) {
        return Eigen::Vector2d(std::sin(v[0]) * v[1], v[1] * v[1]).eval();
      },
      x, Eigen::Vector2d::Constant(1e-6));
  ASSERT_EQ(J.rows(), 2);
  EXPECT_NEAR(J(0, 0), std::cos(0.3) * -1.2, 1e-9);
  EXPECT_NEAR(J(0, 1), std::sin(0.3), 1e-9);
  EXPECT_NEAR(J(1, 0), 0.0, 1e-9);
  EXPECT_NEAR(J(1, 1), -2.4, 1e-9);
}

TEST(Transmission, GenericEvaluationRunsWithJetAndGivesTheParameterJacobian) {
  using Jet = ceres::Jet<double, 16>;
  for (const auto& [name, t] : models()) {
    const Eigen::VectorXd p0 = t.parameters();
    ASSERT_LE(p0.size(), 16);
    std::vector<Jet> p(p0.size());
    for (int k = 0; k < p0.size(); ++k) p[k] = Jet(p0[k], k);
    const double q = 0.3;
    const Jet e = t.error(p.data(), Jet(q));
    EXPECT_NEAR(e.a, t.error(q), 1e-15) << name;
    std::vector<double> J(t.num_parameters());
    t.parameter_jacobian(q, J.data());
    for (int k = 0; k < p0.size(); ++k)
      EXPECT_NEAR(e.v[k], J[k], 1e-12 * (1 + std::abs(J[k]))) << name;
  }
}

TEST(Transmission, PreparedEvaluationEqualsGeneric) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-0.78, 0.78);  // the parallelogram closes over +-45 deg
  for (const auto& [name, t] : models()) {
    const PreparedTransmission fast(t);
    for (int i = 0; i < 200; ++i) {
      const double q = u(rng);
      EXPECT_NEAR(fast.error(q), t.error(q), 1e-15) << name;
      EXPECT_NEAR(fast.derivative(q), t.derivative(q), 1e-13) << name;
    }
  }
}

// The four-bar's interior angle at A, built by geometry: B at the origin,
// A = (L1, 0), C at L2 from B with angle ABC = pi/2 - x, D where the circles
// about A (radius L4) and C (radius L3) meet, on the far side of AC from B.
double four_bar_angle_at_a(const Parallelogram& p, double x) {
  const Eigen::Vector2d A(p.L1, 0), C(p.L2 * std::sin(x), p.L2 * std::cos(x));
  const Eigen::Vector2d AC = C - A;
  const double d = AC.norm();
  const double along = (p.L4 * p.L4 - p.L3 * p.L3 + d * d) / (2 * d);
  const double h = std::sqrt(p.L4 * p.L4 - along * along);
  const Eigen::Vector2d u = AC / d, n(-u.y(), u.x());
  const Eigen::Vector2d mid = A + along * u;
  // B (the origin) lies on the side of AC where n . (B - A) has its sign.
  const Eigen::Vector2d D = mid - (n.dot(-A) > 0 ? h : -h) * n;
  const Eigen::Vector2d AB = -A, AD = D - A;
  return std::atan2(std::abs(AB.x() * AD.y() - AB.y() * AD.x()), AB.dot(AD));
}

// Joint 4 of the paper's device: capstan, then parallelogram. Written out
// independently of the implementation: the capstan's output x = q + eq. (1)
// (atan of the drum offsets), which turns the parallelogram's input crank; its
// output link turns by the change of the interior angle at A (geometry above),
// so the joint's error is angle_A(x) - angle_A(0) - q. Over +-45 degrees.
TEST(Transmission, ChainOfCapstanAndParallelogramMatchesItsGeometry) {
  const Transmission chain = joint4_chain();
  const auto& stages = std::get<Chain>(chain.model()).stages;
  const Capstan c = std::get<Capstan>(stages[0].model());
  const Parallelogram p = std::get<Parallelogram>(stages[1].model());
  const double R = c.ratio, D = c.drum_distance;
  auto ecc = [&](double r, double u) { return std::atan(r * std::sin(u) / (D - r * std::cos(u))); };
  double worst = 0;
  for (int i = -45; i <= 45; ++i) {
    const double q = i * kDeg;
    const double x = q - c.ratio_error / (c.ratio_error + R) * q + ecc(c.r_out, q + c.beta_out) -
                     ecc(c.r_out, c.beta_out) + ecc(c.r_in, R * q + c.beta_in) -
                     ecc(c.r_in, c.beta_in);
    const double expected = four_bar_angle_at_a(p, x) - four_bar_angle_at_a(p, 0) - q;
    worst = std::max(worst, std::abs(chain.error(q) - expected));
  }
  EXPECT_LT(worst, 1e-14);
  // The parallelogram's part is not negligible (the test sees it): about 1e-3 rad at 45 deg.
  EXPECT_GT(std::abs(Transmission(p).error(45 * kDeg)), 1e-4);
}

TEST(Transmission, MonomialViewOfChebyshevFitReproducesIt) {
  const Polynomial cheb = chebyshev10();
  Polynomial mono;
  mono.basis = PolynomialBasis::kMonomial;
  mono.coefficients = monomial_coefficients(cheb);
  ASSERT_EQ(mono.order(), 10);
  for (double q = -0.78; q <= 0.78; q += 0.01) {
    EXPECT_NEAR(Transmission(mono).error(q), Transmission(cheb).error(q), 1e-15) << q;
  }
  // Direct monomial sum of the paper's Table 2 coefficients (error(0) = 0 drops k0).
  const Polynomial paper = paper_table2_monomial();
  const double q = 0.5;
  double sum = 0;
  for (int k = 1; k <= 10; ++k) sum += paper.coefficients[k] * std::pow(q, k);
  EXPECT_NEAR(Transmission(paper).error(q), sum, 1e-15);
}

TEST(Transmission, CheckRejectsUnusableModels) {
  Capstan c = table2_capstan1();
  c.r_out = 0.006;  // larger than D = 5 mm
  EXPECT_NE(Transmission(c).check(-1, 1), "");
  EXPECT_NE(Transmission(Parallelogram{0.05, 0.21, 0.05, 0.5}).check(-0.7, 0.7), "");
  EXPECT_EQ(Transmission(table2_parallelogram()).check(-0.7, 0.7), "");
  EXPECT_EQ(joint4_chain().check(-0.7, 0.7), "");
  EXPECT_NE(Transmission(Chain{}).check(-1, 1), "");
}

// A transmission's drive ratio is its capstan's, alone or first in a chain,
// and 1 without a capstan.
TEST(Transmission, DriveRatioIsTheCapstans) {
  const Capstan c = table2_capstan1();
  ASSERT_GT(c.ratio, 2);
  EXPECT_EQ(Transmission(c).drive_ratio(), c.ratio);
  EXPECT_EQ(joint4_chain().drive_ratio(), c.ratio);  // capstan, then parallelogram
  const Transmission parallelogram_first(
      Chain{{Transmission(table2_parallelogram()), Transmission(c)}});
  EXPECT_EQ(parallelogram_first.drive_ratio(), c.ratio);
  EXPECT_EQ(Transmission(table2_parallelogram()).drive_ratio(), 1.0);
  EXPECT_EQ(Transmission().drive_ratio(), 1.0);
}

}  // namespace
}  // namespace hapticcal
