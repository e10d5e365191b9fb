// The capstan model (paper eq. (1), section "Error sources in the kinematic model
// of a 7-DOF haptic device"; capstan_error in model/transmission.hpp) against an
// independent construction of the mechanism: two eccentric drums and a cable on their common
// tangent, the output angle found from the conservation of the cable's length. transmission_test
// checks that the code says what eq. (1) says; this checks what eq. (1) says against the geometry
// it models.
//
// The construction (plane, SI units). Output drum: axis at the origin, pitch
// radius rho_o, turning counter-clockwise by theta (the joint angle, what the
// external encoder reads). Input drum: axis at (L, 0), pitch radius rho_i,
// turning clockwise by phi (the motor; its reading referred to the joint is
// q = phi / R). The drums turn in opposite senses: the cable runs in a figure
// eight (the paper, beside its Figure 2), on an internal common tangent of the
// two pitch circles. A drum's geometric centre sits at its eccentricity r from
// its axis, at the phase (rotation + b) measured in the drum's own sense of
// rotation from the direction towards the other drum's axis:
//   output centre C_o = r_o (cos(theta + b_o), sin(theta + b_o)),
//   input centre  C_i = (L - r_i cos(phi + b_i), r_i sin(phi + b_i)).
// The cable is fixed to the output drum and does not slip on the input drum,
// so one strand's length from a material point of one drum to one of the other
// - arc on the output circle + tangent segment + arc on the input circle - is
// constant. With d, gamma the length and angle of C_i - C_o, the tangent's normal
// (from C_o towards the line) at the angle tau = gamma + s alpha,
// alpha = acos((rho_o + rho_i) / d) (strand s = +1 or -1, the two crossing
// strands), and its free length l = sqrt(d^2 - (rho_o + rho_i)^2), the strand is
// s [rho_o (theta - tau) - rho_i (phi + tau)] + l long up to a constant (its arcs:
// a material point's direction from its drum's centre turns with the drum), so
// its length is constant iff
//   rho_o theta - rho_i phi = (rho_o + rho_i) (tau - tau_0) - s (l - l_0),    (G)
// solved for theta by a fixed-point iteration (its contraction factor is
// about r_o / rho_o). A second, velocity-based route checks (G): the cable's
// speed along its line is each drum's angular rate times the distance from its
// axis to the line, so dtheta/dphi = h_i / h_o, integrated by RK4.
//
// What eq. (1) is, against (G) (derived by expanding (G) to first order in the
// eccentricities; checked numerically below):
// - Ratio: R + Re = rho_o / rho_i ("Re: deviation in the transmission ratio").
//   With no eccentricity (G) gives theta = phi rho_i / rho_o = R q / (R + Re),
//   theta - q = -Re / (R + Re) q: eq. (1)'s ratio term exactly.
// - Eccentricities: to first order (G) gives
//   theta - phi rho_i / rho_o = (r_i / rho_o) [sin(phi + b_i + s a0) - sin(b_i + s a0)]
//                             - (r_o / rho_o) [sin(theta + b_o - s a0) - sin(b_o - s a0)]
//   with a0 = acos((rho_o + rho_i) / L) the angle between the line of the axes and
//   the cable's normal at home, while eq. (1)'s terms atan2(r sin u, D - r cos u)
//   - home are (r / D) [sin u - sin beta] + O((r/D)^2).
//   They agree to first order when D = rho_o (the output drum's pitch radius),
//   beta_in = b_i + s a0 and beta_out = b_o - s a0 + pi: eq. (1)'s phases are
//   measured from the normal of the cable at home (towards the cable for the
//   input drum, away from it for the output drum; the paper defines no reference,
//   and any reference is a constant shift of beta).
// - So eq. (1) is a first-order model: with eps = (r_o + r_i) / rho_o the
//   discrepancy is second order, plus the product of the output eccentricity and
//   the ratio error (eq. (1) evaluates the output drum's term at q, the geometry
//   at theta = q (1 - Re / (R + Re)) + O(eps)):
//     |theta - q - capstan_error(q)| <= K (eps^2 + (r_o / rho_o) |Re / (R + Re)| |q|).
//   Measured (Python and this test): the ratio of the left side to the bracket is at
//   most 3.64 over R = 5, 10, 20, gaps 0.1 - 0.5 mm, both strands, every phase in
//   45/60 degree steps; at most 1.99 for the cases below. K = 5 is asserted.
//   Halving the eccentricities (Re = 0) divides the discrepancy by 3.99 - 4.03.
//   The sweep is q in [-90, 90] degrees, the built-in device's capstan joints' range.
//   A first-order mistake (a phase's sign, a phase reference off by pi, the ratio
//   error's sign, D read as the centre distance L) gives ratios of 17.7 to 766 on
//   the cases where the term is visible (WrongSignsOrScalesBreakTheFirstOrderAgreement).
//
// Finding, not a failure: eq. (1)'s D acts as the output drum's pitch radius.
// The paper calls it the distance between the drums (and Capstan::drum_distance
// says "between drum centres"); read so (D = L = rho_o + rho_i + gap) the
// eccentricity terms are too small by rho_o / L (0.83 here, at best R / (R + 1)),
// a first-order error. Identification absorbs it (r_out and r_in are fitted, D is
// a constant: the identified radii come out scaled by D / rho_o), so only the
// physical reading of the identified radii is affected.
// At Table 2's eccentricities (r_o / D = 0.02 - 0.05) the second-order part is up
// to 3.7e-3 rad at +-90 degrees, 35 times the paper's encoder sd (1.05e-4 rad); a
// least-squares fit of eq. (1) to the construction leaves 1.3e-5 (capstan 4) to
// 2.7e-4 rad RMS and moves Re by up to 0.03 (measured in Python, not asserted here).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

#include "hapticcal/model/transmission.hpp"

namespace hapticcal {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180;
constexpr double kK = 5;  // the second-order bound's constant (measured <= 3.64)

// The mechanism of the construction above.
struct Drums {
  double rho_o = 0, rho_i = 0, L = 0;  // pitch radii, distance between the axes [m]
  double r_o = 0, b_o = 0;             // output drum eccentricity [m], geometric phase [rad]
  double r_i = 0, b_i = 0;             // input drum's
};

struct Tangent {
  double gamma = 0, alpha = 0, length = 0;  // angle of C_i - C_o, acos((rho_o+rho_i)/d), l
};

Tangent tangent(const Drums& m, double theta, double phi) {
  const double cox = m.r_o * std::cos(theta + m.b_o), coy = m.r_o * std::sin(theta + m.b_o);
  const double cix = m.L - m.r_i * std::cos(phi + m.b_i), ciy = m.r_i * std::sin(phi + m.b_i);
  const double vx = cix - cox, vy = ciy - coy, d = std::hypot(vx, vy), rs = m.rho_o + m.rho_i;
  return {std::atan2(vy, vx), std::acos(rs / d), std::sqrt(d * d - rs * rs)};
}

// theta for the input drum's rotation phi: (G) by fixed-point iteration.
double output_angle(const Drums& m, double phi, int strand) {
  const double rs = m.rho_o + m.rho_i;
  const Tangent t0 = tangent(m, 0, 0);
  const double tau0 = t0.gamma + strand * t0.alpha;
  double theta = m.rho_i * phi / m.rho_o;
  for (int it = 0; it < 200; ++it) {
    const Tangent t = tangent(m, theta, phi);
    const double rhs = rs * (t.gamma + strand * t.alpha - tau0) - strand * (t.length - t0.length);
    const double next = (m.rho_i * phi + rhs) / m.rho_o;
    const bool done = std::abs(next - theta) <= 1e-16 * (1 + std::abs(theta));
    theta = next;
    if (done) break;
  }
  return theta;
}

// The velocity route: dtheta/dphi = h_i / h_o, h the distance from a drum's axis
// to the strand's line, integrated from home by RK4 in `steps` steps.
double output_angle_integrated(const Drums& m, double phi_end, int strand, int steps) {
  auto rate = [&](double phi, double theta) {
    const Tangent t = tangent(m, theta, phi);
    const double tau = t.gamma + strand * t.alpha, nx = std::cos(tau), ny = std::sin(tau);
    // n points from C_o to the output drum's tangent point and from the input
    // drum's tangent point to C_i.
    const double h_o =
        m.rho_o + nx * m.r_o * std::cos(theta + m.b_o) + ny * m.r_o * std::sin(theta + m.b_o);
    const double h_i =
        m.rho_i - (nx * -m.r_i * std::cos(phi + m.b_i) + ny * m.r_i * std::sin(phi + m.b_i));
    return h_i / h_o;
  };
  const double h = phi_end / steps;
  double theta = 0, phi = 0;
  for (int k = 0; k < steps; ++k) {
    const double k1 = rate(phi, theta), k2 = rate(phi + h / 2, theta + h / 2 * k1);
    const double k3 = rate(phi + h / 2, theta + h / 2 * k2), k4 = rate(phi + h, theta + h * k3);
    theta += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
    phi += h;
  }
  return theta;
}

// The drums of a capstan whose eq. (1) parameters are c's: D = rho_o, the ratio
// R + Re = rho_o / rho_i, a clearance `gap` between the pitch circles, and the
// phases mapped as derived above for strand s.
Drums drums_of(const Capstan& c, int strand, double gap) {
  Drums m;
  m.rho_o = c.drum_distance;
  m.rho_i = m.rho_o / (c.ratio + c.ratio_error);
  m.L = m.rho_o + m.rho_i + gap;
  const double a0 = std::acos((m.rho_o + m.rho_i) / m.L);
  m.r_o = c.r_out;
  m.b_o = c.beta_out - kPi + strand * a0;
  m.r_i = c.r_in;
  m.b_i = c.beta_in - strand * a0;
  return m;
}

Capstan capstan(double R, double Re, double r_out_mm, double beta_out_deg, double r_in_mm,
                double beta_in_deg) {
  Capstan c;
  c.ratio = R;
  c.drum_distance = 0.005;  // D = 5 mm
  c.ratio_error = Re;
  c.r_out = r_out_mm * 1e-3;
  c.beta_out = beta_out_deg * kDeg;
  c.r_in = r_in_mm * 1e-3;
  c.beta_in = beta_in_deg * kDeg;
  c.offset = 0.01;  // never part of error()
  return c;
}

double model_error(const Capstan& c, double q) {
  const std::array<double, 5> p{c.ratio_error, c.r_out, c.beta_out, c.r_in, c.beta_in};
  return capstan_error(c, p.data(), q);
}

// The joint angles: the built-in device's capstan joints' range, +-90 degrees.
std::vector<double> sweep() {
  std::vector<double> q;
  for (int i = -90; i <= 90; ++i) q.push_back(i * kDeg);
  return q;
}

struct Comparison {
  double worst = 0;        // max |theta - q - model| [rad]
  double worst_ratio = 0;  // max of it over eps^2 + (r_o/rho_o) |Re/(R+Re)| |q|
  double signal = 0;       // max |theta - q|: what the model has to explain
};

// The construction for `truth` against eq. (1) with the parameters of `model`
// (the same capstan, or a deliberately wrong one).
Comparison compare(const Capstan& truth, const Capstan& model, int strand, double gap) {
  const Drums m = drums_of(truth, strand, gap);
  const double eps_o = truth.r_out / m.rho_o, eps = (truth.r_out + truth.r_in) / m.rho_o;
  const double re = std::abs(truth.ratio_error / (truth.ratio + truth.ratio_error));
  Comparison out;
  for (double q : sweep()) {
    const double theta = output_angle(m, truth.ratio * q, strand);
    const double d = std::abs(theta - q - model_error(model, q));
    out.worst = std::max(out.worst, d);
    out.worst_ratio = std::max(out.worst_ratio, d / (eps * eps + eps_o * re * std::abs(q)));
    out.signal = std::max(out.signal, std::abs(theta - q));
  }
  return out;
}

struct Case {
  std::string name;
  Capstan c;
};

// Paper Table 2's capstans 1-4 (radii read in mm), and three with
// one term dominant or another ratio, whose first-order terms stand clear of the
// second-order part (Table 2's input eccentricities are below it).
std::vector<Case> cases() {
  return {{"table2-1", capstan(10, -0.025, 0.2, -105, 0.005, -15)},
          {"table2-2", capstan(10, -0.020, 0.25, -10, 0.0025, 140)},
          {"table2-3", capstan(10, 0.015, 0.2, 150, 0.004, -100)},
          {"table2-4", capstan(10, 0.02, 0.1, -40, 0.002, -120)},
          {"output", capstan(10, 0, 0.05, 60, 0, 0)},
          {"input", capstan(10, 0.01, 0, 0, 0.02, -50)},
          {"mixed-R20", capstan(20, -0.03, 0.03, 120, 0.01, 35)}};
}

constexpr double kGap = 0.5e-3;  // between the pitch circles [m]; > r_o + r_i in every case

// (G) is what it claims to be: the same angle by the velocity route (which
// shares only the tangent line's position with it), for both strands and large
// eccentricities (r_o / rho_o = 0.04, r_i / rho_i = 0.04).
TEST(CapstanGeometry, LengthConservationMatchesIntegratedCableSpeed) {
  const Capstan c = capstan(10, -0.025, 0.2, 17, 0.02, -115);
  double worst = 0;
  for (int strand : {1, -1}) {
    const Drums m = drums_of(c, strand, kGap);
    for (double q : {-1.5, -0.7, 0.3, 1.2, 1.5}) {
      const double a = output_angle(m, c.ratio * q, strand);
      const double b = output_angle_integrated(m, c.ratio * q, strand, 4000);
      worst = std::max(worst, std::abs(a - b));
    }
  }
  std::printf("length conservation vs integrated cable speed: max difference %.2e rad\n", worst);
  EXPECT_LT(worst, 1e-12);
}

// No eccentricity: eq. (1) is exact. The ratio term is 2.5e-3 rad per rad of q
// for Re = -0.025, so a wrong sign would show, and so would Re / R for
// Re / (R + Re) (1e-5 rad at 90 degrees for R = 10; 2.3e-5 for R = 6.5, measured
// by editing a copy of the header).
TEST(CapstanGeometry, ZeroEccentricityIsExactlyTheRatioTerm) {
  double worst = 0;
  for (double R : {10.0, 20.0, 6.5}) {
    for (double Re : {-0.025, -0.02, 0.015, 0.02, 0.0}) {
      // Phases without eccentricity have no effect: arbitrary ones.
      const Capstan c = capstan(R, Re, 0, 33, 0, -71);
      for (int strand : {1, -1}) {
        const Comparison r = compare(c, c, strand, kGap);
        worst = std::max(worst, r.worst);
        EXPECT_LT(r.worst, 1e-14) << "R " << R << " Re " << Re << " strand " << strand;
        EXPECT_NEAR(r.signal, std::abs(Re) / (R + Re) * kPi / 2, 1e-15);
      }
    }
  }
  std::printf("no eccentricity: max |theta - q - eq. (1)| %.2e rad\n", worst);
}

// Eccentric drums: eq. (1) agrees with the construction to second order.
TEST(CapstanGeometry, SmallEccentricitiesAgreeToSecondOrder) {
  std::printf("%-10s %6s %12s %12s %12s\n", "case", "strand", "signal", "max |diff|", "/bound");
  for (const Case& k : cases()) {
    // The library's entry point evaluates the same eq. (1).
    for (double q : sweep()) EXPECT_NEAR(Transmission(k.c).error(q), model_error(k.c, q), 1e-15);
    for (int strand : {1, -1}) {
      const Comparison r = compare(k.c, k.c, strand, kGap);
      std::printf("%-10s %6d %9.3e rad %9.3e rad %9.3f\n", k.name.c_str(), strand, r.signal,
                  r.worst, r.worst_ratio);
      EXPECT_LT(r.worst_ratio, kK) << k.name << " strand " << strand;
      // The eccentricities are the larger part of what the model explains: the
      // signal is more than twice the ratio term's largest value.
      const double ratio_term = std::abs(k.c.ratio_error) / (k.c.ratio + k.c.ratio_error) * kPi / 2;
      EXPECT_GT(r.signal, 2 * ratio_term) << k.name;
    }
  }
}

// Second order, not a small first-order error: halving the eccentricities (no
// ratio error) quarters the discrepancy while the signal halves. A wrong
// amplitude, phase or sign in a first-order term would halve it instead.
TEST(CapstanGeometry, DiscrepancyIsSecondOrderInTheEccentricities) {
  const std::vector<Case> scaled = {{"output", capstan(10, 0, 0.1, 60, 0, 0)},
                                    {"input", capstan(10, 0, 0, 0, 0.04, -50)},
                                    {"both", capstan(10, 0, 0.1, -105, 0.02, -15)}};
  for (const Case& k : scaled) {
    for (int strand : {1, -1}) {
      Capstan half = k.c;
      half.r_out /= 2;
      half.r_in /= 2;
      const Comparison full = compare(k.c, k.c, strand, kGap);
      const Comparison halved = compare(half, half, strand, kGap);
      const double ratio = full.worst / halved.worst;
      std::printf("%-7s strand %2d: discrepancy %.3e -> %.3e rad (/%.3f), signal /%.3f\n",
                  k.name.c_str(), strand, full.worst, halved.worst, ratio,
                  full.signal / halved.signal);
      EXPECT_GT(ratio, 3.6) << k.name << " strand " << strand;
      EXPECT_LT(ratio, 4.4) << k.name << " strand " << strand;
      EXPECT_NEAR(full.signal / halved.signal, 2.0, 0.1) << k.name;
    }
  }
}

// The test can fail: eq. (1) with a first-order mistake - a phase's sign flipped,
// the output phase's reference turned by pi (the output term's sign), the ratio
// error's sign flipped, or D read as the distance between the drums' axes -
// exceeds the bound K by far on every case where that term is visible.
TEST(CapstanGeometry, WrongSignsOrScalesBreakTheFirstOrderAgreement) {
  struct Mistake {
    std::string name;
    void (*apply)(Capstan&);
    std::vector<std::string> visible_in;
  };
  const std::vector<Mistake> mistakes = {
      {"-beta_out", [](Capstan& c) { c.beta_out = -c.beta_out; }, {"output", "mixed-R20"}},
      {"beta_out+pi", [](Capstan& c) { c.beta_out += kPi; }, {"output", "mixed-R20", "table2-1"}},
      {"-beta_in", [](Capstan& c) { c.beta_in = -c.beta_in; }, {"input", "mixed-R20"}},
      {"-Re", [](Capstan& c) { c.ratio_error = -c.ratio_error; }, {"input", "mixed-R20"}},
      {"D=L",
       [](Capstan& c) { c.drum_distance += c.drum_distance / (c.ratio + c.ratio_error) + kGap; },
       {"output", "input", "mixed-R20"}}};
  for (const Mistake& mistake : mistakes) {
    for (const Case& k : cases()) {
      const auto& v = mistake.visible_in;
      if (std::find(v.begin(), v.end(), k.name) == v.end()) continue;
      Capstan wrong = k.c;
      mistake.apply(wrong);
      for (int strand : {1, -1}) {
        const Comparison r = compare(k.c, wrong, strand, kGap);
        std::printf("%-12s %-10s strand %2d: max |diff| %.3e rad, /bound %.1f\n",
                    mistake.name.c_str(), k.name.c_str(), strand, r.worst, r.worst_ratio);
        EXPECT_GT(r.worst_ratio, 2 * kK) << mistake.name << " " << k.name << " strand " << strand;
      }
    }
  }
}

}  // namespace
}  // namespace hapticcal
