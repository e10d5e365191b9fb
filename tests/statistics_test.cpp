// Distribution functions against published tables.
#include <gtest/gtest.h>

#include <cmath>

#include "hapticcal/identification/identification.hpp"

namespace hapticcal {
namespace {

// Chi-square quantiles from the NIST/SEMATECH e-Handbook table 1.3.6.7.4
// (lower and upper 5 % critical values).
TEST(ChiSquareQuantile, MatchesThePublishedTable) {
  struct Row {
    double dof, p05, p95;
  };
  for (const Row& r :
       {Row{1, 0.004, 3.841}, Row{2, 0.103, 5.991}, Row{10, 3.940, 18.307}, Row{20, 10.851, 31.410},
        Row{100, 77.929, 124.342}, Row{200, 168.279, 233.994}}) {
    SCOPED_TRACE(r.dof);
    EXPECT_NEAR(chi_square_quantile(0.05, r.dof), r.p05, 0.0005 + 1e-4 * r.p05);
    EXPECT_NEAR(chi_square_quantile(0.95, r.dof), r.p95, 0.0005 + 1e-4 * r.p95);
  }
  EXPECT_NEAR(chi_square_quantile(0.5, 2), 2 * std::log(2.0), 1e-9);  // exponential's median
  EXPECT_EQ(chi_square_quantile(0, 5), 0);
  EXPECT_TRUE(std::isinf(chi_square_quantile(1, 5)));
  EXPECT_TRUE(std::isnan(chi_square_quantile(0.5, 0)));
}

}  // namespace
}  // namespace hapticcal
