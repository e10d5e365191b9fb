// Step 1 of the paper's procedure: a transmission model fitted to ext - q.
#include <ceres/ceres.h>
#include <fmt/format.h>

#include <Eigen/Dense>
#include <cmath>

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/identification.hpp"
#include "identification/capstan_cost.hpp"
#include "identification/solver_options.hpp"

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

void fit_capstan(const Capstan& nominal, const Eigen::VectorXd& q, const Eigen::VectorXd& target,
                 TransmissionFit& fit, Transmission& fitted) {
  std::array<double, 6> p = capstan_start(nominal, q, target);
  auto* cost = new CapstanCost(nominal, q, target);
  ceres::Problem problem;
  problem.AddResidualBlock(cost, nullptr, p.data());
  // Keep the eccentricities below the drum distance (eq. 1 needs |r| < D).
  for (int k : {1, 3}) {
    problem.SetParameterLowerBound(p.data(), k, -0.99 * nominal.drum_distance);
    problem.SetParameterUpperBound(p.data(), k, 0.99 * nominal.drum_distance);
  }
  ceres::Solver::Summary summary;
  ceres::Solve(detail::levenberg_marquardt(200), &problem, &summary);
  fit.converged = summary.termination_type == ceres::CONVERGENCE;
  fit.message = summary.message;
  // A negative radius is the same drum with the phase turned by pi.
  for (int k : {1, 3}) {
    if (p[k] < 0) {
      p[k] = -p[k];
      p[k + 1] += M_PI;
    }
    p[k + 1] = std::remainder(p[k + 1], 2 * M_PI);
  }
  const Capstan c = cost->with(p.data());
  fitted = Transmission(c);
  const int n = static_cast<int>(q.size());
  Eigen::VectorXd r(n);
  Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor> Jr(n, 6);
  double* jacobian[] = {Jr.data()};
  const double* params[] = {p.data()};
  cost->Evaluate(params, r.data(), jacobian);
  fit.value = Eigen::Map<const Eigen::VectorXd>(p.data(), 5);
  fit.offset = p[5];
  fit.rms_after = residual_rms(r);
  const Eigen::VectorXd sd = standard_deviations(Jr, r.squaredNorm() / std::max(n - 6, 1));
  fit.sd = sd.head(5);
  fit.offset_sd = sd[5];
}

void fit_polynomial(int order, const Eigen::VectorXd& q, const Eigen::VectorXd& target,
                    TransmissionFit& fit, Transmission& fitted) {
  Polynomial poly;
  poly.basis = PolynomialBasis::kChebyshev;
  poly.lower = q.minCoeff();
  poly.upper = q.maxCoeff();
  poly.coefficients.assign(order + 1, 0.0);
  const Transmission basis(poly);
  const int n = static_cast<int>(q.size());
  Eigen::MatrixXd A(n, order + 1);  // columns: c, then P_k(q) - P_k(0)
  Eigen::VectorXd row(order);
  for (int i = 0; i < n; ++i) {
    basis.parameter_jacobian(q[i], row.data());
    A(i, 0) = 1.0;
    A.block(i, 1, 1, order) = row.transpose();
  }
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
  if (qr.rank() < order + 1) {
    throw InputError(fmt::format("j{}: {} distinct readings cannot fix a polynomial of order {}",
                                 fit.joint + 1, qr.rank(), order));
  }
  const Eigen::VectorXd x = qr.solve(target);
  const Eigen::VectorXd r = A * x - target;
  fit.converged = true;
  fit.message = "linear least squares";
  fit.offset = x[0];
  fit.value = x.tail(order);
  fit.rms_after = residual_rms(r);
  const Eigen::VectorXd sd = standard_deviations(A, r.squaredNorm() / std::max(n - order - 1, 1));
  fit.offset_sd = sd[0];
  fit.sd = sd.tail(order);
  for (int k = 1; k <= order; ++k) poly.coefficients[k] = x[k];
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
  if (const auto* c = std::get_if<Capstan>(&link.transmission.model())) {
    fit.kind = TransmissionKind::kCapstan;
    fit.nominal = link.transmission.parameters();
    fit_capstan(*c, q, target, fit, fitted);
  } else if (link.transmission.is_none() ||
             std::holds_alternative<Polynomial>(link.transmission.model())) {
    const auto* p = std::get_if<Polynomial>(&link.transmission.model());
    const int n = order ? *order : (p ? p->order() : 10);
    if (n < 1 || n > 30) throw InputError(fmt::format("polynomial order {} (use 1 to 30)", n));
    fit.kind = TransmissionKind::kPolynomial;
    fit.nominal = Eigen::VectorXd::Zero(n);
    if (p && p->order() == n) fit.nominal = link.transmission.parameters();
    fit_polynomial(n, q, target, fit, fitted);
  } else {
    throw InputError(
        fmt::format("{}: a {} transmission cannot be identified (only one parallelogram length is, "
                    "Schroer et al.); declare the joint as a polynomial as the paper does",
                    link.name, link.transmission.type_name()));
  }
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
