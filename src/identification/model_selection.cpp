// Model selection and cross-validation of step 2 (issue 12): which of the
// identifiable parameters the data support, and how well the fit predicts poses
// it has not seen.
#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>
#include <optional>
#include <random>

#include "hapticcal/identification/identification.hpp"
#include "identification/measurement_cost.hpp"
#include "identification/stack.hpp"

namespace hapticcal {
namespace {

using detail::RowMatrix;
using detail::RowsOf;

constexpr double kInfinite = std::numeric_limits<double>::infinity();

// Metres and radians made comparable as in analyze_identifiability: an angle
// column divided by the problem's length scale.
Eigen::VectorXd column_scale(const KinematicProblem& problem) {
  Eigen::VectorXd scale = Eigen::VectorXd::Ones(problem.model.structure().num_slots());
  for (const ParameterInfo& pi : problem.model.parameter_info()) {
    if (pi.unit == ParameterUnit::kAngle) scale[pi.slot] = problem.length_scale;
  }
  return scale;
}

// The least-squares solution of A x = b, or nothing if A's columns are
// (numerically) dependent: then the rows cannot determine the parameters.
std::optional<Eigen::VectorXd> least_squares(const Eigen::MatrixXd& A, const Eigen::VectorXd& b) {
  if (A.cols() == 0) return Eigen::VectorXd();
  if (A.rows() < A.cols()) return std::nullopt;
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
  qr.setThreshold(1e-10);
  if (qr.rank() < A.cols()) return std::nullopt;
  return Eigen::VectorXd(qr.solve(b));
}

// Row indices (d rows a pose) of the poses in fold f (`in`) or in the others.
std::vector<Eigen::Index> fold_rows(const std::vector<int>& fold, int f, bool in, int d) {
  std::vector<Eigen::Index> rows;
  for (size_t i = 0; i < fold.size(); ++i) {
    if ((fold[i] == f) != in) continue;
    for (int k = 0; k < d; ++k) rows.push_back(static_cast<Eigen::Index>(i) * d + k);
  }
  return rows;
}

// The poses of fold f (`in`) or of the others, as a problem of their own.
KinematicProblem fold_problem(const KinematicProblem& problem, const std::vector<int>& fold, int f,
                              bool in) {
  KinematicProblem sub = problem;
  sub.joints.clear();
  std::vector<int> poses;
  for (size_t i = 0; i < fold.size(); ++i) {
    if ((fold[i] == f) == in) poses.push_back(static_cast<int>(i));
  }
  sub.measured.resize(static_cast<Eigen::Index>(poses.size()), problem.measured.cols());
  if (problem.weights.size() > 0) sub.weights.resize(static_cast<Eigen::Index>(poses.size()));
  sub.rows = 0;
  for (size_t k = 0; k < poses.size(); ++k) {
    const int i = poses[k];
    sub.joints.push_back(problem.joints[i]);
    sub.measured.row(static_cast<Eigen::Index>(k)) = problem.measured.row(i);
    const double w = problem.weights.size() > 0 ? problem.weights[i] : 1.0;
    if (problem.weights.size() > 0) sub.weights[static_cast<Eigen::Index>(k)] = w;
    sub.rows += static_cast<int>(std::lround(w * w));
  }
  sub.compressed = false;
  return sub;
}

}  // namespace

std::vector<int> pose_folds(int poses, int folds, std::uint64_t seed) {
  std::vector<int> order(std::max(poses, 0));
  std::iota(order.begin(), order.end(), 0);
  // Fisher-Yates on the raw 64-bit draws (std::shuffle differs between
  // standard libraries).
  std::mt19937_64 rng(seed ^ 0x5eed'f01d'c0ffee11ull);
  for (int i = poses - 1; i > 0; --i) {
    const auto j = static_cast<int>(rng() % static_cast<std::uint64_t>(i + 1));
    std::swap(order[i], order[j]);
  }
  std::vector<int> fold(order.size());
  for (size_t k = 0; k < order.size(); ++k)
    fold[order[k]] = static_cast<int>(k) % std::max(folds, 1);
  return fold;
}

double significance_threshold(double alpha, int parameters) {
  // Two-sided normal quantile 1 - alpha / (2 k) by bisection on erfc.
  const double tail = alpha / (2.0 * std::max(parameters, 1));
  double lo = 0, hi = 40;
  for (int i = 0; i < 200; ++i) {
    const double z = 0.5 * (lo + hi);
    (0.5 * std::erfc(z / std::numbers::sqrt2) > tail ? lo : hi) = z;
  }
  return 0.5 * (lo + hi);
}

ModelSelection select_model(const KinematicProblem& problem, const std::vector<int>& identified,
                            const Eigen::VectorXd& solution, double alpha, int folds,
                            std::uint64_t seed) {
  const ChainStructure s = problem.model.structure();
  const RowsOf kind{problem.type, problem.rotation_scale};
  const int d = kind.dimension();
  const int m = static_cast<int>(problem.joints.size());
  const detail::Stack at =
      detail::stack(s, solution, problem.joints, kind, problem.measured, problem.weights);
  const Eigen::VectorXd start = problem.model.kinematic_parameters();
  const Eigen::VectorXd scale = column_scale(problem);
  std::map<int, std::string> name;
  for (const ParameterInfo& pi : problem.model.parameter_info()) name[pi.slot] = pi.name;

  const int k_folds = std::clamp(folds, 2, std::max(m, 2));
  const std::vector<int> fold = pose_folds(m, k_folds, seed);
  std::vector<std::vector<Eigen::Index>> train(k_folds), test(k_folds);
  for (int f = 0; f < k_folds; ++f) {
    train[f] = fold_rows(fold, f, false, d);
    test[f] = fold_rows(fold, f, true, d);
  }
  const double rows = std::max(problem.rows, 1);

  ModelSelection out;
  std::vector<int> model = identified;  // the current model's slots
  std::vector<int> removed;             // in order of removal
  while (true) {
    // Linearised at the full fit: a held parameter is moved back to its start
    // value, and the model's parameters fitted to what that leaves.
    Eigen::VectorXd r = at.r;
    for (int slot : identified) {
      if (std::find(model.begin(), model.end(), slot) == model.end())
        r += at.J.col(slot) * (start[slot] - solution[slot]);
    }
    const auto k = static_cast<Eigen::Index>(model.size());
    Eigen::MatrixXd A(at.J.rows(), k);
    for (Eigen::Index c = 0; c < k; ++c) A.col(c) = at.J.col(model[c]) / scale[model[c]];
    double cv_rss = 0;
    for (int f = 0; f < k_folds && std::isfinite(cv_rss); ++f) {
      const std::optional<Eigen::VectorXd> x = least_squares(A(train[f], Eigen::all), -r(train[f]));
      if (!x) {
        cv_rss = kInfinite;
        break;
      }
      cv_rss += (r(test[f]) + A(test[f], Eigen::all) * *x).squaredNorm();
    }
    SelectionStep step;
    step.parameters = static_cast<int>(k);
    step.cv_rms = std::sqrt(cv_rss / rows);
    if (k == 0) {
      step.rms = std::sqrt(r.squaredNorm() / rows);
      out.path.push_back(step);
      break;
    }
    // The fit on every pose; the parameter whose change from its start is the
    // fewest standard deviations is held next.
    Eigen::HouseholderQR<Eigen::MatrixXd> qr(A);
    const Eigen::MatrixXd R = qr.matrixQR().topLeftCorner(k, k).triangularView<Eigen::Upper>();
    const Eigen::VectorXd x =
        R.triangularView<Eigen::Upper>().solve((qr.householderQ().transpose() * -r).head(k));
    const Eigen::MatrixXd R_inverse =
        R.triangularView<Eigen::Upper>().solve(Eigen::MatrixXd::Identity(k, k));
    const double sigma = std::sqrt((r + A * x).squaredNorm() /
                                   static_cast<double>(std::max<Eigen::Index>(at.J.rows() - k, 1)));
    step.rms = std::sqrt((r + A * x).squaredNorm() / rows);
    int weakest = 0;
    double weakest_t = kInfinite;
    for (Eigen::Index c = 0; c < k; ++c) {
      const int slot = model[c];
      const double change = scale[slot] * (solution[slot] - start[slot]) + x[c];
      const double sd = sigma * R_inverse.row(c).norm();
      const double t = sd > 0 ? std::abs(change) / sd : kInfinite;
      if (t < weakest_t || (std::isnan(t) && weakest_t == kInfinite)) {
        weakest_t = t;
        weakest = static_cast<int>(c);
      }
    }
    step.threshold = significance_threshold(alpha, static_cast<int>(k));
    step.removed = name.at(model[weakest]);
    step.removed_t = weakest_t;
    out.path.push_back(step);
    removed.push_back(model[weakest]);
    model.erase(model.begin() + weakest);
  }
  // The first model whose weakest parameter is significant.
  while (out.chosen + 1 < static_cast<int>(out.path.size()) &&
         out.path[out.chosen].removed_t < out.path[out.chosen].threshold) {
    ++out.chosen;
  }
  const std::vector<int> held(removed.begin(), removed.begin() + out.chosen);
  for (int slot : identified) {
    if (std::find(held.begin(), held.end(), slot) == held.end()) out.kept.push_back(slot);
  }
  for (int i = 0; i < out.chosen; ++i) {
    out.reason[removed[i]] = fmt::format(
        "not supported by these data (model selection): its change from nominal, {:.2f} sd, is "
        "below the threshold of {:.2f} sd (5 % family-wise over the {} parameters then fitted)",
        out.path[i].removed_t, out.path[i].threshold, out.path[i].parameters);
  }
  return out;
}

CrossValidation cross_validate(const KinematicProblem& problem, const std::vector<int>& identified,
                               int folds, std::uint64_t seed) {
  CrossValidation out;
  const int m = static_cast<int>(problem.joints.size());
  if (problem.compressed) {
    out.note = "not computed: the log is too long for per-pose fits (compressed Jacobian)";
    return out;
  }
  if (m < 2 || folds < 2) {
    out.note = m < 2 ? "not computed: fewer than two poses" : "not computed (folds < 2)";
    return out;
  }
  out.folds = std::min(folds, m);
  const ChainStructure s = problem.model.structure();
  const RowsOf kind{problem.type, problem.rotation_scale};
  const Eigen::VectorXd scale = column_scale(problem);
  const std::vector<int> fold = pose_folds(m, out.folds, seed);
  const auto k = static_cast<Eigen::Index>(identified.size());
  double rss = 0;
  for (int f = 0; f < out.folds; ++f) {
    const KinematicProblem train = fold_problem(problem, fold, f, false);
    const KinematicProblem test = fold_problem(problem, fold, f, true);
    // The other folds' poses must determine the parameters on their own.
    const detail::Stack at = detail::stack(s, train.model.kinematic_parameters(), train.joints,
                                           kind, train.measured, train.weights);
    Eigen::MatrixXd A(at.J.rows(), k);
    for (Eigen::Index c = 0; c < k; ++c) A.col(c) = at.J.col(identified[c]) / scale[identified[c]];
    if (!least_squares(A, Eigen::VectorXd::Zero(A.rows()))) {
      out.note = fmt::format(
          "not computable: {} poses (a fold's training set) cannot determine the {} parameters",
          train.joints.size(), k);
      return out;
    }
    const KinematicSolution fit = solve_kinematics(train, identified);
    rss += detail::position_rss(
        detail::residuals_at(s, fit.parameters, test.joints, kind, test.measured, test.weights),
        kind);
  }
  out.rms = std::sqrt(rss / std::max(problem.rows, 1));
  return out;
}

}  // namespace hapticcal
