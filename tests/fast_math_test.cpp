// The batched elementary functions of the prepared path against libm.
#include "kinematics/fast_math.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <random>

namespace hapticcal {
namespace {

// Error in units of the last place of the reference value (at least of 2^-53).
double ulps(double value, double reference) {
  const double ulp = std::max(std::abs(std::nextafter(reference, INFINITY) - reference),
                              std::numeric_limits<double>::epsilon() / 2);
  return std::abs(value - reference) / ulp;
}

TEST(FastMath, SincosBatchIsWithinTwoUlpOfLibmOverMinus100To100Rad) {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(-100, 100);
  std::vector<double> x(1 << 20);
  for (double& v : x) v = u(rng);
  // Quadrant boundaries, multiples of pi/2, tiny and signed zeros.
  for (int k = -60; k <= 60; ++k) {
    const double b = k * std::numbers::pi / 4;
    x.insert(x.end(), {b, std::nextafter(b, -INFINITY), std::nextafter(b, INFINITY)});
  }
  x.insert(x.end(), {0.0, -0.0, 1e-300, -1e-300, 1e-8});
  std::vector<double> s(x.size()), c(x.size());
  sincos_batch(x.data(), s.data(), c.data(), static_cast<int>(x.size()));
  double worst_s = 0, worst_c = 0, worst_abs = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    worst_s = std::max(worst_s, ulps(s[i], std::sin(x[i])));
    worst_c = std::max(worst_c, ulps(c[i], std::cos(x[i])));
    worst_abs =
        std::max({worst_abs, std::abs(s[i] - std::sin(x[i])), std::abs(c[i] - std::cos(x[i]))});
  }
  std::printf("sincos_batch worst error: sin %.2f ulp, cos %.2f ulp, %.2e absolute\n", worst_s,
              worst_c, worst_abs);
  EXPECT_LE(worst_s, 2.0);
  EXPECT_LE(worst_c, 2.0);
  EXPECT_LE(worst_abs, 2.3e-16);
}

TEST(FastMath, AtanBatchIsWithinOneUlpOfLibm) {
  std::vector<double> t;
  for (int i = -3000; i <= 3000; ++i) t.push_back(i * 1e-4);  // series and libm branches
  t.push_back(5.0);
  std::vector<double> out(t.size());
  atan_batch(t.data(), out.data(), static_cast<int>(t.size()));
  for (size_t i = 0; i < t.size(); ++i) EXPECT_LE(ulps(out[i], std::atan(t[i])), 1.0) << t[i];
}

TEST(FastMath, SmallAngleSincosIsWithinOneUlpOfLibm) {
  for (int i = -2000; i <= 2000; ++i) {
    const double x = i * 1e-4;  // up to 0.2: both branches
    double s, c;
    small_angle_sincos(x, s, c);
    EXPECT_LE(ulps(s, std::sin(x)), 1.0) << x;
    EXPECT_LE(ulps(c, std::cos(x)), 1.0) << x;
  }
}

}  // namespace
}  // namespace hapticcal
