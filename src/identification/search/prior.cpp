// The tolerance prior's scale by the evidence (MacKay 1992, "Bayesian
// interpolation"; Bishop, Pattern Recognition and Machine Learning, sec. 3.5):
// the linearised problem's marginal likelihood as a function of the prior's
// weight lambda, with the noise sd at its optimum for each lambda.
#include "identification/search/prior.hpp"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <map>

#include "hapticcal/core/error.hpp"
#include "identification/families/family.hpp"

namespace hapticcal {
namespace detail {
namespace {

constexpr double kFree = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Grid of the evidence over log10(lambda): this many decades either side of
// the prior columns' mean curvature, in steps of kGridStep decades.
constexpr double kGridDecades = 10;
constexpr double kGridStep = 0.25;
// Rounds of evidence and MAP solve at most, and the relative change of lambda
// that ends them.
constexpr int kPriorRounds = 4;
constexpr double kLambdaSettled = 0.05;

// The problem in tolerance units u: a prior column's u_j = (x_j - x0_j) / t_j,
// a free column's u_j = (x_j - x_c,j) |J_j| (equilibrated); residuals
// r(u) = r_c + A (u - u_c), so E_D(u) = c0 - 2 b.u + u^T H u with b = H u_c - g.
// The free columns are eliminated once (their optimum for given prior columns:
// u_f = H_ff^-1 (b_f - H_fp u_p)), leaving E_D = c - 2 b_s.u_p + u_p^T S u_p with
// the Schur complement S = H_pp - H_pf H_ff^-1 H_fp, and S = V diag(d) V^T is
// decomposed once: for each lambda the MAP u_p = (S + lambda I)^-1 b_s, E_D,
// E_W = |u_p|^2 and log det(H + lambda P) = log det H_ff + sum log(d_i + lambda)
// cost O(k) (MacKay 1992, the evidence of a linear model in its eigenbasis).
class LinearModel {
 public:
  // From the normal equations of the columns (G = J^T J, g = J^T r, rr = |r|^2):
  // a prior column scaled by its tolerance, a free one to unit norm.
  LinearModel(const NormalEquations& ne, const Eigen::VectorXd& tolerance,
              const Eigen::VectorXd& deviation, double rows)
      : k_(static_cast<int>(ne.g.size())), rows_(rows) {
    Eigen::VectorXd units = Eigen::VectorXd::Ones(k_), uc = Eigen::VectorXd::Zero(k_);
    for (int c = 0; c < k_; ++c) {
      if (std::isfinite(tolerance[c])) {
        units[c] = tolerance[c];
        uc[c] = deviation[c] / tolerance[c];
        prior_.push_back(c);
      } else {
        if (ne.G(c, c) > 0) units[c] = 1 / std::sqrt(ne.G(c, c));
        free_.push_back(c);
      }
    }
    k_prior_ = static_cast<int>(prior_.size());
    units_ = units;
    uc_ = uc;
    const Eigen::MatrixXd H = units.asDiagonal() * ne.G * units.asDiagonal();
    const Eigen::VectorXd g = units.cwiseProduct(ne.g);
    const Eigen::VectorXd b = H * uc - g;
    const double c0 = ne.rr - 2 * uc.dot(g) + uc.dot(H * uc);
    const Eigen::MatrixXd Hpp = H(prior_, prior_), Hpf = H(prior_, free_);
    Eigen::MatrixXd S = Hpp;
    bs_ = b(prior_);
    c_ = c0;
    if (!free_.empty()) {
      const Eigen::LLT<Eigen::MatrixXd> llt(H(free_, free_));
      if (llt.info() != Eigen::Success) return;  // the free columns are singular
      log_det_free_ = 2 * Eigen::MatrixXd(llt.matrixL()).diagonal().array().log().sum();
      if (!std::isfinite(log_det_free_)) return;
      Hff_ = llt;
      bf_ = b(free_);
      Hfp_ = Hpf.transpose();
      const Eigen::MatrixXd X = llt.solve(Hfp_);  // H_ff^-1 H_fp
      const Eigen::VectorXd y = llt.solve(bf_);   // H_ff^-1 b_f
      S -= Hpf * X;
      bs_ -= Hpf * y;
      c_ -= bf_.dot(y);
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(0.5 * (S + S.transpose()));
    if (eig.info() != Eigen::Success) return;
    d_ = eig.eigenvalues().cwiseMax(0.0);
    V_ = eig.eigenvectors();
    beta_ = V_.transpose() * bs_;
    Hpp_diagonal_ = Hpp.diagonal();
    ok_ = true;
  }

  bool ok() const { return ok_; }
  int prior_columns() const { return k_prior_; }
  // Rows the noise is estimated from: less one a free column.
  double noise_rows() const { return rows_ - (k_ - k_prior_); }
  // Mean curvature of the prior columns: where lambda starts to matter.
  double curvature() const {
    const double sum = Hpp_diagonal_.sum();
    return k_prior_ > 0 && sum > 0 ? sum / k_prior_ : 1.0;
  }

  // The MAP of weight lambda and what the evidence needs of it.
  struct Solution {
    bool ok = false;
    double data_rss = 0;   // E_D: |r(u)|^2
    double prior_rss = 0;  // E_W: |u_prior|^2
    double log_det = 0;    // log det(H + lambda P)
  };
  Solution solve(double lambda) const {
    Solution s;
    if (!ok_) return s;
    const Eigen::ArrayXd shifted = d_.array() + lambda;
    if (!(shifted.minCoeff() > 0)) return s;
    const Eigen::ArrayXd w = beta_.array() / shifted;  // u_p in the eigenbasis
    s.data_rss =
        std::max(c_ - 2 * (beta_.array() * w).sum() + (d_.array() * w.square()).sum(), 0.0);
    s.prior_rss = w.square().sum();
    s.log_det = log_det_free_ + shifted.log().sum();
    s.ok = std::isfinite(s.log_det) && std::isfinite(s.data_rss);
    return s;
  }
  // Per column: 1 - lambda (H + lambda P)^-1_jj, how much the data (not the
  // prior) determine it (1 for a free column).
  Eigen::VectorXd data_share(double lambda) const {
    Eigen::VectorXd share = Eigen::VectorXd::Ones(k_);
    const Eigen::ArrayXd inverse = (d_.array() + lambda).inverse();
    for (int i = 0; i < k_prior_; ++i) {
      share[prior_[i]] = 1 - lambda * (V_.row(i).array().square() * inverse.transpose()).sum();
    }
    return share;
  }
  // The MAP's change of each column from the fit, in its own units.
  Eigen::VectorXd step(double lambda) const {
    Eigen::VectorXd u(k_);
    const Eigen::VectorXd up = V_ * (beta_.array() / (d_.array() + lambda)).matrix();
    u(prior_) = up;
    if (!free_.empty()) {
      const Eigen::VectorXd uf = Hff_.solve(bf_ - Hfp_ * up);
      u(free_) = uf;
    }
    return units_.cwiseProduct(u - uc_);
  }

  // The log evidence of weight lambda with the noise precision beta at its
  // optimum, beta = n / (E_D + lambda E_W), n the noise rows (constants dropped).
  double profile(double lambda, const Solution& s) const {
    const double n = noise_rows();
    const double beta = n / (s.data_rss + lambda * s.prior_rss);
    return 0.5 * k_prior_ * std::log(lambda) + 0.5 * n * std::log(beta) - 0.5 * s.log_det;
  }

 private:
  int k_ = 0, k_prior_ = 0;
  double rows_ = 0, c_ = 0, log_det_free_ = 0;
  bool ok_ = false;
  std::vector<Eigen::Index> prior_, free_;
  Eigen::LLT<Eigen::MatrixXd> Hff_;
  Eigen::MatrixXd Hfp_, V_;
  Eigen::VectorXd units_, uc_, bs_, bf_, d_, beta_, Hpp_diagonal_;
};

// Golden-section search for the maximum of f over [a, b].
template <class F>
double golden_maximum(F f, double a, double b) {
  const double ratio = (std::sqrt(5.0) - 1) / 2;
  double c = b - ratio * (b - a), d = a + ratio * (b - a);
  double fc = f(c), fd = f(d);
  for (int i = 0; i < 60 && b - a > 1e-6; ++i) {
    if (fc > fd) {
      b = d;
      d = c;
      fd = fc;
      c = b - ratio * (b - a);
      fc = f(c);
    } else {
      a = c;
      c = d;
      fc = fd;
      d = a + ratio * (b - a);
      fd = f(d);
    }
  }
  return fc > fd ? c : d;
}

}  // namespace

std::optional<PriorChoice> choose_prior(const Stack& at, const std::vector<int>& slots,
                                        const Eigen::VectorXd& tolerance,
                                        const Eigen::VectorXd& deviation, double rows,
                                        std::optional<double> scale) {
  if (at.r.size() == 0) return std::nullopt;  // a compressed stack
  const auto columns = std::vector<Eigen::Index>(slots.begin(), slots.end());
  NormalEquations ne;
  const Eigen::MatrixXd J = at.J(Eigen::all, columns);
  ne.G = J.transpose() * J;
  ne.g = J.transpose() * at.r;
  ne.rr = at.r.squaredNorm();
  return choose_prior(ne, tolerance, deviation, rows, scale);
}

std::optional<PriorChoice> choose_prior(const NormalEquations& ne, const Eigen::VectorXd& tolerance,
                                        const Eigen::VectorXd& deviation, double rows,
                                        std::optional<double> scale) {
  const LinearModel model(ne, tolerance, deviation, rows);
  if (model.prior_columns() == 0 || model.noise_rows() < 1 || !model.ok()) return std::nullopt;
  const auto evidence = [&](double log_lambda) {
    const double lambda = std::pow(10.0, log_lambda);
    const LinearModel::Solution s = model.solve(lambda);
    return s.ok ? model.profile(lambda, s) : -std::numeric_limits<double>::infinity();
  };
  PriorChoice out;
  const double centre = std::log10(model.curvature());
  if (!std::isfinite(centre)) return std::nullopt;  // tolerances beyond double's range
  double best = centre - kGridDecades, best_value = -std::numeric_limits<double>::infinity();
  const int points = static_cast<int>(2 * kGridDecades / kGridStep);
  for (int i = 0; i <= points; ++i) {
    const double x = centre - kGridDecades + i * kGridStep;
    const double value = evidence(x);
    if (std::isfinite(value)) out.curve.emplace_back(x, value);
    if (value > best_value) {
      best_value = value;
      best = x;
    }
  }
  if (!std::isfinite(best_value)) return std::nullopt;  // the free columns are singular
  double log_lambda = golden_maximum(evidence, best - kGridStep, best + kGridStep);
  if (scale) {
    // A given scale: lambda = sigma^2 / scale^2 with sigma at its optimum,
    // beta = (n - gamma) / E_D (MacKay's re-estimate), by fixed point.
    double lambda = std::pow(10.0, log_lambda);
    for (int i = 0; i < 200; ++i) {
      const LinearModel::Solution s = model.solve(lambda);
      if (!s.ok) return std::nullopt;
      const double gamma =
          model.data_share(lambda).sum() - (tolerance.size() - model.prior_columns());
      const double beta = std::max(model.noise_rows() - gamma, 1.0) / std::max(s.data_rss, 1e-300);
      const double next = 1 / (*scale * *scale * beta);
      const bool settled = std::abs(std::log(next / lambda)) < 1e-10;
      lambda = next;
      if (settled) break;
    }
    log_lambda = std::log10(lambda);
  }
  out.lambda = std::pow(10.0, log_lambda);
  const LinearModel::Solution s = model.solve(out.lambda);
  if (!s.ok) return std::nullopt;
  out.log_evidence = model.profile(out.lambda, s);
  // A given scale's sigma is its fixed point's (lambda = sigma^2 / scale^2).
  out.sigma = scale ? *scale * std::sqrt(out.lambda)
                    : std::sqrt((s.data_rss + out.lambda * s.prior_rss) / model.noise_rows());
  out.scale = scale ? *scale : out.sigma / std::sqrt(out.lambda);
  out.data_share = model.data_share(out.lambda);
  out.effective = out.data_share.sum();
  out.step = model.step(out.lambda);
  return out;
}

Stack with_prior_rows(const Stack& at, const Eigen::VectorXd& weight,
                      const Eigen::VectorXd& deviation) {
  std::vector<int> rows;
  for (int j = 0; j < weight.size(); ++j) {
    if (weight[j] > 0) rows.push_back(j);
  }
  Stack out = at;
  const Eigen::Index m = at.r.size(), n = static_cast<Eigen::Index>(rows.size());
  out.r.conservativeResize(m + n);
  out.J.conservativeResize(m + n, Eigen::NoChange);
  out.J.bottomRows(n).setZero();
  for (Eigen::Index i = 0; i < n; ++i) {
    const int j = rows[static_cast<size_t>(i)];
    out.r[m + i] = weight[j] * deviation[j];
    out.J(m + i, j) = weight[j];
  }
  out.rss = out.r.squaredNorm();
  return out;
}

}  // namespace detail

void add_tolerance(Tolerances& tolerances, const std::string& item) {
  const std::size_t eq = item.find('=');
  const std::string name = item.substr(0, eq);
  const std::string text = eq == std::string::npos ? "" : item.substr(eq + 1);
  char* end = nullptr;
  const double value = text.empty() ? 0 : std::strtod(text.c_str(), &end);
  if (eq == std::string::npos || name.empty() || text.empty() || *end != '\0' ||
      !(value > 0 && std::isfinite(value))) {
    throw InputError(fmt::format(
        "--tolerance '{}': expected NAME=SD with a positive SD in SI units (m, rad), NAME "
        "length, angle or a parameter such as j2.a",
        printable(item)));
  }
  if (name == "length") {
    tolerances.length = value;
  } else if (name == "angle") {
    tolerances.angle = value;
  } else {
    tolerances.by_name[name] = value;
  }
}

double Tolerances::family(std::string_view name) const {
  if (const auto it = by_family.find(std::string(name)); it != by_family.end()) return it->second;
  const detail::JointErrorFamily* f = detail::find_joint_error_family(name);
  return f ? f->tolerance() : std::numeric_limits<double>::infinity();
}

namespace detail {

Eigen::VectorXd slot_tolerances(const DeviceModel& model, const Tolerances& t) {
  const ChainStructure s = model.structure();
  Eigen::VectorXd out = Eigen::VectorXd::Constant(s.num_slots(), kFree);
  std::map<std::string, double> unused = t.by_name;
  for (const ParameterInfo& pi : model.parameter_info()) {
    if (const auto it = t.by_name.find(pi.name); it != t.by_name.end()) {
      out[pi.slot] = it->second;
      unused.erase(pi.name);
    } else if (pi.block == ParameterBlock::kLink) {
      out[pi.slot] = pi.unit == ParameterUnit::kAngle ? t.angle : t.length;
    } else if (pi.block == ParameterBlock::kJointError) {
      out[pi.slot] = t.family(pi.family);
    }
  }
  if (!unused.empty()) {
    throw InputError(fmt::format("--tolerance {}: the model has no such parameter",
                                 printable(unused.begin()->first)));
  }
  return out;
}

std::optional<PriorSolution> solve_with_prior(const KinematicProblem& problem,
                                              const std::vector<int>& slots,
                                              const Eigen::VectorXd& tolerance,
                                              const KinematicSolution& start, const Stack& at,
                                              double rows, std::optional<double> scale,
                                              int iterations, std::string& why_not) {
  const ChainStructure s = problem.model.structure();
  const Eigen::VectorXd centre = problem.model.kinematic_parameters();
  const auto columns = std::vector<Eigen::Index>(slots.begin(), slots.end());
  const Eigen::VectorXd t = tolerance(columns);
  PriorSolution out;
  out.solution = start;
  out.data = at;
  double previous = 0;
  for (int round = 0; round < kPriorRounds; ++round) {
    const Eigen::VectorXd deviation = (out.solution.parameters - centre)(columns);
    const std::optional<PriorChoice> choice =
        choose_prior(out.data, slots, t, deviation, rows, scale);
    if (!choice) {
      why_not =
          "the evidence cannot be formed (the free parameters are not determined, or "
          "no residual freedom is left)";
      return std::nullopt;
    }
    // Settled: the solution is that of the previous lambda, and so are the
    // figures reported with it.
    if (round > 0 && std::abs(std::log(choice->lambda / previous)) < kLambdaSettled) break;
    out.fit.scale = choice->scale;
    out.fit.sigma = choice->sigma;
    out.fit.log_evidence = choice->log_evidence;
    out.fit.effective_parameters = choice->effective;
    out.fit.curve = choice->curve;
    out.data_share = Eigen::VectorXd::Constant(s.num_slots(), kNaN);
    out.data_share(columns) = choice->data_share;
    previous = choice->lambda;
    out.fit.lambda = choice->lambda;
    out.weight = Eigen::VectorXd::Zero(s.num_slots());
    for (size_t c = 0; c < slots.size(); ++c) {
      if (std::isfinite(t[c])) out.weight[slots[c]] = std::sqrt(choice->lambda) / t[c];
    }
    KinematicProblem map = problem;
    map.model.set_kinematic_parameters(out.solution.parameters);
    map.prior_weight = out.weight;
    map.prior_centre = centre;
    out.solution = solve_kinematics(map, slots, iterations);
    out.fit.rounds = round + 1;
    if (out.solution.termination != SolveTermination::kConverged) {
      why_not = "its Levenberg-Marquardt did not converge (" + out.solution.message + ")";
      return std::nullopt;
    }
    out.data = stack(s, out.solution.parameters, problem.joints, rows_of(problem), problem.measured,
                     problem.weights);
  }
  out.fit.used = true;
  out.fit.scale_given = scale.has_value();
  out.fit.fitted = static_cast<int>(slots.size());
  return out;
}

}  // namespace detail
}  // namespace hapticcal
