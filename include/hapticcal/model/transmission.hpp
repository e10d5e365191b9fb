// Transmission error models: the difference between the joint angle and the
// device's own reading referred to the joint side, dtheta(q) = theta - q - offset.
// Every model is referenced to home: error(0) = 0.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <variant>
#include <vector>

namespace hapticcal {

// Capstan drive with eccentric drums, paper eq. (1) with tan read as atan2.
// ratio and drum_distance are known constants; the five parameters
// [ratio_error, r_out, beta_out, r_in, beta_in] are identified. offset is the
// constant c between an external encoder's zero and the joint: a nuisance of
// step 1, stored for the record and never part of error().
struct Capstan {
  double ratio = 1.0;  // R, input drum turns per output turn
  // D [m], the paper's "drum distance". In eq. (1)'s eccentricity terms it acts
  // as the output drum's pitch radius (tests/capstan_geometry_test.cpp derives
  // it from the drums' geometry): given the distance between the axes instead,
  // r_out and r_in are identified scaled by D / (that radius).
  double drum_distance = 0.0;
  double offset = 0.0;       // c [rad]
  double ratio_error = 0.0;  // Re
  double r_out = 0.0;        // output drum eccentricity [m]
  double beta_out = 0.0;     // its phase [rad]
  double r_in = 0.0;         // input drum eccentricity [m]
  double beta_in = 0.0;      // its phase [rad]
  static constexpr int kNumParameters = 5;
};

// Planar parallelogram with link lengths L1..L4, paper eq. (2) corrected
//. Zero error for L1 = L3, L2 = L4.
struct Parallelogram {
  double L1 = 0.0, L2 = 0.0, L3 = 0.0, L4 = 0.0;  // [m]
  static constexpr int kNumParameters = 4;
};

// A polynomial of any order. In the Chebyshev basis the reading is mapped from
// [lower, upper] onto [-1, 1]; the monomial basis (the paper's k_k q^k) is kept
// for reading published coefficients. coefficients[0] has no effect (error(0) = 0),
// so the parameters are coefficients[1..].
enum class PolynomialBasis { kChebyshev, kMonomial };
struct Polynomial {
  PolynomialBasis basis = PolynomialBasis::kChebyshev;
  double lower = -1.0, upper = 1.0;  // Chebyshev domain [rad]
  std::vector<double> coefficients;
  int order() const { return static_cast<int>(coefficients.size()) - 1; }
};

// Harmonics of the angle that a gear or drive adds (issue 25; the paper's
// capstan eccentricity generalised): for frequencies f_i (error cycles a turn of
// the angle: 1 and 2 for the first and second harmonic of the output, R and 2R
// for the motor's through a drive of ratio R),
//   dtheta(q) = sum_i s_i sin(f_i q) + c_i (cos(f_i q) - 1),
// referenced to home and linear in the parameters [s_1, c_1, s_2, c_2, ...].
struct Harmonic {
  std::vector<double> frequencies;
  std::vector<double> coefficients;  // s_1, c_1, s_2, c_2, ...: two a frequency
  static constexpr size_t kMaxFrequencies = 8;
};

class Transmission;

// A kind of transmission defined outside the library: one file that implements
// this and one register_transmission_kind call. Its parameters are numbers
// named by parameter_names(); the device file gives them as keys beside `type:
// <name>` (absent: 0), step 1 fits all of them by least squares from the
// external encoders, starting from the file's values, and everything else
// (compensation, step 2, the runtime) evaluates error(). The error is referenced
// to home: error(p, 0) = 0. derivative and parameter_jacobian default to
// central differences of error.
class TransmissionDefinition {
 public:
  virtual ~TransmissionDefinition() = default;
  // Its device-file type: letters, digits and '_', not a built-in kind's.
  virtual std::string_view name() const = 0;
  virtual std::vector<std::string> parameter_names() const = 0;
  // dtheta(q) with parameters p (parameter_names()' order).
  virtual double error(const double* p, double q) const = 0;
  // d dtheta / dq.
  virtual double derivative(const double* p, double q) const;
  // d dtheta / d p, one value a parameter.
  virtual void parameter_jacobian(const double* p, double q, double* J) const;
  // Empty if these parameters can be evaluated over [lower, upper], else why.
  virtual std::string check(const double* /*p*/, double /*lower*/, double /*upper*/) const {
    return {};
  }
};

// A transmission of a registered kind: its definition and its parameters.
struct Extension {
  const TransmissionDefinition* definition = nullptr;
  std::vector<double> parameters;
};

// A kind made known to device files (not thread-safe: before any file is read).
// std::invalid_argument if its name is a built-in kind's, already registered, or
// not a word.
void register_transmission_kind(const TransmissionDefinition* definition);
// The registered kind of this name, or null.
const TransmissionDefinition* find_transmission_kind(std::string_view name);
// The registered kinds' names, in registration order.
std::vector<std::string> registered_transmission_kinds();

// The kinds of transmission, in the order of Transmission::Model's alternatives.
enum class TransmissionKind {
  kNone,
  kCapstan,
  kParallelogram,
  kPolynomial,
  kChain,
  kHarmonic,
  kExtension
};
// "none", "capstan", "parallelogram", "polynomial", "chain", "harmonic",
// "extension" (device files name an extension by its definition's name).
const char* to_string(TransmissionKind kind);
std::optional<TransmissionKind> transmission_kind_named(const std::string& name);

// Stages in series: the output angle of one drives the next.
struct Chain {
  std::vector<Transmission> stages;
};

// One joint's transmission: none, or one of the models above.
class Transmission {
 public:
  using Model =
      std::variant<std::monostate, Capstan, Parallelogram, Polynomial, Chain, Harmonic, Extension>;

  Transmission() = default;
  Transmission(Model model) : model_(std::move(model)) {}  // NOLINT: implicit by design

  const Model& model() const { return model_; }
  Model& model() { return model_; }
  bool is_none() const { return std::holds_alternative<std::monostate>(model_); }
  TransmissionKind kind() const { return static_cast<TransmissionKind>(model_.index()); }
  // "none", "capstan", "parallelogram", "polynomial", "chain", "harmonic" or an
  // extension's name.
  std::string type_name() const;
  // The motor-to-joint ratio of its capstan (alone, or the first in a chain);
  // 1 without one.
  double drive_ratio() const;

  // dtheta(q), referenced to home.
  double error(double q) const;
  // d dtheta / dq.
  double derivative(double q) const;

  // The identified parameters, in the order of parameter_names().
  int num_parameters() const;
  std::vector<std::string> parameter_names() const;  // e.g. "r_out", "stage2.L1", "c3"
  Eigen::VectorXd parameters() const;
  void set_parameters(const double* values);
  // J_error_params: d dtheta(q) / d parameters, num_parameters() values.
  void parameter_jacobian(double q, double* J_error_params) const;

  // Empty if the model can be evaluated over [lower, upper], else the reason.
  std::string check(double lower, double upper) const;

  // Generic evaluation with parameters supplied as T (double or ceres::Jet),
  // in the order of parameter_names(). An extension's in double only.
  template <typename T>
  T error(const T* params, const T& q) const;

 private:
  Model model_;
};

// ---------------------------------------------------------------------------
// Generic model equations.

// Paper eq. (1): capstan error with p = [Re, ro, bo, ri, bi], referenced to home.
template <typename T>
T capstan_error(const Capstan& c, const T* p, const T& q) {
  using std::atan2;
  using std::cos;
  using std::sin;
  const T R(c.ratio), D(c.drum_distance);
  const T& Re = p[0];
  const T& ro = p[1];
  const T& bo = p[2];
  const T& ri = p[3];
  const T& bi = p[4];
  const T u_out = q + bo;
  const T u_in = R * q + bi;
  return -Re / (Re + R) * q + atan2(ro * sin(u_out), D - ro * cos(u_out)) -
         atan2(ro * sin(bo), D - ro * cos(bo)) + atan2(ri * sin(u_in), D - ri * cos(u_in)) -
         atan2(ri * sin(bi), D - ri * cos(bi));
}

// The paper's eq. (2) corrected, before referencing to home; L = [L1, L2, L3, L4].
template <typename T>
T parallelogram_raw(const T* L, const T& qa) {
  using std::acos;
  using std::sin;
  using std::sqrt;
  const T s2 = L[0] * L[0] + L[1] * L[1] - T(2) * L[0] * L[1] * sin(qa);  // cos(pi/2 - qa)
  const T s = sqrt(s2);
  return acos((L[0] * L[0] + s2 - L[1] * L[1]) / (T(2) * L[0] * s)) +
         acos((L[3] * L[3] + s2 - L[2] * L[2]) / (T(2) * L[3] * s)) - T(std::numbers::pi / 2) - qa;
}

template <typename T>
T parallelogram_error(const T* L, const T& q) {
  return parallelogram_raw(L, q) - parallelogram_raw(L, T(0));
}

// Polynomial value sum_k c_k P_k(q) (c_0 taken as zero), P_k Chebyshev or monomial.
template <typename T>
T polynomial_value(const Polynomial& poly, const T* c_from_1, const T& q) {
  const int n = poly.order();
  if (n < 1) return T(0);
  if (poly.basis == PolynomialBasis::kMonomial) {
    T acc = c_from_1[n - 1];
    for (int k = n - 1; k >= 1; --k) acc = acc * q + c_from_1[k - 1];
    return acc * q;
  }
  // Clenshaw's recurrence for sum_{k>=1} c_k T_k(x).
  const T x = (T(2) * q - T(poly.lower + poly.upper)) / T(poly.upper - poly.lower);
  T b1(0), b2(0);
  for (int k = n; k >= 1; --k) {
    const T b0 = c_from_1[k - 1] + T(2) * x * b1 - b2;
    b2 = b1;
    b1 = b0;
  }
  return x * b1 - b2;  // c_0 = 0
}

template <typename T>
T polynomial_error(const Polynomial& poly, const T* c_from_1, const T& q) {
  return polynomial_value(poly, c_from_1, q) - polynomial_value(poly, c_from_1, T(0));
}

// Harmonic error with p = [s_1, c_1, s_2, c_2, ...].
template <typename T>
T harmonic_error(const Harmonic& h, const T* p, const T& q) {
  using std::cos;
  using std::sin;
  T sum(0);
  for (size_t i = 0; i < h.frequencies.size(); ++i) {
    const T u = T(h.frequencies[i]) * q;
    sum += p[2 * i] * sin(u) + p[2 * i + 1] * (cos(u) - T(1));
  }
  return sum;
}

template <typename T>
T Transmission::error(const T* params, const T& q) const {
  struct Visitor {
    const T* p;
    const T& q;
    T operator()(const std::monostate&) const { return T(0); }
    T operator()(const Capstan& c) const { return capstan_error(c, p, q); }
    T operator()(const Parallelogram&) const { return parallelogram_error(p, q); }
    T operator()(const Polynomial& poly) const { return polynomial_error(poly, p, q); }
    T operator()(const Harmonic& h) const { return harmonic_error(h, p, q); }
    T operator()(const Extension& e) const {
      if constexpr (std::is_same_v<T, double>) {
        return e.definition->error(p, q);
      } else {
        static_cast<void>(e);
        throw std::logic_error("an extension transmission is evaluated in double only");
      }
    }
    T operator()(const Chain& chain) const {
      T x = q;
      const T* stage_params = p;
      for (const Transmission& stage : chain.stages) {
        x = x + stage.error(stage_params, x);
        stage_params += stage.num_parameters();
      }
      return x - q;
    }
  };
  return std::visit(Visitor{params, q}, model_);
}

// The transmission without a harmonic stage at its end (a bare Harmonic: none;
// a chain ending in one: its other stages): what step 1 fits and plots of a
// link whose model carries an earlier step 2's joint errors. Unchanged otherwise.
Transmission without_trailing_harmonic(const Transmission& t);

// Monomial coefficients k_0..k_n of a polynomial in q (a derived view of a
// Chebyshev fit, for printing as the paper does).
std::vector<double> monomial_coefficients(const Polynomial& poly);

// Derived constants for evaluating a transmission in a hot loop (1 kHz control,
// identification): home terms, phase sines and polynomial home values are
// computed once. Results equal Transmission::error to a few ulp.
class PreparedTransmission {
 public:
  PreparedTransmission() = default;
  explicit PreparedTransmission(const Transmission& transmission);
  double error(double q) const;
  // d dtheta / dq, equal to Transmission::derivative; allocates nothing.
  double derivative(double q) const;

  // Eq. (1) split so that a caller can batch its sines, cosines and arc
  // tangents over joints (PreparedModel does): with sin(q + b) expanded, the
  // error is slope q + atan(t_out) + atan(t_in) - home, where x = D - r cos u > 0
  // (check() demands |r| < D) makes atan(y / x) equal atan2(y, x).
  bool is_capstan() const { return kind_ == Kind::kCapstan; }
  double ratio() const { return ratio_; }
  void capstan_tangents(double sin_q, double cos_q, double sin_rq, double cos_rq, double& t_out,
                        double& t_in) const;
  double capstan_error(double q, double atan_out, double atan_in) const {
    return slope_ * q + atan_out + atan_in - home_;
  }

 private:
  enum class Kind { kNone, kCapstan, kPolynomial, kGeneric };

  Kind kind_ = Kind::kNone;
  Transmission generic_;
  // Capstan constants.
  double ratio_ = 1, drum_ = 0, slope_ = 0, home_ = 0;
  double r_out_ = 0, cos_bo_ = 1, sin_bo_ = 0;
  double r_in_ = 0, cos_bi_ = 1, sin_bi_ = 0;
  // Polynomial constants: x = scale q + shift maps the domain onto [-1, 1].
  Polynomial polynomial_;
  double polynomial_home_ = 0, scale_ = 1, shift_ = 0;
};

}  // namespace hapticcal
