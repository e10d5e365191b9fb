#include "kinematics/fast_math.hpp"

#include <bit>
#include <cmath>
#include <cstdint>

namespace hapticcal {
namespace {

// pi/2 = kP1 + kP2 + kP3: kP1 and kP2 hold 33 significant bits each, so k * kP1
// and k * kP2 are exact for |k| < 2^20 (computed from 200 digits of pi).
constexpr double kP1 = 1.5707963267341256;
constexpr double kP2 = 6.077100506303966e-11;
constexpr double kP3 = 2.0222662487959506e-21;
constexpr double kTwoOverPi = 0.6366197723675814;
constexpr double kShifter = 6755399441055744.0;  // 1.5 * 2^52: adding it rounds to an integer

// 1/n! with alternating signs, for the Taylor series of sin (odd) and cos (even);
// on |r| <= pi/4 the first omitted terms are below 1e-19 relative.
constexpr double kSin[8] = {
    -1.0 / 6,        1.0 / 120,        -1.0 / 5040,          1.0 / 362880,
    -1.0 / 39916800, 1.0 / 6227020800, -1.0 / 1307674368000, 1.0 / 355687428096000};
constexpr double kCos[9] = {-1.0 / 2,
                            1.0 / 24,
                            -1.0 / 720,
                            1.0 / 40320,
                            -1.0 / 3628800,
                            1.0 / 479001600,
                            -1.0 / 87178291200,
                            1.0 / 20922789888000,
                            -1.0 / 6402373705728000};

// x86-64: an AVX2+FMA clone chosen at load time where the CPU has it; these
// kernels are plain loops (no Eigen), so mixing instruction sets is safe.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && \
    !defined(__SANITIZE_ADDRESS__)
#define HAPTICCAL_CLONES [[gnu::target_clones("arch=x86-64-v3", "default")]]
#else
#define HAPTICCAL_CLONES
#endif

}  // namespace

HAPTICCAL_CLONES void sincos_batch(const double* x, double* s, double* c, int n) {
  for (int i = 0; i < n; ++i) {
    const double shifted = x[i] * kTwoOverPi + kShifter;
    const double k = shifted - kShifter;                                   // x = k pi/2 + r
    const std::uint64_t quadrant = std::bit_cast<std::uint64_t>(shifted);  // low bits: k mod 4
    double r = x[i] - k * kP1;
    r -= k * kP2;
    r -= k * kP3;
    // Estrin's scheme: short dependency chains.
    const double r2 = r * r, r4 = r2 * r2, r8 = r4 * r4;
    const double ps = (kSin[0] + r2 * kSin[1]) + r4 * (kSin[2] + r2 * kSin[3]) +
                      r8 * ((kSin[4] + r2 * kSin[5]) + r4 * (kSin[6] + r2 * kSin[7]));
    const double pc = (kCos[0] + r2 * kCos[1]) + r4 * (kCos[2] + r2 * kCos[3]) +
                      r8 * ((kCos[4] + r2 * kCos[5]) + r4 * (kCos[6] + r2 * kCos[7])) +
                      r8 * r8 * kCos[8];
    const double sin_r = r + r * r2 * ps;
    const double cos_r = 1.0 + r2 * pc;
    // Quadrant k: sin x = (sin r, cos r, -sin r, -cos r), cos x = (cos r, -sin r, -cos r, sin r).
    const std::uint64_t swap = 0 - (quadrant & 1);  // all ones for odd k
    const std::uint64_t bs = std::bit_cast<std::uint64_t>(sin_r);
    const std::uint64_t bc = std::bit_cast<std::uint64_t>(cos_r);
    const std::uint64_t sin_bits = (bc & swap) | (bs & ~swap);
    const std::uint64_t cos_bits = (bs & swap) | (bc & ~swap);
    s[i] = std::bit_cast<double>(sin_bits ^ ((quadrant & 2) << 62));
    c[i] = std::bit_cast<double>(cos_bits ^ (((quadrant + 1) & 2) << 62));
  }
}

HAPTICCAL_CLONES void atan_batch(const double* t, double* out, int n) {
  static constexpr double kInverseOdd[9] = {1.0,      1.0 / 3,  1.0 / 5,  1.0 / 7, 1.0 / 9,
                                            1.0 / 11, 1.0 / 13, 1.0 / 15, 1.0 / 17};
  bool all_small = true;
  for (int i = 0; i < n; ++i) {
    // atan t = sum (-1)^k t^(2k+1) / (2k+1); nine terms leave < 6e-20 relative at 0.1.
    const double u = -t[i] * t[i], u2 = u * u, u4 = u2 * u2;  // Estrin in u = -t^2
    const double acc =
        (kInverseOdd[0] + u * kInverseOdd[1]) + u2 * (kInverseOdd[2] + u * kInverseOdd[3]) +
        u4 * ((kInverseOdd[4] + u * kInverseOdd[5]) + u2 * (kInverseOdd[6] + u * kInverseOdd[7])) +
        u4 * u4 * kInverseOdd[8];
    out[i] = t[i] * acc;
    all_small &= std::abs(t[i]) <= 0.1;
  }
  if (all_small) return;
  for (int i = 0; i < n; ++i) {
    if (!(std::abs(t[i]) <= 0.1)) out[i] = std::atan(t[i]);
  }
}

}  // namespace hapticcal
