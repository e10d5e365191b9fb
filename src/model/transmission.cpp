#include "hapticcal/model/transmission.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <stdexcept>
#include <unsupported/Eigen/AutoDiff>

#include "hapticcal/model/model.hpp"

namespace hapticcal {
namespace {

std::array<double, Capstan::kNumParameters> capstan_parameters(const Capstan& c) {
  return {c.ratio_error, c.r_out, c.beta_out, c.r_in, c.beta_in};
}

// Eccentric-drum term g(u) = atan2(r sin u, D - r cos u) and its partials.
double drum_du(double r, double D, double u) {  // dg/du
  const double c = std::cos(u);
  return (r * D * c - r * r) / (D * D - 2 * D * r * c + r * r);
}
double drum_dr(double r, double D, double u) {  // dg/dr
  return D * std::sin(u) / (D * D - 2 * D * r * std::cos(u) + r * r);
}

double capstan_derivative(const Capstan& c, double q) {
  const double R = c.ratio;
  return -c.ratio_error / (c.ratio_error + R) + drum_du(c.r_out, c.drum_distance, q + c.beta_out) +
         R * drum_du(c.r_in, c.drum_distance, R * q + c.beta_in);
}

void capstan_jacobian(const Capstan& c, double q, double* J) {
  const double R = c.ratio, D = c.drum_distance;
  const double s = c.ratio_error + R;
  J[0] = -R / (s * s) * q;
  J[1] = drum_dr(c.r_out, D, q + c.beta_out) - drum_dr(c.r_out, D, c.beta_out);
  J[2] = drum_du(c.r_out, D, q + c.beta_out) - drum_du(c.r_out, D, c.beta_out);
  J[3] = drum_dr(c.r_in, D, R * q + c.beta_in) - drum_dr(c.r_in, D, c.beta_in);
  J[4] = drum_du(c.r_in, D, R * q + c.beta_in) - drum_du(c.r_in, D, c.beta_in);
}

// d/dq of the corrected eq. (2): chain rule through s(q).
double parallelogram_derivative(const Parallelogram& P, double q) {
  const double L1 = P.L1, L2 = P.L2, L3 = P.L3, L4 = P.L4;
  const double s2 = L1 * L1 + L2 * L2 - 2 * L1 * L2 * std::sin(q);
  const double s = std::sqrt(s2);
  const double ds_dq = -L1 * L2 * std::cos(q) / s;
  const double u1 = (L1 * L1 + s2 - L2 * L2) / (2 * L1 * s);
  const double u2 = (L4 * L4 + s2 - L3 * L3) / (2 * L4 * s);
  const double du1_ds = -(L1 * L1 - L2 * L2) / (2 * L1 * s2) + 1 / (2 * L1);
  const double du2_ds = -(L4 * L4 - L3 * L3) / (2 * L4 * s2) + 1 / (2 * L4);
  return (-du1_ds / std::sqrt(1 - u1 * u1) - du2_ds / std::sqrt(1 - u2 * u2)) * ds_dq - 1;
}

void parallelogram_jacobian(const Parallelogram& P, double q, double* J) {
  // Forward-mode derivatives (Eigen's AutoDiffScalar: the core library needs no Ceres).
  using Dual = Eigen::AutoDiffScalar<Eigen::Vector4d>;
  const std::array<Dual, 4> L = {Dual(P.L1, 4, 0), Dual(P.L2, 4, 1), Dual(P.L3, 4, 2),
                                 Dual(P.L4, 4, 3)};
  const Dual e = parallelogram_error(L.data(), Dual(q));
  for (int k = 0; k < 4; ++k) J[k] = e.derivatives()[k];
}

// Chebyshev (or monomial) basis values P_k(q) and their derivatives, k = 0..n.
void polynomial_basis(const Polynomial& poly, double q, double* P, double* dP_dq) {
  const int n = poly.order();
  if (poly.basis == PolynomialBasis::kMonomial) {
    double qk = 1;
    for (int k = 0; k <= n; ++k) {
      if (dP_dq) dP_dq[k] = k == 0 ? 0.0 : k * (P[k - 1]);
      P[k] = qk;
      qk *= q;
    }
    return;
  }
  const double scale = 2 / (poly.upper - poly.lower);
  const double x = (2 * q - (poly.lower + poly.upper)) / (poly.upper - poly.lower);
  P[0] = 1;
  if (n >= 1) P[1] = x;
  for (int k = 2; k <= n; ++k) P[k] = 2 * x * P[k - 1] - P[k - 2];
  if (!dP_dq) return;
  dP_dq[0] = 0;
  if (n >= 1) dP_dq[1] = scale;
  for (int k = 2; k <= n; ++k) {  // T'_k = 2 T_{k-1} + 2x T'_{k-1} - T'_{k-2}
    dP_dq[k] = 2 * scale * P[k - 1] + 2 * x * dP_dq[k - 1] - dP_dq[k - 2];
  }
}

// d/dq of sum_k c_k P_k(q), without allocation (a controller calls it per
// cycle): Horner for the monomial basis; for Chebyshev T'_k by the recurrence
// T'_k = 2 T_{k-1} + 2x T'_{k-1} - T'_{k-2}, times dx/dq.
double polynomial_derivative(const Polynomial& poly, double q) {
  const int n = poly.order();
  if (n < 1) return 0.0;
  const std::vector<double>& c = poly.coefficients;
  if (poly.basis == PolynomialBasis::kMonomial) {
    double d = n * c[n];
    for (int k = n - 1; k >= 1; --k) d = d * q + k * c[k];
    return d;
  }
  const double scale = 2 / (poly.upper - poly.lower);
  const double x = (2 * q - (poly.lower + poly.upper)) / (poly.upper - poly.lower);
  double T_prev = 1, T = x;    // T_{k-2}, T_{k-1} as k runs
  double dT_prev = 0, dT = 1;  // their derivatives in x
  double d = c[1];
  for (int k = 2; k <= n; ++k) {
    const double T_next = 2 * x * T - T_prev;
    const double dT_next = 2 * T + 2 * x * dT - dT_prev;
    T_prev = T;
    T = T_next;
    dT_prev = dT;
    dT = dT_next;
    d += c[k] * dT;
  }
  return d * scale;
}

void polynomial_jacobian(const Polynomial& poly, double q, double* J) {
  const int n = poly.order();
  std::vector<double> P(n + 1), P0(n + 1);
  polynomial_basis(poly, q, P.data(), nullptr);
  polynomial_basis(poly, 0.0, P0.data(), nullptr);
  for (int k = 1; k <= n; ++k) J[k - 1] = P[k] - P0[k];
}

// The first of 101 angles across [lower, upper] where the error or its slope is
// not finite, or none.
std::optional<double> not_finite_at(const Transmission& t, double lower, double upper) {
  for (int i = 0; i <= 100; ++i) {
    const double q = lower + (upper - lower) * i / 100.0;
    if (!std::isfinite(t.error(q)) || !std::isfinite(t.derivative(q))) return q;
  }
  return std::nullopt;
}

}  // namespace

double Transmission::error(double q) const {
  struct Visitor {
    double q;
    double operator()(const std::monostate&) const { return 0.0; }
    double operator()(const Capstan& c) const {
      const auto p = capstan_parameters(c);
      return capstan_error(c, p.data(), q);
    }
    double operator()(const Parallelogram& P) const {
      const double L[4] = {P.L1, P.L2, P.L3, P.L4};
      return parallelogram_error(L, q);
    }
    double operator()(const Polynomial& poly) const {
      if (poly.order() < 1) return 0.0;
      return polynomial_error(poly, poly.coefficients.data() + 1, q);
    }
    double operator()(const Chain& chain) const {
      double x = q;
      for (const Transmission& stage : chain.stages) x += stage.error(x);
      return x - q;
    }
    double operator()(const Harmonic& h) const {
      return harmonic_error(h, h.coefficients.data(), q);
    }
    double operator()(const Extension& e) const {
      return e.definition->error(e.parameters.data(), q);
    }
  };
  return std::visit(Visitor{q}, model_);
}

double Transmission::derivative(double q) const {
  struct Visitor {
    double q;
    double operator()(const std::monostate&) const { return 0.0; }
    double operator()(const Capstan& c) const { return capstan_derivative(c, q); }
    double operator()(const Parallelogram& P) const { return parallelogram_derivative(P, q); }
    double operator()(const Polynomial& poly) const { return polynomial_derivative(poly, q); }
    double operator()(const Extension& e) const {
      return e.definition->derivative(e.parameters.data(), q);
    }
    double operator()(const Harmonic& h) const {
      double d = 0;
      for (size_t i = 0; i < h.frequencies.size(); ++i) {
        const double f = h.frequencies[i];
        d += f * (h.coefficients[2 * i] * std::cos(f * q) -
                  h.coefficients[2 * i + 1] * std::sin(f * q));
      }
      return d;
    }
    double operator()(const Chain& chain) const {
      double x = q, product = 1;
      for (const Transmission& stage : chain.stages) {
        product *= 1 + stage.derivative(x);
        x += stage.error(x);
      }
      return product - 1;
    }
  };
  return std::visit(Visitor{q}, model_);
}

int Transmission::num_parameters() const {
  struct Visitor {
    int operator()(const std::monostate&) const { return 0; }
    int operator()(const Capstan&) const { return Capstan::kNumParameters; }
    int operator()(const Parallelogram&) const { return Parallelogram::kNumParameters; }
    int operator()(const Polynomial& poly) const { return std::max(poly.order(), 0); }
    int operator()(const Harmonic& h) const { return static_cast<int>(2 * h.frequencies.size()); }
    int operator()(const Extension& e) const { return static_cast<int>(e.parameters.size()); }
    int operator()(const Chain& chain) const {
      int n = 0;
      for (const Transmission& stage : chain.stages) n += stage.num_parameters();
      return n;
    }
  };
  return std::visit(Visitor{}, model_);
}

std::vector<std::string> Transmission::parameter_names() const {
  struct Visitor {
    std::vector<std::string> operator()(const std::monostate&) const { return {}; }
    std::vector<std::string> operator()(const Capstan&) const {
      return {"ratio_error", "r_out", "beta_out", "r_in", "beta_in"};
    }
    std::vector<std::string> operator()(const Parallelogram&) const {
      return {"L1", "L2", "L3", "L4"};
    }
    std::vector<std::string> operator()(const Extension& e) const {
      return e.definition->parameter_names();
    }
    std::vector<std::string> operator()(const Polynomial& poly) const {
      std::vector<std::string> names;
      for (int k = 1; k <= poly.order(); ++k) names.push_back(fmt::format("c{}", k));
      return names;
    }
    std::vector<std::string> operator()(const Harmonic& h) const {
      std::vector<std::string> names;
      // A dot would split the dotted name: 13.3 is "13p3".
      for (double f : h.frequencies) {
        std::string text = fmt::format("{:g}", f);
        std::replace(text.begin(), text.end(), '.', 'p');
        names.push_back("sin" + text);
        names.push_back("cos" + text);
      }
      return names;
    }
    std::vector<std::string> operator()(const Chain& chain) const {
      std::vector<std::string> names;
      for (size_t s = 0; s < chain.stages.size(); ++s) {
        for (const std::string& name : chain.stages[s].parameter_names()) {
          names.push_back(fmt::format("stage{}.{}", s + 1, name));
        }
      }
      return names;
    }
  };
  return std::visit(Visitor{}, model_);
}

Eigen::VectorXd Transmission::parameters() const {
  struct Visitor {
    Eigen::VectorXd operator()(const std::monostate&) const { return {}; }
    Eigen::VectorXd operator()(const Capstan& c) const {
      const auto p = capstan_parameters(c);
      return Eigen::Map<const Eigen::VectorXd>(p.data(), p.size());
    }
    Eigen::VectorXd operator()(const Parallelogram& P) const {
      return Eigen::Vector4d(P.L1, P.L2, P.L3, P.L4);
    }
    Eigen::VectorXd operator()(const Polynomial& poly) const {
      if (poly.order() < 1) return {};
      return Eigen::Map<const Eigen::VectorXd>(poly.coefficients.data() + 1, poly.order());
    }
    Eigen::VectorXd operator()(const Harmonic& h) const {
      return Eigen::Map<const Eigen::VectorXd>(h.coefficients.data(),
                                               static_cast<Eigen::Index>(h.coefficients.size()));
    }
    Eigen::VectorXd operator()(const Extension& e) const {
      return Eigen::Map<const Eigen::VectorXd>(e.parameters.data(),
                                               static_cast<Eigen::Index>(e.parameters.size()));
    }
    Eigen::VectorXd operator()(const Chain& chain) const {
      std::vector<double> all;
      for (const Transmission& stage : chain.stages) {
        const Eigen::VectorXd p = stage.parameters();
        all.insert(all.end(), p.data(), p.data() + p.size());
      }
      return Eigen::Map<const Eigen::VectorXd>(all.data(), all.size());
    }
  };
  return std::visit(Visitor{}, model_);
}

void Transmission::set_parameters(const double* v) {
  struct Visitor {
    const double* v;
    void operator()(std::monostate&) const {}
    void operator()(Capstan& c) const {
      c.ratio_error = v[0];
      c.r_out = v[1];
      c.beta_out = v[2];
      c.r_in = v[3];
      c.beta_in = v[4];
    }
    void operator()(Parallelogram& P) const {
      P.L1 = v[0];
      P.L2 = v[1];
      P.L3 = v[2];
      P.L4 = v[3];
    }
    void operator()(Polynomial& poly) const {
      for (int k = 1; k <= poly.order(); ++k) poly.coefficients[k] = v[k - 1];
    }
    void operator()(Harmonic& h) const {
      std::copy(v, v + h.coefficients.size(), h.coefficients.begin());
    }
    void operator()(Extension& e) const {
      std::copy(v, v + e.parameters.size(), e.parameters.begin());
    }
    void operator()(Chain& chain) const {
      const double* p = v;
      for (Transmission& stage : chain.stages) {
        stage.set_parameters(p);
        p += stage.num_parameters();
      }
    }
  };
  std::visit(Visitor{v}, model_);
}

void Transmission::parameter_jacobian(double q, double* J) const {
  struct Visitor {
    double q;
    double* J;
    void operator()(const std::monostate&) const {}
    void operator()(const Capstan& c) const { capstan_jacobian(c, q, J); }
    void operator()(const Parallelogram& P) const { parallelogram_jacobian(P, q, J); }
    void operator()(const Polynomial& poly) const { polynomial_jacobian(poly, q, J); }
    void operator()(const Extension& e) const {
      e.definition->parameter_jacobian(e.parameters.data(), q, J);
    }
    void operator()(const Harmonic& h) const {
      for (size_t i = 0; i < h.frequencies.size(); ++i) {
        const double u = h.frequencies[i] * q;
        J[2 * i] = std::sin(u);
        J[2 * i + 1] = std::cos(u) - 1;
      }
    }
    void operator()(const Chain& chain) const {
      // Stage k moves x_{k+1} by d e_k; later stages scale that by (1 + e_j'(x_j)).
      const size_t n = chain.stages.size();
      std::vector<double> x(n + 1);
      x[0] = q;
      for (size_t k = 0; k < n; ++k) x[k + 1] = x[k] + chain.stages[k].error(x[k]);
      double* Jk = J;
      for (size_t k = 0; k < n; ++k) {
        const Transmission& stage = chain.stages[k];
        stage.parameter_jacobian(x[k], Jk);
        double downstream = 1;
        for (size_t j = k + 1; j < n; ++j) downstream *= 1 + chain.stages[j].derivative(x[j]);
        for (int i = 0; i < stage.num_parameters(); ++i) Jk[i] *= downstream;
        Jk += stage.num_parameters();
      }
    }
  };
  std::visit(Visitor{q, J}, model_);
}

double Transmission::drive_ratio() const {
  if (const auto* c = std::get_if<Capstan>(&model_)) return c->ratio;
  if (const auto* chain = std::get_if<Chain>(&model_)) {
    for (const Transmission& stage : chain->stages) {
      if (const auto* c = std::get_if<Capstan>(&stage.model())) return c->ratio;
    }
  }
  return 1.0;
}

std::string Transmission::check(double lower, double upper) const {
  struct Visitor {
    double lower, upper;
    std::string operator()(const std::monostate&) const { return {}; }
    std::string operator()(const Capstan& c) const {
      if (!(c.ratio > 0)) return "ratio must be positive";
      if (!(c.drum_distance > 0)) return "drum_distance must be positive";
      if (!(c.ratio + c.ratio_error > 0)) return "ratio + ratio_error must be positive";
      if (!(std::abs(c.r_out) < c.drum_distance)) return "r_out must be smaller than drum_distance";
      if (!(std::abs(c.r_in) < c.drum_distance)) return "r_in must be smaller than drum_distance";
      return {};
    }
    std::string operator()(const Parallelogram& P) const {
      if (!(P.L1 > 0 && P.L2 > 0 && P.L3 > 0 && P.L4 > 0)) return "lengths must be positive";
      if (const auto q = not_finite_at(Transmission{P}, lower, upper))
        return fmt::format("the linkage cannot close at q = {} rad", *q);
      return {};
    }
    std::string operator()(const Polynomial& poly) const {
      if (poly.coefficients.empty()) return "coefficients must not be empty";
      if (poly.basis == PolynomialBasis::kChebyshev && !(poly.lower < poly.upper))
        return "domain must have lower < upper";
      return {};
    }
    std::string operator()(const Harmonic& h) const {
      if (h.frequencies.empty()) return "frequencies must not be empty";
      if (h.frequencies.size() > Harmonic::kMaxFrequencies)
        return fmt::format("at most {} frequencies", Harmonic::kMaxFrequencies);
      if (h.coefficients.size() != 2 * h.frequencies.size())
        return "sin and cos need one coefficient a frequency";
      for (size_t i = 0; i < h.frequencies.size(); ++i) {
        const double f = h.frequencies[i];
        if (!(f > 0 && f <= 1000)) return "frequencies must be in (0, 1000]";
        for (size_t k = 0; k < i; ++k) {
          if (h.frequencies[k] == f) return fmt::format("frequency {:g} given twice", f);
        }
      }
      for (double c : h.coefficients) {
        if (!(std::abs(c) <= 1)) return "coefficients must be within 1 rad";
      }
      return {};
    }
    std::string operator()(const Extension& e) const {
      if (!e.definition) return "an extension without its kind's definition";
      if (e.parameters.size() != e.definition->parameter_names().size())
        return fmt::format("{} needs {} parameters", e.definition->name(),
                           e.definition->parameter_names().size());
      const std::string why = e.definition->check(e.parameters.data(), lower, upper);
      if (!why.empty()) return why;
      // Referenced to home, and finite with a finite slope over the range.
      const Transmission t{e};
      if (!(std::abs(t.error(0.0)) <= 1e-12)) return "its error at q = 0 must be 0";
      if (const auto q = not_finite_at(t, lower, upper))
        return fmt::format("its error is not finite at q = {} rad", *q);
      return {};
    }
    std::string operator()(const Chain& chain) const {
      if (chain.stages.empty()) return "a chain needs at least one stage";
      for (size_t k = 0; k < chain.stages.size(); ++k) {
        const std::string why = chain.stages[k].check(lower, upper);
        if (!why.empty()) return fmt::format("stage {}: {}", k + 1, why);
      }
      return {};
    }
  };
  return std::visit(Visitor{lower, upper}, model_);
}

Transmission without_trailing_harmonic(const Transmission& t) {
  if (t.kind() == TransmissionKind::kHarmonic) return Transmission();
  const auto* chain = std::get_if<Chain>(&t.model());
  if (!chain || chain->stages.back().kind() != TransmissionKind::kHarmonic) return t;
  if (chain->stages.size() == 2) return chain->stages.front();
  Chain shorter = *chain;
  shorter.stages.pop_back();
  return Transmission(shorter);
}

std::vector<double> monomial_coefficients(const Polynomial& poly) {
  const int n = poly.order();
  std::vector<double> k(std::max(n + 1, 0), 0.0);
  if (n < 0) return k;
  if (poly.basis == PolynomialBasis::kMonomial) return poly.coefficients;
  // T_j(x) in monomials of x, then x = a q + b, expanded by Horner on polynomials.
  const double a = 2 / (poly.upper - poly.lower);
  const double b = -(poly.lower + poly.upper) / (poly.upper - poly.lower);
  std::vector<std::vector<double>> T(n + 1, std::vector<double>(n + 1, 0.0));
  T[0][0] = 1;
  if (n >= 1) T[1][1] = 1;
  for (int j = 2; j <= n; ++j) {
    for (int i = 0; i <= n; ++i) {
      T[j][i] = (i > 0 ? 2 * T[j - 1][i - 1] : 0.0) - T[j - 2][i];
    }
  }
  std::vector<double> in_x(n + 1, 0.0);
  for (int j = 0; j <= n; ++j) {
    for (int i = 0; i <= n; ++i) in_x[i] += poly.coefficients[j] * T[j][i];
  }
  // sum_i in_x[i] (a q + b)^i by Horner.
  for (int i = n; i >= 0; --i) {
    std::vector<double> next(n + 1, 0.0);
    for (int m = 0; m < n; ++m) {
      next[m + 1] += a * k[m];
      next[m] += b * k[m];
    }
    next[n] += b * k[n];
    next[0] += in_x[i];
    k = next;
  }
  return k;
}

PreparedTransmission::PreparedTransmission(const Transmission& t) {
  if (t.is_none()) return;
  if (const auto* c = std::get_if<Capstan>(&t.model())) {
    kind_ = Kind::kCapstan;
    ratio_ = c->ratio;
    drum_ = c->drum_distance;
    slope_ = -c->ratio_error / (c->ratio_error + c->ratio);
    r_out_ = c->r_out;
    cos_bo_ = std::cos(c->beta_out);
    sin_bo_ = std::sin(c->beta_out);
    r_in_ = c->r_in;
    cos_bi_ = std::cos(c->beta_in);
    sin_bi_ = std::sin(c->beta_in);
    double t_out, t_in;
    capstan_tangents(0.0, 1.0, 0.0, 1.0, t_out, t_in);
    home_ = std::atan(t_out) + std::atan(t_in);
    return;
  }
  if (const auto* p = std::get_if<Polynomial>(&t.model()); p && p->order() >= 1) {
    kind_ = Kind::kPolynomial;
    polynomial_ = *p;
    polynomial_home_ = polynomial_value(*p, p->coefficients.data() + 1, 0.0);
    if (p->basis == PolynomialBasis::kChebyshev) {
      scale_ = 2 / (p->upper - p->lower);
      shift_ = -(p->lower + p->upper) / (p->upper - p->lower);
    }
    return;
  }
  kind_ = Kind::kGeneric;
  generic_ = t;
}

void PreparedTransmission::capstan_tangents(double so, double co, double si, double ci,
                                            double& t_out, double& t_in) const {
  const double s_out = so * cos_bo_ + co * sin_bo_, c_out = co * cos_bo_ - so * sin_bo_;
  const double s_in = si * cos_bi_ + ci * sin_bi_, c_in = ci * cos_bi_ - si * sin_bi_;
  t_out = r_out_ * s_out / (drum_ - r_out_ * c_out);
  t_in = r_in_ * s_in / (drum_ - r_in_ * c_in);
}

double PreparedTransmission::error(double q) const {
  switch (kind_) {
    case Kind::kNone:
      return 0.0;
    case Kind::kCapstan: {
      double t_out, t_in;
      capstan_tangents(std::sin(q), std::cos(q), std::sin(ratio_ * q), std::cos(ratio_ * q), t_out,
                       t_in);
      return capstan_error(q, std::atan(t_out), std::atan(t_in));
    }
    case Kind::kPolynomial: {
      const std::vector<double>& c = polynomial_.coefficients;
      const int n = polynomial_.order();
      if (polynomial_.basis == PolynomialBasis::kMonomial) {
        return polynomial_value(polynomial_, c.data() + 1, q) - polynomial_home_;
      }
      const double x = scale_ * q + shift_;  // Clenshaw, as polynomial_value
      double b1 = 0, b2 = 0;
      for (int k = n; k >= 1; --k) {
        const double b0 = c[k] + 2 * x * b1 - b2;
        b2 = b1;
        b1 = b0;
      }
      return x * b1 - b2 - polynomial_home_;
    }
    case Kind::kGeneric:
      return generic_.error(q);
  }
  return 0.0;
}

double PreparedTransmission::derivative(double q) const {
  switch (kind_) {
    case Kind::kNone:
      return 0.0;
    case Kind::kCapstan: {
      // slope + g'(q + beta_out) + R g'(R q + beta_in), g' = drum_du, with
      // cos(q + beta) from the prepared phase.
      const double cos_out = std::cos(q) * cos_bo_ - std::sin(q) * sin_bo_;
      const double cos_in = std::cos(ratio_ * q) * cos_bi_ - std::sin(ratio_ * q) * sin_bi_;
      auto du = [&](double r, double c) {
        return (r * drum_ * c - r * r) / (drum_ * drum_ - 2 * drum_ * r * c + r * r);
      };
      return slope_ + du(r_out_, cos_out) + ratio_ * du(r_in_, cos_in);
    }
    case Kind::kPolynomial:
      return polynomial_derivative(polynomial_, q);
    case Kind::kGeneric:
      return generic_.derivative(q);
  }
  return 0.0;
}

}  // namespace hapticcal
