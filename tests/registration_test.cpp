// Closed-form point-set registration: exact recovery, optimality against Eigen's
// Umeyama, a Gauss-Newton step and perturbed transforms, reflections, weights
// and the inputs that do not determine a transform.
#include "hapticcal/identification/registration.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "hapticcal/core/error.hpp"

namespace hapticcal {
namespace {

Eigen::Matrix3d random_rotation(std::mt19937_64& rng) {
  std::normal_distribution<double> n;
  // Four normal numbers normalised: a uniformly distributed unit quaternion.
  return Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized().toRotationMatrix();
}

Eigen::Matrix3Xd random_points(std::mt19937_64& rng, int count, double half_width = 1) {
  std::uniform_real_distribution<double> u(-half_width, half_width);
  Eigen::Matrix3Xd p(3, count);
  for (int i = 0; i < count; ++i) p.col(i) = Eigen::Vector3d(u(rng), u(rng), u(rng));
  return p;
}

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

// sum w_i |R a_i + t - b_i|^2
double cost(const Eigen::Matrix3d& R, const Eigen::Vector3d& t, const Eigen::Matrix3Xd& a,
            const Eigen::Matrix3Xd& b, const Eigen::VectorXd& w) {
  return ((R * a).colwise() + t - b).colwise().squaredNorm().dot(w);
}

// One Gauss-Newton step on sum w_i |exp([omega]) R a_i + t + delta - b_i|^2 from (R, t):
// (omega, delta). Zero at a stationary point of the cost.
Eigen::Matrix<double, 6, 1> gauss_newton_step(const Registration& x, const Eigen::Matrix3Xd& a,
                                              const Eigen::Matrix3Xd& b, const Eigen::VectorXd& w) {
  Eigen::Matrix<double, 6, 6> JtJ = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> Jtr = Eigen::Matrix<double, 6, 1>::Zero();
  for (Eigen::Index i = 0; i < a.cols(); ++i) {
    const Eigen::Vector3d Ra = x.R * a.col(i);
    const Eigen::Vector3d r = Ra + x.t - b.col(i);
    Eigen::Matrix<double, 3, 6> J_r_x;
    J_r_x << -skew(Ra), Eigen::Matrix3d::Identity();
    JtJ += w[i] * J_r_x.transpose() * J_r_x;
    Jtr += w[i] * J_r_x.transpose() * r;
  }
  return -JtJ.ldlt().solve(Jtr);
}

void expect_rotation(const Eigen::Matrix3d& R) {
  EXPECT_LT((R.transpose() * R - Eigen::Matrix3d::Identity()).norm(), 1e-14);
  EXPECT_NEAR(R.determinant(), 1.0, 1e-14);
}

TEST(Registration, RecoversRandomRigidTransformsFromExactPointsTo1e12) {
  std::mt19937_64 rng(101);
  for (int trial = 0; trial < 200; ++trial) {
    SCOPED_TRACE(trial);
    const int n = 3 + trial % 40;
    const Eigen::Matrix3d R = random_rotation(rng);
    const Eigen::Vector3d t = 2 * Eigen::Vector3d::Random();
    const Eigen::Matrix3Xd a = random_points(rng, n);
    const Eigen::Matrix3Xd b = (R * a).colwise() + t;
    const Registration x = register_points(a, b);
    expect_rotation(x.R);
    EXPECT_LT((x.R - R).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LT((x.t - t).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LT(x.rms, 1e-12);
  }
}

TEST(Registration, RecoversATransformFromCoplanarPoints) {
  std::mt19937_64 rng(102);
  Eigen::Matrix3Xd a = random_points(rng, 6);
  a.row(2).setConstant(0.3);  // all in the plane z = 0.3: rank 2 once centred
  const Eigen::Matrix3d R = random_rotation(rng);
  const Eigen::Vector3d t(0.1, -0.2, 0.5);
  const Registration x = register_points(a, (R * a).colwise() + t);
  EXPECT_LT((x.R - R).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((x.t - t).cwiseAbs().maxCoeff(), 1e-12);
}

// With noise there is no exact answer: the result must be the least-squares one. Checked three
// independent ways: Eigen::umeyama (scaling off) gives the same transform, a Gauss-Newton step
// from it does not move it, and no nearby transform costs less.
TEST(Registration, NoisyPointsGiveTheLeastSquaresTransform) {
  std::mt19937_64 rng(103);
  std::normal_distribution<double> noise(0, 1e-3);
  std::normal_distribution<double> small(0, 1e-3);
  for (int trial = 0; trial < 50; ++trial) {
    SCOPED_TRACE(trial);
    const int n = 4 + trial % 30;
    const Eigen::Matrix3Xd a = random_points(rng, n, 0.5);
    Eigen::Matrix3Xd b = (random_rotation(rng) * a).colwise() + Eigen::Vector3d(1, 2, -1);
    for (Eigen::Index i = 0; i < b.size(); ++i) b.data()[i] += noise(rng);
    const Eigen::VectorXd w = Eigen::VectorXd::Ones(n);
    const Registration x = register_points(a, b);
    expect_rotation(x.R);

    const Eigen::Matrix4d T = Eigen::umeyama(a, b, false);
    EXPECT_LT((x.R - T.topLeftCorner<3, 3>()).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LT((x.t - T.topRightCorner<3, 1>()).cwiseAbs().maxCoeff(), 1e-12);

    EXPECT_LT(gauss_newton_step(x, a, b, w).norm(), 1e-12);

    const double best = cost(x.R, x.t, a, b, w);
    EXPECT_NEAR(x.rms, std::sqrt(best / n), 1e-15);
    for (int k = 0; k < 20; ++k) {
      const Eigen::Vector3d omega(small(rng), small(rng), small(rng));
      const Eigen::Vector3d delta(small(rng), small(rng), small(rng));
      const Eigen::Matrix3d R =
          Eigen::AngleAxisd(omega.norm(), omega.normalized()).toRotationMatrix() * x.R;
      EXPECT_GT(cost(R, x.t + delta, a, b, w), best);
    }
  }
}

// b the mirror image of a: the best proper rotation, not the reflection (det R = +1), and it is
// a minimum - lower than random rotations with their best translation, and than nearby ones.
TEST(Registration, MirroredPointsStillGiveAProperRotation) {
  std::mt19937_64 rng(104);
  std::normal_distribution<double> small(0, 1e-2);
  for (int trial = 0; trial < 20; ++trial) {
    SCOPED_TRACE(trial);
    const int n = 5 + trial;
    const Eigen::Matrix3Xd a = random_points(rng, n);
    const Eigen::Matrix3d mirror = Eigen::Vector3d(1, 1, -1).asDiagonal();
    const Eigen::Matrix3Xd b =
        ((random_rotation(rng) * mirror) * a).colwise() + Eigen::Vector3d(0.3, 0.2, 0.1);
    const Eigen::VectorXd w = Eigen::VectorXd::Ones(n);
    const Registration x = register_points(a, b);
    expect_rotation(x.R);
    EXPECT_GT(x.rms, 1e-3);  // a reflection cannot be matched by a rotation

    const Eigen::Matrix4d T = Eigen::umeyama(a, b, false);
    EXPECT_LT((x.R - T.topLeftCorner<3, 3>()).cwiseAbs().maxCoeff(), 1e-10);
    EXPECT_LT(gauss_newton_step(x, a, b, w).norm(), 1e-10);

    const double best = cost(x.R, x.t, a, b, w);
    const Eigen::Vector3d a_mean = a.rowwise().mean(), b_mean = b.rowwise().mean();
    for (int k = 0; k < 50; ++k) {
      const Eigen::Matrix3d R = random_rotation(rng);
      EXPECT_GT(cost(R, b_mean - R * a_mean, a, b, w), best);
      const Eigen::Vector3d omega(small(rng), small(rng), small(rng));
      const Eigen::Matrix3d R_near =
          Eigen::AngleAxisd(omega.norm(), omega.normalized()).toRotationMatrix() * x.R;
      EXPECT_GT(cost(R_near, b_mean - R_near * a_mean, a, b, w), best);
    }
  }
}

TEST(Registration, APointWithWeightZeroHasNoInfluence) {
  std::mt19937_64 rng(105);
  std::normal_distribution<double> noise(0, 1e-3);
  const int n = 10;
  const Eigen::Matrix3Xd a = random_points(rng, n);
  Eigen::Matrix3Xd b = (random_rotation(rng) * a).colwise() + Eigen::Vector3d(0, 1, 0);
  for (Eigen::Index i = 0; i < b.size(); ++i) b.data()[i] += noise(rng);
  const Registration without = register_points(a, b);

  Eigen::Matrix3Xd a_more(3, n + 1), b_more(3, n + 1);
  a_more << a.leftCols(4), Eigen::Vector3d(5, 5, 5), a.rightCols(n - 4);
  b_more << b.leftCols(4), Eigen::Vector3d(-9, 40, 3), b.rightCols(n - 4);  // a gross outlier
  Eigen::VectorXd w = Eigen::VectorXd::Ones(n + 1);
  w[4] = 0;
  const Registration with = register_points(a_more, b_more, w);
  EXPECT_LT((with.R - without.R).cwiseAbs().maxCoeff(), 1e-14);
  EXPECT_LT((with.t - without.t).cwiseAbs().maxCoeff(), 1e-14);
  EXPECT_NEAR(with.rms, without.rms, 1e-15);
  // With its weight the outlier pulls the transform away.
  const Registration pulled = register_points(a_more, b_more);
  EXPECT_GT((pulled.t - without.t).norm(), 1e-2);
}

// Integer weights are the same as repeating each point that many times, which Eigen::umeyama
// (unweighted) solves independently.
TEST(Registration, IntegerWeightsEqualRepeatedPoints) {
  std::mt19937_64 rng(106);
  std::normal_distribution<double> noise(0, 1e-2);
  std::uniform_int_distribution<int> count(1, 4);
  const int n = 8;
  const Eigen::Matrix3Xd a = random_points(rng, n);
  Eigen::Matrix3Xd b = (random_rotation(rng) * a).colwise() + Eigen::Vector3d(0.5, 0, 0);
  for (Eigen::Index i = 0; i < b.size(); ++i) b.data()[i] += noise(rng);
  Eigen::VectorXd w(n);
  for (int i = 0; i < n; ++i) w[i] = count(rng);
  Eigen::Matrix3Xd a_rep(3, static_cast<Eigen::Index>(w.sum())), b_rep(3, a_rep.cols());
  for (int i = 0, k = 0; i < n; ++i) {
    for (int copy = 0; copy < w[i]; ++copy, ++k) {
      a_rep.col(k) = a.col(i);
      b_rep.col(k) = b.col(i);
    }
  }
  const Registration weighted = register_points(a, b, w);
  const Eigen::Matrix4d T = Eigen::umeyama(a_rep, b_rep, false);
  EXPECT_LT((weighted.R - T.topLeftCorner<3, 3>()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((weighted.t - T.topRightCorner<3, 1>()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_NEAR(weighted.rms, register_points(a_rep, b_rep).rms, 1e-14);
  // And the weights matter: the unweighted result differs.
  EXPECT_GT((register_points(a, b).R - weighted.R).norm(), 1e-6);
}

// The message of the InputError that register_points(a, b, w) throws ("" if none).
std::string error_of(const Eigen::Matrix3Xd& a, const Eigen::Matrix3Xd& b,
                     const Eigen::VectorXd& w = {}) {
  try {
    register_points(a, b, w);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(Registration, InputsThatDoNotDetermineATransformThrow) {
  std::mt19937_64 rng(107);
  const Eigen::Matrix3Xd a = random_points(rng, 5);
  const Eigen::Matrix3Xd b = (random_rotation(rng) * a).colwise() + Eigen::Vector3d(1, 0, 0);
  ASSERT_EQ(error_of(a, b), "");

  EXPECT_NE(error_of(a.leftCols(2), b.leftCols(2))
                .find("2 points; a rigid transform needs at "
                      "least 3"),
            std::string::npos);
  EXPECT_NE(error_of(a, b.leftCols(4)).find("a has 5 points but b has 4"), std::string::npos);
  EXPECT_NE(error_of(a, b, Eigen::VectorXd::Ones(4)).find("4 weights for 5 points"),
            std::string::npos);

  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  Eigen::Matrix3Xd bad = a;
  bad(1, 3) = nan;
  EXPECT_NE(error_of(bad, b).find("a(1, 3) = nan is not finite"), std::string::npos);
  bad = b;
  bad(2, 0) = -inf;
  EXPECT_NE(error_of(a, bad).find("b(2, 0) = -inf is not finite"), std::string::npos);
  Eigen::VectorXd w = Eigen::VectorXd::Ones(5);
  w[2] = nan;
  EXPECT_NE(error_of(a, b, w).find("weights(2, 0) = nan is not finite"), std::string::npos);
  w[2] = -1;
  EXPECT_NE(error_of(a, b, w).find("weights(2) = -1 is negative"), std::string::npos);
  w << 1, 0, 0, 1, 0;
  EXPECT_NE(error_of(a, b, w).find("2 points have a positive weight"), std::string::npos);

  // Collinear: exactly, and within 1e-12 of a line (below the 1e-9 threshold).
  Eigen::Matrix3Xd line(3, 4);
  line << 0, 1, 2, 3, 0, 2, 4, 6, 1, 1, 1, 1;
  const Eigen::Matrix3d R = random_rotation(rng);
  EXPECT_NE(error_of(line, R * line)
                .find("points of a are (near-)collinear: the rotation is "
                      "not determined"),
            std::string::npos);
  Eigen::Matrix3Xd near_line = line;
  near_line(2, 1) += 1e-12;
  EXPECT_NE(error_of(near_line, R * near_line).find("points of a are (near-)collinear"),
            std::string::npos);
  // ... but 1e-6 off the line is still a transform.
  near_line(2, 1) += 1e-6;
  EXPECT_EQ(error_of(near_line, R * near_line), "");
  // Collinear in b only: the rotation is not determined either.
  EXPECT_NE(error_of(a.leftCols(4), line).find("points of b are (near-)collinear"),
            std::string::npos);
  // All at one place.
  const Eigen::Matrix3Xd same = Eigen::Vector3d(1, 2, 3).replicate(1, 4);
  EXPECT_NE(error_of(same, same).find("points of a are all at one place"), std::string::npos);
  // A point set collinear once the zero-weight point is left out.
  Eigen::Matrix3Xd line_plus(3, 5);
  line_plus << line, Eigen::Vector3d(5, -3, 2);
  const Eigen::VectorXd drop_last = (Eigen::VectorXd(5) << 1, 1, 1, 1, 0).finished();
  EXPECT_NE(error_of(line_plus, R * line_plus, drop_last).find("(near-)collinear"),
            std::string::npos);
  EXPECT_EQ(error_of(line_plus, R * line_plus), "");
}

}  // namespace
}  // namespace hapticcal
