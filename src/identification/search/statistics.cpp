// Distribution functions: the chi-square quantile.
#include <algorithm>
#include <cmath>
#include <limits>

#include "hapticcal/identification/identification.hpp"

namespace hapticcal {
namespace {

// The regularised lower incomplete gamma function P(a, x): its series for
// x < a + 1 (DLMF 8.11.4), else 1 - Q(a, x) by Q's continued fraction (DLMF
// 8.9.2, modified Lentz), as in Numerical Recipes' gammp.
double lower_gamma_regularised(double a, double x) {
  if (x <= 0) return 0;
  const double front = std::exp(-x + a * std::log(x) - std::lgamma(a));
  if (x < a + 1) {
    double term = 1 / a, sum = term;
    for (int n = 1; n < 1000; ++n) {
      term *= x / (a + n);
      sum += term;
      if (std::abs(term) < std::abs(sum) * 1e-16) break;
    }
    return sum * front;
  }
  constexpr double tiny = 1e-300;
  double b = x + 1 - a, c = 1 / tiny, d = 1 / b, h = d;
  for (int i = 1; i < 1000; ++i) {
    const double an = -i * (i - a);
    b += 2;
    d = an * d + b;
    if (std::abs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1) < 1e-16) break;
  }
  return 1 - front * h;
}

}  // namespace

double chi_square_quantile(double p, double dof) {
  if (!(dof > 0) || !(p >= 0) || !(p <= 1)) return std::numeric_limits<double>::quiet_NaN();
  if (p == 0) return 0;
  if (p == 1) return std::numeric_limits<double>::infinity();
  // Bisection on x: the distribution function rises monotonically.
  double lo = 0, hi = std::max(1.0, dof);
  while (lower_gamma_regularised(dof / 2, hi / 2) < p) hi *= 2;
  for (int i = 0; i < 200 && hi - lo > 1e-14 * hi; ++i) {
    const double x = 0.5 * (lo + hi);
    (lower_gamma_regularised(dof / 2, x / 2) < p ? lo : hi) = x;
  }
  return 0.5 * (lo + hi);
}

}  // namespace hapticcal
