// Model selection and cross-validation of step 2 (issue 12): which of the
// identifiable parameters the data support, and how well the fit predicts poses
// it has not seen. Both work on the problem linearised at a fit: the normal
// equations of every fold are formed once, and each model of the selection's
// path and each fold is then a small solve (a calibration stays within its 10 ms).
#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <numeric>
#include <optional>
#include <random>
#include <tuple>

#include "hapticcal/identification/identification.hpp"
#include "identification/problem/measurement_cost.hpp"
#include "identification/problem/stack.hpp"
#include "identification/search/held_out.hpp"

namespace hapticcal {
namespace {

using detail::rows_of;
using detail::RowsOf;
using detail::solve_normal;

constexpr double kInfinite = std::numeric_limits<double>::infinity();
// The selection's path is followed this many models past the one kept (for
// the record: the cross-validated error rising as supported parameters go).
constexpr int kRecordedBeyond = 3;

// Metres and radians made comparable as in analyze_identifiability: an angle
// column divided by the problem's length scale.
Eigen::VectorXd column_scale(const KinematicProblem& problem) {
  Eigen::VectorXd scale = Eigen::VectorXd::Ones(problem.model.structure().num_slots());
  for (const ParameterInfo& pi : problem.model.parameter_info()) {
    if (pi.unit == ParameterUnit::kAngle) scale[pi.slot] = problem.length_scale;
  }
  return scale;
}

std::vector<Eigen::Index> indices(const std::vector<int>& v) {
  return std::vector<Eigen::Index>(v.begin(), v.end());
}

// The identification problem linearised at a fit x: residuals r(x + dx / s) =
// r + A dx with A the Jacobian's columns of `columns` divided by their scale s,
// split into folds of poses. A model is a subset S of the columns fitted while
// the others (H) are moved by a given shift h (scaled units).
class LinearisedFolds {
 public:
  LinearisedFolds(const detail::Stack& at, const std::vector<int>& columns,
                  const Eigen::VectorXd& scale, const std::vector<int>& fold, int folds,
                  const RowsOf& kind)
      : r_(at.r), folds_(folds) {
    const int d = kind.dimension();
    A_.resize(at.J.rows(), static_cast<Eigen::Index>(columns.size()));
    for (size_t c = 0; c < columns.size(); ++c) {
      A_.col(static_cast<Eigen::Index>(c)) = at.J.col(columns[c]) / scale[columns[c]];
    }
    G_ = A_.transpose() * A_;
    g_ = A_.transpose() * r_;
    rows_.assign(folds, {});
    for (size_t i = 0; i < fold.size(); ++i) {
      for (int k = 0; k < d; ++k) rows_[fold[i]].push_back(static_cast<Eigen::Index>(i) * d + k);
    }
    for (int f = 0; f < folds; ++f) {
      const Eigen::MatrixXd Af = A_(rows_[f], Eigen::all);
      G_train_.push_back(G_ - Af.transpose() * Af);
      g_train_.push_back(g_ - Af.transpose() * r_(rows_[f]));
    }
    // The rows that measure a position or distance (a pose's rotation rows are
    // reported apart, as in KinematicFit::rms_after).
    measures_ = Eigen::VectorXd::Ones(r_.size());
    const int length_rows = traits(kind.type).length_rows;
    if (length_rows < d) {
      for (Eigen::Index i = 0; i < r_.size(); ++i) measures_[i] = i % d < length_rows ? 1.0 : 0.0;
    }
  }

  // Cross-validated sums of squares of model S (H shifted by h): every row,
  // and the measuring rows only. Infinite where a fold's other poses cannot
  // determine S.
  std::pair<double, double> cross_validated(const std::vector<int>& S, const std::vector<int>& H,
                                            const Eigen::VectorXd& h) const {
    const auto s = indices(S), held = indices(H);
    double all = 0, measuring = 0;
    for (int f = 0; f < folds_; ++f) {
      if (r_.size() - static_cast<Eigen::Index>(rows_[f].size()) <
          static_cast<Eigen::Index>(s.size()))
        return {kInfinite, kInfinite};  // fewer training rows than parameters
      const Eigen::VectorXd b = g_train_[f](s) + G_train_[f](s, held) * h;
      const std::optional<Eigen::VectorXd> x = solve_normal(G_train_[f](s, s), -b);
      if (!x) return {kInfinite, kInfinite};
      const Eigen::VectorXd e = r_(rows_[f]) + A_(rows_[f], held) * h + A_(rows_[f], s) * *x;
      all += e.squaredNorm();
      measuring += e.cwiseProduct(e).dot(measures_(rows_[f]));
    }
    return {all, measuring};
  }

  // The fit of S on every pose (H shifted by h): the step x, its residual sum
  // of squares, and (G_SS)^-1.
  struct Fit {
    Eigen::VectorXd x;
    double rss = 0;            // every row
    double measuring_rss = 0;  // the measuring rows
    Eigen::MatrixXd inverse;
  };
  Fit fit(const std::vector<int>& S, const std::vector<int>& H, const Eigen::VectorXd& h) const {
    const auto s = indices(S), held = indices(H);
    const double r_shifted =
        r_.squaredNorm() + 2 * h.dot(g_(held)) + h.dot(G_(held, held) * h);  // |r + A_H h|^2
    const Eigen::VectorXd b = g_(s) + G_(s, held) * h;
    Fit out;
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(G_(s, s));
    out.inverse = ldlt.solve(Eigen::MatrixXd::Identity(s.size(), s.size()));
    out.x = -out.inverse * b;
    out.rss = std::max(r_shifted + b.dot(out.x), 0.0);
    const Eigen::VectorXd e = r_ + A_(Eigen::all, held) * h + A_(Eigen::all, s) * out.x;
    out.measuring_rss = e.cwiseProduct(e).dot(measures_);
    return out;
  }

  Eigen::Index rows() const { return r_.size(); }

 private:
  Eigen::VectorXd r_, g_, measures_;
  Eigen::MatrixXd A_, G_;
  int folds_ = 0;
  std::vector<std::vector<Eigen::Index>> rows_;  // of each fold
  std::vector<Eigen::MatrixXd> G_train_;         // normal matrix without fold f
  std::vector<Eigen::VectorXd> g_train_;
};

// Positions 0..n-1 of `identified`, without those in `held_positions`.
std::vector<int> complement(int n, const std::vector<int>& held_positions) {
  std::vector<int> out;
  for (int i = 0; i < n; ++i) {
    if (std::find(held_positions.begin(), held_positions.end(), i) == held_positions.end())
      out.push_back(i);
  }
  return out;
}

}  // namespace

namespace detail {

std::vector<int> pose_units(const KinematicProblem& problem) {
  const int m = static_cast<int>(problem.joints.size());
  const Eigen::Index n = problem.model.dof();
  std::vector<int> unit(static_cast<size_t>(m));
  int units = 0;
  for (int i = 0; i < m; ++i) {
    const bool same_pose =
        problem.tip && i > 0 && problem.joints[i].head(n) == problem.joints[i - 1].head(n);
    unit[i] = same_pose ? units - 1 : units++;
  }
  return unit;
}

std::vector<int> unit_folds(const KinematicProblem& problem, int folds, std::uint64_t seed) {
  const std::vector<int> unit = pose_units(problem);
  const int units = unit.empty() ? 0 : unit.back() + 1;
  const std::vector<int> of_unit = pose_folds(units, folds, seed);
  std::vector<int> fold(unit.size());
  for (size_t i = 0; i < unit.size(); ++i) fold[i] = of_unit[static_cast<size_t>(unit[i])];
  return fold;
}

}  // namespace detail

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

namespace {

// The regularised incomplete beta function I_x(a, b) by its continued fraction
// (DLMF 8.17.22, evaluated by the modified Lentz method), with the symmetry
// I_x(a, b) = 1 - I_{1-x}(b, a) where the fraction converges slowly.
double incomplete_beta(double x, double a, double b) {
  if (x <= 0) return 0;
  if (x >= 1) return 1;
  if (x > (a + 1) / (a + b + 2)) return 1 - incomplete_beta(1 - x, b, a);
  const double front = std::exp(std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) +
                                a * std::log(x) + b * std::log1p(-x)) /
                       a;
  constexpr double tiny = 1e-300;
  double c = 1, d = 1 - (a + b) * x / (a + 1);
  d = 1 / (std::abs(d) < tiny ? tiny : d);
  double f = d;
  for (int m = 1; m < 500; ++m) {
    for (int half = 0; half < 2; ++half) {
      const double numerator = half == 0
                                   ? m * (b - m) * x / ((a + 2 * m - 1) * (a + 2 * m))
                                   : -(a + m) * (a + b + m) * x / ((a + 2 * m) * (a + 2 * m + 1));
      d = 1 + numerator * d;
      d = 1 / (std::abs(d) < tiny ? tiny : d);
      c = 1 + numerator / c;
      if (std::abs(c) < tiny) c = tiny;
      f *= c * d;
      if (half == 1 && std::abs(c * d - 1) < 1e-15) return front * f;
    }
  }
  return front * f;
}

}  // namespace

double student_t_tail(double t, double dof) {
  // P(|T| > t) = I_{nu / (nu + t^2)}(nu / 2, 1 / 2).
  return incomplete_beta(dof / (dof + t * t), dof / 2, 0.5);
}

double significance_threshold(double alpha, int parameters, double dof) {
  if (!(dof >= 1)) return kInfinite;  // no residual freedom: nothing is significant
  // The model search asks for the same few thresholds many times (each fold's
  // elimination): remembered per thread.
  thread_local std::map<std::tuple<double, int, double>, double> known;
  const auto key = std::make_tuple(alpha, parameters, dof);
  if (const auto it = known.find(key); it != known.end()) return it->second;
  if (known.size() > 100000) known.clear();
  // P(|T| > t) = alpha / k, by bisection on x = nu / (nu + t^2) in (0, 1],
  // until the midpoint is one of the ends (lo and hi adjacent doubles: further
  // halvings would change nothing).
  const double p = alpha / std::max(parameters, 1);
  double lo = 0, hi = 1;
  for (int i = 0; i < 200; ++i) {
    const double x = 0.5 * (lo + hi);
    if (x == lo || x == hi) break;
    (incomplete_beta(x, dof / 2, 0.5) < p ? lo : hi) = x;
  }
  const double x = 0.5 * (lo + hi);
  return known[key] = std::sqrt(dof * (1 - x) / x);
}

namespace detail {

ModelSelection select_model(const KinematicProblem& problem, const std::vector<int>& identified,
                            const Eigen::VectorXd& solution, const Stack& at, double alpha,
                            int folds, std::uint64_t seed) {
  const RowsOf kind = rows_of(problem);
  const int m = static_cast<int>(problem.joints.size());
  const int n = static_cast<int>(identified.size());
  const Eigen::VectorXd start = problem.model.kinematic_parameters();
  const Eigen::VectorXd scale = column_scale(problem);
  std::map<int, std::string> name;
  for (const ParameterInfo& pi : problem.model.parameter_info()) name[pi.slot] = pi.name;
  const int units = m == 0 ? 0 : pose_units(problem).back() + 1;
  const int k_folds = std::clamp(folds, 2, std::max(units, 2));
  const LinearisedFolds system(at, identified, scale, unit_folds(problem, k_folds, seed), k_folds,
                               kind);
  // A held parameter goes back to its start value: in scaled units, h.
  Eigen::VectorXd back(n);
  for (int c = 0; c < n; ++c)
    back[c] = scale[identified[c]] * (start[identified[c]] - solution[identified[c]]);
  const double rows = std::max(problem.rows, 1);

  ModelSelection out;
  std::vector<int> held;  // positions in `identified`, in order of removal
  int beyond = -1;        // steps taken past the chosen model (-1: not found yet)
  while (beyond < kRecordedBeyond) {
    const std::vector<int> model = complement(n, held);
    const Eigen::VectorXd h = back(indices(held));
    SelectionStep step;
    step.parameters = static_cast<int>(model.size());
    step.cv_rms = std::sqrt(system.cross_validated(model, held, h).second / rows);
    const LinearisedFolds::Fit fit = system.fit(model, held, h);
    step.rms = std::sqrt(fit.measuring_rss / rows);
    if (model.empty()) {
      out.path.push_back(step);
      break;
    }
    // The parameter whose change from its start is the fewest standard
    // deviations is the candidate to hold next.
    const double dof = static_cast<double>(system.rows() - step.parameters -
                                           problem.labels.unknowns());  // a fixture's unknowns
    const double sigma = std::sqrt(fit.rss / std::max(dof, 1.0));
    int weakest = 0;
    double weakest_t = kInfinite;
    for (int c = 0; c < step.parameters; ++c) {
      const double change = -back[model[c]] + fit.x[c];
      const double sd = sigma * std::sqrt(std::max(fit.inverse(c, c), 0.0));
      const double t = sd > 0 ? std::abs(change) / sd : kInfinite;
      if (t < weakest_t) {
        weakest_t = t;
        weakest = c;
      }
    }
    step.threshold = significance_threshold(alpha, step.parameters, dof);
    step.removed = name.at(identified[model[weakest]]);
    step.removed_t = weakest_t;
    out.path.push_back(step);
    held.push_back(model[weakest]);
    // The first model whose weakest parameter is significant is the one kept.
    if (beyond < 0 && weakest_t >= step.threshold) {
      out.chosen = static_cast<int>(out.path.size()) - 1;
      beyond = 0;
    } else if (beyond >= 0) {
      ++beyond;
    }
  }
  if (beyond < 0) out.chosen = static_cast<int>(out.path.size()) - 1;  // down to none
  for (int c : complement(n, std::vector<int>(held.begin(), held.begin() + out.chosen)))
    out.kept.push_back(identified[c]);
  for (int i = 0; i < out.chosen; ++i) {
    out.reason[identified[held[i]]] = fmt::format(
        "not supported by these data (model selection): its change from nominal, {:.2f} sd, is "
        "below the threshold of {:.2f} sd ({:g} % family-wise over the {} parameters then "
        "fitted)",
        out.path[i].removed_t, out.path[i].threshold, alpha * 100, out.path[i].parameters);
  }
  return out;
}

CrossValidation cross_validate(const KinematicProblem& problem, const std::vector<int>& identified,
                               const Stack& at, int folds, std::uint64_t seed) {
  CrossValidation out;
  const int m = static_cast<int>(problem.joints.size());
  if (problem.compressed) {
    out.note = "not computed: the log is too long for per-pose fits (compressed Jacobian)";
    return out;
  }
  if (problem.labelled()) {
    out.note =
        "not computed for fixture logs (a held-out pose's point or plane comes from the other "
        "poses): evaluate the model on a fixture placement left out of the fit instead";
    return out;
  }
  const int units = m == 0 ? 0 : pose_units(problem).back() + 1;  // poses (a tree's: not tips)
  if (units < 2 || folds < 2) {
    out.note = units < 2 ? "not computed: fewer than two poses" : "not computed (folds < 2)";
    return out;
  }
  out.folds = std::min(folds, units);
  const RowsOf kind = rows_of(problem);
  const LinearisedFolds system(at, identified, column_scale(problem),
                               unit_folds(problem, out.folds, seed), out.folds, kind);
  std::vector<int> all(identified.size());
  std::iota(all.begin(), all.end(), 0);
  const double rss = system.cross_validated(all, {}, Eigen::VectorXd()).second;
  if (!std::isfinite(rss)) {
    out.note = fmt::format(
        "not computable: a fold's other poses ({} of {}) cannot determine the {} parameters",
        m - (m + out.folds - 1) / out.folds, m, identified.size());
    return out;
  }
  out.rms = std::sqrt(rss / std::max(problem.rows, 1));
  return out;
}

}  // namespace detail
}  // namespace hapticcal
