// Batched elementary functions for the prepared (controller) path. The loops
// have no branches on the data, so the compiler vectorises them; results agree
// with libm to about one ulp (tests/fast_math_test.cpp).
#pragma once

#include <cmath>

namespace hapticcal {

// s[i] = sin(x[i]), c[i] = cos(x[i]) for |x[i]| < 1e5 (Cody-Waite reduction by
// pi/2 in three parts, Taylor polynomials on [-pi/4, pi/4]).
void sincos_batch(const double* x, double* s, double* c, int n);

// out[i] = atan(t[i]): a series for |t| <= 0.1 (eccentric-drum terms), libm beyond.
void atan_batch(const double* t, double* out, int n);

// sin and cos of a small angle: a Taylor series for |x| <= 0.1 (the first
// omitted terms are below 3e-19 relative), libm beyond.
inline void small_angle_sincos(double x, double& s, double& c) {
  if (!(std::abs(x) <= 0.1)) {
    s = std::sin(x);
    c = std::cos(x);
    return;
  }
  const double x2 = x * x;
  s = x * (1 + x2 * (-1.0 / 6 + x2 * (1.0 / 120 + x2 * (-1.0 / 5040 + x2 * (1.0 / 362880)))));
  c = 1 + x2 * (-0.5 +
                x2 * (1.0 / 24 + x2 * (-1.0 / 720 + x2 * (1.0 / 40320 + x2 * (-1.0 / 3628800)))));
}

}  // namespace hapticcal
