// Step 1 of the paper's procedure: a transmission model fitted to ext - q.
#include <ceres/ceres.h>
#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <optional>

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/identification.hpp"
#include "identification/problem/capstan_cost.hpp"
#include "identification/problem/solver_options.hpp"

namespace hapticcal {
namespace {

using detail::CapstanCost;

double residual_rms(const Eigen::VectorXd& r) { return std::sqrt(r.squaredNorm() / r.size()); }

// Standard deviations sqrt(diag(s^2 (A^T A)^-1)) with s^2 the residual variance,
// through the SVD of A (robust when A is ill-conditioned).
Eigen::VectorXd standard_deviations(const Eigen::MatrixXd& A, double residual_variance) {
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeThinV);
  const Eigen::VectorXd s = svd.singularValues();
  Eigen::VectorXd sd = Eigen::VectorXd::Zero(A.cols());
  for (int k = 0; k < A.cols(); ++k) {
    double v = 0;
    for (int j = 0; j < s.size(); ++j) {
      v += s[j] > 0 ? std::pow(svd.matrixV()(k, j) / s[j], 2) : INFINITY;
    }
    sd[k] = std::sqrt(residual_variance * v);
  }
  return sd;
}

// First-order expansion of eq. (1) in r/D: ext - q ~ c' + s q + Ao sin q +
// Bo cos q + Ai sin Rq + Bi cos Rq with Ao + i Bo = (ro / D) e^(i bo). Linear,
// so it starts LM near the right phases without a search.
std::array<double, 6> capstan_start(const Capstan& c, const Eigen::VectorXd& q,
                                    const Eigen::VectorXd& target) {
  const int n = static_cast<int>(q.size());
  Eigen::MatrixXd A(n, 6);
  for (int i = 0; i < n; ++i) {
    const double rq = c.ratio * q[i];
    A.row(i) << 1.0, q[i], std::sin(q[i]), std::cos(q[i]), std::sin(rq), std::cos(rq);
  }
  const Eigen::VectorXd x = A.colPivHouseholderQr().solve(target);
  const double D = c.drum_distance;
  const double s = x[1];
  const double ro = std::min(D * std::hypot(x[2], x[3]), 0.5 * D);
  const double ri = std::min(D * std::hypot(x[4], x[5]), 0.5 * D);
  const double bo = std::atan2(x[3], x[2]), bi = std::atan2(x[5], x[4]);
  const double Re = -s * c.ratio / (1 + s);
  return {Re, ro, bo, ri, bi, x[0] + x[3] + x[5]};
}

// Leave-one-out RMS of a least-squares fit with design (or Jacobian) A and
// residuals r (PRESS, Allen 1974): each sample's residual had it been left
// out, r_i / (1 - h_ii), h_ii the leverage (the hat matrix's diagonal, from a
// thin QR of A). For a nonlinear fit, the same at the solution (linearised).
// Infinite where a sample alone fixes a parameter (h_ii = 1).
double leave_one_out_rms(const Eigen::MatrixXd& A, const Eigen::VectorXd& r) {
  const Eigen::Index n = A.rows(), p = A.cols();
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(A);
  const Eigen::MatrixXd Q = qr.householderQ() * Eigen::MatrixXd::Identity(n, p);
  double sum = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const double h = Q.row(i).squaredNorm();
    if (h > 1 - 1e-9) return INFINITY;
    sum += std::pow(r[i] / (1 - h), 2);
  }
  return std::sqrt(sum / static_cast<double>(n));
}

// Generalised cross-validation (Golub, Heath & Wahba 1979): the leave-one-out
// error with every sample at the mean leverage p / n, RMS(r) / (1 - p / n).
// Step 1 chooses by it, not by PRESS: one sample of leverage near 1 (a reading
// alone at the end of a joint's range) makes PRESS explode for every model
// that can bend there, and the choice fall to an order that cannot follow the
// transmission (a random 30-pose design: order 3 instead of 9, the calibrated
// distances 2.5 times worse).
double generalised_cv_rms(const Eigen::VectorXd& r, Eigen::Index parameters) {
  const double n = static_cast<double>(r.size());
  if (static_cast<double>(parameters) >= n) return INFINITY;
  return std::sqrt(r.squaredNorm() / n) / (1 - static_cast<double>(parameters) / n);
}

// The most coefficients (the encoder zero c included) n samples support.
int supported_parameters(int n) { return n / kStepOneSamplesPerParameter; }

// A capstan's variants, from eq. (1) whole to the ratio error alone: which of
// the eccentricities [ro, bo] (slots 1, 2) and [ri, bi] (3, 4) are kept.
struct CapstanVariant {
  const char* label;
  bool outer, inner;
};
constexpr CapstanVariant kCapstanVariants[] = {{"eccentric drums", true, true},
                                               {"eccentric output drum", true, false},
                                               {"eccentric input drum", false, true},
                                               {"ratio error only", false, false}};

struct CapstanSolve {
  std::array<double, 6> p{};
  Eigen::VectorXd r;
  Eigen::MatrixXd J;  // the kept parameters' columns
  std::vector<int> kept;
  bool converged = false;
  std::string message;
};

CapstanSolve solve_capstan(const Capstan& nominal, const Eigen::VectorXd& q,
                           const Eigen::VectorXd& target, const CapstanVariant& variant) {
  CapstanSolve out;
  out.p = capstan_start(nominal, q, target);
  // Slots 1, 2 the output drum's, 3, 4 the input drum's; 0 (Re) and 5 (c) always.
  std::vector<int> held;
  for (int k = 0; k < 6; ++k) {
    const bool kept = k == 0 || k == 5 || (k <= 2 ? variant.outer : variant.inner);
    (kept ? out.kept : held).push_back(k);
  }
  for (int k : held) out.p[k] = 0;
  auto* cost = new CapstanCost(nominal, q, target);
  ceres::Problem problem;
  problem.AddResidualBlock(cost, nullptr, out.p.data());
  if (!held.empty()) problem.SetManifold(out.p.data(), new ceres::SubsetManifold(6, held));
  // Keep the eccentricities below the drum distance (eq. 1 needs |r| < D).
  for (int k : {1, 3}) {
    problem.SetParameterLowerBound(out.p.data(), k, -0.99 * nominal.drum_distance);
    problem.SetParameterUpperBound(out.p.data(), k, 0.99 * nominal.drum_distance);
  }
  ceres::Solver::Summary summary;
  detail::solve(detail::levenberg_marquardt(200), &problem, &summary);
  out.converged = summary.termination_type == ceres::CONVERGENCE;
  out.message = summary.message;
  // A negative radius is the same drum with the phase turned by pi.
  for (int k : {1, 3}) {
    if (out.p[k] < 0) {
      out.p[k] = -out.p[k];
      out.p[k + 1] += M_PI;
    }
    out.p[k + 1] = std::remainder(out.p[k + 1], 2 * M_PI);
  }
  const int n = static_cast<int>(q.size());
  out.r.resize(n);
  Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor> Jr(n, 6);
  double* jacobian[] = {Jr.data()};
  const double* params[] = {out.p.data()};
  cost->Evaluate(params, out.r.data(), jacobian);
  out.J.resize(n, static_cast<Eigen::Index>(out.kept.size()));
  for (size_t c = 0; c < out.kept.size(); ++c)
    out.J.col(static_cast<Eigen::Index>(c)) = Jr.col(out.kept[c]);
  return out;
}

// Eq. (1) by Levenberg-Marquardt in each variant the samples support (at
// least kStepOneSamplesPerParameter a parameter); the one of least
// generalised cross-validation error is kept (the held eccentricities stay
// zero, sd 0).
void fit_capstan(const Capstan& nominal, const Eigen::VectorXd& q, const Eigen::VectorXd& target,
                 TransmissionFit& fit, Transmission& fitted) {
  const int n = static_cast<int>(q.size());
  if (supported_parameters(n) < 2) {
    throw InputError(fmt::format(
        "j{}: {} samples support no capstan model (step 1 needs at least {} samples a parameter: "
        "{} for the ratio error and the encoder zero)",
        fit.joint + 1, n, kStepOneSamplesPerParameter, 2 * kStepOneSamplesPerParameter));
  }
  std::optional<CapstanSolve> best;
  double best_gcv = INFINITY;
  for (const CapstanVariant& variant : kCapstanVariants) {
    const int parameters = 2 + 2 * variant.outer + 2 * variant.inner;
    if (parameters > supported_parameters(n)) continue;
    CapstanSolve s = solve_capstan(nominal, q, target, variant);
    const double loo = leave_one_out_rms(s.J, s.r);
    const double gcv = generalised_cv_rms(s.r, parameters);
    fit.candidates.push_back({variant.label, parameters, loo, gcv});
    // A converged, finite fit over one that is not; then the least GCV.
    const bool usable = s.converged && std::isfinite(gcv);
    const bool best_usable = best && best->converged && std::isfinite(best_gcv);
    if (!best || (usable && !best_usable) || (usable == best_usable && gcv < best_gcv)) {
      best = std::move(s);
      best_gcv = gcv;
      fit.held_out_rms = loo;
      fit.model_choice = variant.label;
    }
  }
  const CapstanSolve& s = *best;
  fit.converged = s.converged;
  fit.message = s.message;
  fitted = Transmission(nominal);
  fitted.set_parameters(s.p.data());  // [Re, ro, bo, ri, bi]; c (p[5]) is the fit's
  fit.value = Eigen::Map<const Eigen::VectorXd>(s.p.data(), 5);
  fit.offset = s.p[5];
  fit.rms_after = residual_rms(s.r);
  const Eigen::Index kept = s.J.cols();
  const Eigen::VectorXd sd =
      standard_deviations(s.J, s.r.squaredNorm() / std::max<double>(n - kept, 1));
  Eigen::VectorXd all = Eigen::VectorXd::Zero(6);
  for (Eigen::Index c = 0; c < kept; ++c) all[s.kept[c]] = sd[c];
  fit.sd = all.head(5);
  fit.offset_sd = all[5];
}

// ext - q = c + dtheta(p, q) of a registered kind, the residual of each sample
// with its Jacobian [d dtheta / d p, 1] (the kind's own parameter_jacobian).
class ExtensionCost : public ceres::CostFunction {
 public:
  ExtensionCost(const Extension& e, const Eigen::VectorXd& q, const Eigen::VectorXd& target)
      : e_(e), q_(q), target_(target) {
    set_num_residuals(static_cast<int>(q.size()));
    mutable_parameter_block_sizes()->push_back(static_cast<int>(e.parameters.size()) + 1);
  }
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const double* p = parameters[0];
    const size_t n = e_.parameters.size();
    for (Eigen::Index i = 0; i < q_.size(); ++i) {
      residuals[i] = e_.definition->error(p, q_[i]) + p[n] - target_[i];
      if (jacobians && jacobians[0]) {
        double* row = jacobians[0] + i * static_cast<Eigen::Index>(n + 1);
        e_.definition->parameter_jacobian(p, q_[i], row);
        row[n] = 1;
      }
      if (!std::isfinite(residuals[i])) return false;
    }
    return true;
  }

 private:
  const Extension& e_;
  const Eigen::VectorXd& q_;
  const Eigen::VectorXd& target_;
};

// A registered kind by Levenberg-Marquardt from the device file's parameters
// (and the encoder zero from the mean), every parameter free.
void fit_extension(const Extension& nominal, const Eigen::VectorXd& q,
                   const Eigen::VectorXd& target, TransmissionFit& fit, Transmission& fitted) {
  const int n = static_cast<int>(q.size());
  const int parameters = static_cast<int>(nominal.parameters.size()) + 1;
  if (parameters > supported_parameters(n)) {
    throw InputError(fmt::format(
        "j{}: {} samples support no {} model (step 1 needs at least {} samples a parameter, the "
        "encoder zero included: {})",
        fit.joint + 1, n, nominal.definition->name(), kStepOneSamplesPerParameter,
        parameters * kStepOneSamplesPerParameter));
  }
  std::vector<double> p = nominal.parameters;
  p.push_back(target.mean());
  auto* cost = new ExtensionCost(nominal, q, target);
  ceres::Problem problem;
  problem.AddResidualBlock(cost, nullptr, p.data());
  ceres::Solver::Summary summary;
  detail::solve(detail::levenberg_marquardt(200), &problem, &summary);
  fit.converged = summary.termination_type == ceres::CONVERGENCE;
  fit.message = summary.message;
  Eigen::VectorXd r(n);
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> J(n, parameters);
  double* jacobian[] = {J.data()};
  const double* at[] = {p.data()};
  cost->Evaluate(at, r.data(), jacobian);
  const Eigen::MatrixXd A = J;
  fit.held_out_rms = leave_one_out_rms(A, r);
  fit.candidates.push_back({std::string(nominal.definition->name()), parameters, fit.held_out_rms,
                            generalised_cv_rms(r, parameters)});
  fit.model_choice = std::string(nominal.definition->name());
  fitted = Transmission(nominal);
  fitted.set_parameters(p.data());
  fit.value = Eigen::Map<const Eigen::VectorXd>(p.data(), parameters - 1);
  fit.offset = p.back();
  fit.rms_after = residual_rms(r);
  const Eigen::VectorXd sd =
      standard_deviations(A, r.squaredNorm() / std::max<double>(n - parameters, 1));
  fit.sd = sd.head(parameters - 1);
  fit.offset_sd = sd[parameters - 1];
}

// The polynomial of each order from 1 to `order` the samples support (at least
// kStepOneSamplesPerParameter a coefficient, c included), by linear least
// squares in a Chebyshev basis on the sampled range; the order of least
// generalised cross-validation error is kept. `exact` (--polynomial-order):
// that order alone, refused if the samples do not support it.
void fit_polynomial(int order, bool exact, const Eigen::VectorXd& q, const Eigen::VectorXd& target,
                    TransmissionFit& fit, Transmission& fitted) {
  const int n = static_cast<int>(q.size());
  const int top = std::min(order, step_one_supported_order(n));
  if (exact && top < order) {
    throw InputError(fmt::format(
        "--polynomial-order {}: j{}'s {} samples support order {} at most (step 1 needs at least "
        "{} samples a coefficient, the encoder zero counted)",
        order, fit.joint + 1, n, std::max(top, 0), kStepOneSamplesPerParameter));
  }
  if (top < 1) {
    throw InputError(fmt::format(
        "j{}: {} samples support no polynomial (step 1 needs at least {} samples a coefficient, "
        "the encoder zero counted: {} for order 1)",
        fit.joint + 1, n, kStepOneSamplesPerParameter, 2 * kStepOneSamplesPerParameter));
  }
  Polynomial poly;
  poly.basis = PolynomialBasis::kChebyshev;
  poly.lower = q.minCoeff();
  poly.upper = q.maxCoeff();
  poly.coefficients.assign(top + 1, 0.0);
  const Transmission basis(poly);
  Eigen::MatrixXd A(n, top + 1);  // columns: c, then P_k(q) - P_k(0)
  Eigen::VectorXd row(top);
  for (int i = 0; i < n; ++i) {
    basis.parameter_jacobian(q[i], row.data());
    A(i, 0) = 1.0;
    A.block(i, 1, 1, top) = row.transpose();
  }
  int chosen = 0;
  double best_gcv = INFINITY;
  Eigen::VectorXd x;
  for (int k = exact ? top : 1; k <= top; ++k) {
    const auto Ak = A.leftCols(k + 1);
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(Ak);
    if (qr.rank() < k + 1) {
      if (chosen == 0) {
        throw InputError(
            fmt::format("j{}: {} distinct readings cannot fix a polynomial of order {}",
                        fit.joint + 1, qr.rank(), k));
      }
      break;  // the readings cannot fix more coefficients
    }
    const Eigen::VectorXd xk = qr.solve(target);
    const Eigen::VectorXd rk = Ak * xk - target;
    const double loo = leave_one_out_rms(Ak, rk), gcv = generalised_cv_rms(rk, k + 1);
    fit.candidates.push_back({fmt::format("order {}", k), k + 1, loo, gcv});
    if (chosen == 0 || gcv < best_gcv) {
      chosen = k;
      x = xk;
      best_gcv = gcv;
      fit.held_out_rms = loo;
      fit.model_choice = fit.candidates.back().label;
    }
  }
  const auto Ac = A.leftCols(chosen + 1);
  const Eigen::VectorXd r = Ac * x - target;
  fit.converged = true;
  fit.message = "linear least squares";
  fit.offset = x[0];
  fit.value = x.tail(chosen);
  fit.rms_after = residual_rms(r);
  const Eigen::VectorXd sd = standard_deviations(Ac, r.squaredNorm() / std::max(n - chosen - 1, 1));
  fit.offset_sd = sd[0];
  fit.sd = sd.tail(chosen);
  poly.coefficients.assign(chosen + 1, 0.0);
  for (int k = 1; k <= chosen; ++k) poly.coefficients[k] = x[k];
  fitted = Transmission(poly);
  fit.monomial = monomial_coefficients(poly);
}

}  // namespace

Transmission fit_transmission(const DeviceModel& model, int joint, const Eigen::VectorXd& q,
                              const Eigen::VectorXd& ext, std::optional<int> order,
                              TransmissionFit& fit) {
  const Link& link = model.links[joint];
  fit.joint = joint;
  fit.n = static_cast<int>(q.size());
  const Eigen::VectorXd target = ext - q;
  if (q.maxCoeff() - q.minCoeff() <= 0) {
    throw InputError(
        fmt::format("q{}: the reading never moves, so its transmission cannot be "
                    "fitted",
                    joint + 1));
  }
  if (ext.maxCoeff() - ext.minCoeff() <= 0) {
    throw InputError(fmt::format("ext{}: the external encoder never moves", joint + 1));
  }
  const double mean = target.mean();
  fit.rms_before = residual_rms(target.array() - mean);
  Transmission fitted;
  fit.kind = link.transmission.is_none() ? TransmissionKind::kPolynomial : link.transmission.kind();
  const auto* p = std::get_if<Polynomial>(&link.transmission.model());
  if (const auto* c = std::get_if<Capstan>(&link.transmission.model())) {
    fit.nominal = link.transmission.parameters();
    fit_capstan(*c, q, target, fit, fitted);
  } else if (link.transmission.is_none() || p) {
    const int n = order ? *order : (p ? p->order() : 10);
    if (n < 1 || n > 30) throw InputError(fmt::format("polynomial order {} (use 1 to 30)", n));
    fit.requested_order = n;
    fit_polynomial(n, order.has_value(), q, target, fit, fitted);
    fit.nominal = Eigen::VectorXd::Zero(fit.value.size());
    if (p && p->order() == fit.value.size()) fit.nominal = link.transmission.parameters();
  } else if (const auto* e = std::get_if<Extension>(&link.transmission.model())) {
    fit.nominal = link.transmission.parameters();
    fit_extension(*e, q, target, fit, fitted);
  } else {
    throw InputError(
        fmt::format("{}: a {} transmission cannot be identified (only one parallelogram length is, "
                    "Schroer et al.); declare the joint as a polynomial as the paper does",
                    link.name, link.transmission.type_name()));
  }
  fit.type = fitted.type_name();
  fit.names.clear();
  for (const std::string& name : fitted.parameter_names())
    fit.names.push_back(link.name + "." + name);
  return fitted;
}

DisplayUnit display_unit(const std::string& parameter) {
  const std::string p = parameter.substr(parameter.rfind('.') + 1);
  if (p == "ratio_error") return {1, ""};
  if (p == "r_out" || p == "r_in" || (p.size() >= 2 && p[0] == 'L')) return {1e3, "mm"};
  if (p == "beta_out" || p == "beta_in") return {180 / M_PI, "deg"};
  return {1, "rad"};  // polynomial coefficients
}

DisplayUnit display_unit(const TransmissionFit& fit, int k) { return display_unit(fit.names[k]); }

DisplayUnit display_unit(ParameterUnit unit) {
  return {1e3, unit == ParameterUnit::kAngle ? "mrad" : "mm"};
}

}  // namespace hapticcal
