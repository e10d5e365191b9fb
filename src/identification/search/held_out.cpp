// The honest held-out error of step 2's candidate models (held_out.hpp): each
// estimator re-run on each fold's normal equations.
#include "identification/search/held_out.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "identification/problem/measurement_cost.hpp"

namespace hapticcal::detail {
namespace {

constexpr double kNoTest = std::numeric_limits<double>::infinity();

std::vector<Eigen::Index> column_index(const std::vector<int>& v) {
  return std::vector<Eigen::Index>(v.begin(), v.end());
}

// The equations of the columns `fitted` with every other column held back at
// its start (moved by `back`): G_FF, g_F + G_FH h and the residual's |r + A_H h|^2.
NormalEquations reduced_equations(const NormalEquations& ne,
                                  const std::vector<Eigen::Index>& fitted,
                                  const std::vector<Eigen::Index>& held, const Eigen::VectorXd& h) {
  NormalEquations out;
  out.G = ne.G(fitted, fitted);
  out.g = ne.g(fitted) + ne.G(fitted, held) * h;
  out.rr = ne.rr + 2 * h.dot(ne.g(held)) + h.dot(ne.G(held, held) * h);
  return out;
}

// The columns of 0..k-1 not in `fitted`.
std::vector<Eigen::Index> held_columns(Eigen::Index k, const std::vector<Eigen::Index>& fitted) {
  std::vector<bool> in(static_cast<size_t>(k), false);
  for (Eigen::Index c : fitted) in[static_cast<size_t>(c)] = true;
  std::vector<Eigen::Index> out;
  for (Eigen::Index c = 0; c < k; ++c) {
    if (!in[static_cast<size_t>(c)]) out.push_back(c);
  }
  return out;
}

// The significance cut (model selection, docs/calibrate.md) on normal equations:
// backward elimination of the parameter of least t while it is below the
// family-wise threshold; the held ones go back to their start. The inverse of
// the fitted columns' normal matrix is downdated as each column goes (the
// inverse of a principal submatrix: A^-1 less the outer product of the
// removed column over its pivot), so the whole path costs one inversion.
std::optional<LinearEstimate> cut_on(const NormalEquations& ne, double dof_rows,
                                     const Eigen::VectorXd& back, std::vector<Eigen::Index> fitted,
                                     double alpha) {
  const Eigen::Index k = ne.G.rows();
  std::vector<Eigen::Index> held = held_columns(k, fitted);
  const NormalEquations reduced = reduced_equations(ne, fitted, held, back(held));
  LinearEstimate out;
  out.x = back;
  std::optional<Eigen::MatrixXd> inverse = inverse_normal(reduced.G);
  if (!inverse) return std::nullopt;
  Eigen::VectorXd b = reduced.g;  // g_F + G_FH h
  double rr = reduced.rr;         // |r + A_H h|^2
  while (!fitted.empty()) {
    const Eigen::VectorXd x = -*inverse * b;
    const double dof = dof_rows - static_cast<double>(fitted.size());
    const double sigma = std::sqrt(std::max(rr + b.dot(x), 0.0) / std::max(dof, 1.0));
    Eigen::Index weakest = 0;
    double weakest_t = kNoTest;
    for (Eigen::Index c = 0; c < x.size(); ++c) {
      const double sd = sigma * std::sqrt(std::max((*inverse)(c, c), 0.0));
      const double t = sd > 0 ? std::abs(x[c] - back[fitted[c]]) / sd : kNoTest;
      if (t < weakest_t) {
        weakest_t = t;
        weakest = c;
      }
    }
    if (weakest_t >= significance_threshold(alpha, static_cast<int>(fitted.size()), dof)) {
      out.x(fitted) = x;
      out.kept.assign(fitted.begin(), fitted.end());
      out.parameters = static_cast<double>(fitted.size());
      return out;
    }
    // Hold the weakest at its start: its column joins the held shift.
    const Eigen::Index j = fitted[weakest];
    const double h = back[j];
    Eigen::VectorXd shift = Eigen::VectorXd::Zero(k);
    shift(held) = back(held);
    rr += 2 * h * (ne.g[j] + ne.G.row(j).dot(shift)) + h * h * ne.G(j, j);
    held.push_back(j);
    std::vector<Eigen::Index> keep;
    for (Eigen::Index c = 0; c < static_cast<Eigen::Index>(fitted.size()); ++c) {
      if (c != weakest) keep.push_back(c);
    }
    const Eigen::VectorXd column = (*inverse)(keep, weakest);
    const Eigen::MatrixXd next =
        (*inverse)(keep, keep) - column * column.transpose() / (*inverse)(weakest, weakest);
    fitted.erase(fitted.begin() + weakest);
    b = b(keep).eval();
    b += ne.G(fitted, j) * h;
    *inverse = next;
  }
  return out;  // nothing kept
}

}  // namespace

std::optional<Eigen::MatrixXd> inverse_normal(const Eigen::MatrixXd& G) {
  if (G.rows() == 0) return Eigen::MatrixXd();
  const Eigen::VectorXd diagonal = G.diagonal();
  if (!(diagonal.minCoeff() > 0)) return std::nullopt;
  const Eigen::VectorXd e = diagonal.cwiseSqrt().cwiseInverse();
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(e.asDiagonal() * G * e.asDiagonal());
  if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > kSingularPivot)) {
    return std::nullopt;
  }
  return Eigen::MatrixXd(
      e.asDiagonal() * ldlt.solve(Eigen::MatrixXd::Identity(G.rows(), G.cols())) * e.asDiagonal());
}

std::optional<Eigen::VectorXd> solve_normal(const Eigen::MatrixXd& G, const Eigen::VectorXd& b) {
  if (G.rows() == 0) return Eigen::VectorXd();
  const Eigen::VectorXd diagonal = G.diagonal();
  if (!(diagonal.minCoeff() > 0)) return std::nullopt;
  const Eigen::VectorXd e = diagonal.cwiseSqrt().cwiseInverse();
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(e.asDiagonal() * G * e.asDiagonal());
  if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > kSingularPivot)) {
    return std::nullopt;
  }
  return Eigen::VectorXd(e.asDiagonal() * ldlt.solve(e.asDiagonal() * b));
}

std::optional<LinearEstimate> estimate(const NormalEquations& ne, double dof_rows,
                                       const HeldOutSystem& system,
                                       const LinearCandidate& candidate, double alpha,
                                       std::optional<double> prior_scale) {
  const std::vector<Eigen::Index> fitted = column_index(candidate.fitted);
  const std::vector<Eigen::Index> held = held_columns(ne.G.rows(), fitted);
  const Eigen::VectorXd& back = system.back;
  if (candidate.estimator == Estimator::kCut) return cut_on(ne, dof_rows, back, fitted, alpha);
  const NormalEquations reduced = reduced_equations(ne, fitted, held, back(held));
  LinearEstimate out;
  out.x = back;
  out.kept = candidate.fitted;
  const Eigen::VectorXd tolerance = system.tolerance(fitted);
  const bool prior =
      candidate.estimator == Estimator::kPrior &&
      std::any_of(tolerance.begin(), tolerance.end(), [](double t) { return std::isfinite(t); });
  if (prior) {
    // The prior's centre is each column's start: the deviation is -back.
    const std::optional<PriorChoice> choice =
        choose_prior(reduced, tolerance, -back(fitted), dof_rows, prior_scale);
    if (!choice) return std::nullopt;
    out.x(fitted) = choice->step;
    out.parameters = choice->effective;
    return out;
  }
  const std::optional<Eigen::VectorXd> x = solve_normal(reduced.G, -reduced.g);
  if (!x) return std::nullopt;
  out.x(fitted) = *x;
  out.parameters = static_cast<double>(fitted.size());
  return out;
}

FoldPlan fold_plan(int units, std::uint64_t seed) {
  FoldPlan plan;
  plan.seed = seed;
  plan.folds = std::clamp(units, 2, 5);
  plan.repeats =
      units <= plan.folds
          ? 1  // one unit a fold: every shuffle gives the same folds
          : std::clamp((kHeldOutPredictions + units - 1) / std::max(units, 1), 1, kMaxRepeats);
  return plan;
}

namespace {

// A fold's training poses that cannot determine some directions of a
// least-squares or cut candidate (a few poses, one fold short of exciting a
// parameter): those directions held at the prior's centre, each column's
// start, as a calibration on such poses holds what they do not excite. A ridge
// of kFoldRidge times the whole normal matrix's diagonal on every column the
// prior tolerates (the device's own; the set-up's have no prior) moves what
// the fold determines by about that fraction and what it does not to its start.
constexpr double kFoldRidge = 1e-6;
NormalEquations held_at_prior(const NormalEquations& train, const NormalEquations& whole,
                              const HeldOutSystem& system) {
  NormalEquations out = train;
  for (Eigen::Index j = 0; j < train.G.rows(); ++j) {
    if (!std::isfinite(system.tolerance[j])) continue;
    const double d = kFoldRidge * whole.G(j, j);
    // |r + A x|^2 + d (x - back)^2: G + d, g - d back, rr + d back^2.
    out.G(j, j) += d;
    out.g[j] -= d * system.back[j];
    out.rr += d * system.back[j] * system.back[j];
  }
  return out;
}

}  // namespace

std::vector<Eigen::VectorXd> held_out_errors(const HeldOutSystem& system,
                                             const std::vector<LinearCandidate>& candidates,
                                             const FoldPlan& plan, double alpha,
                                             std::optional<double> prior_scale) {
  const int units = static_cast<int>(system.unit_rows.size());
  const size_t n = candidates.size();
  std::vector<Eigen::VectorXd> error(n, Eigen::VectorXd::Zero(units));
  std::vector<bool> failed(n, units < 2);
  NormalEquations whole;
  whole.G = system.A.transpose() * system.A;
  whole.g = system.A.transpose() * system.r;
  whole.rr = system.r.squaredNorm();
  const int folds = std::min(plan.folds, units);
  for (int repeat = 0; repeat < plan.repeats && units >= 2; ++repeat) {
    const std::vector<int> fold = pose_folds(units, folds, plan.seed + repeat);
    for (int f = 0; f < folds; ++f) {
      std::vector<int> in_fold;
      std::vector<Eigen::Index> rows;
      double dof = system.dof_rows;
      for (int u = 0; u < units; ++u) {
        if (fold[u] != f) continue;
        in_fold.push_back(u);
        rows.insert(rows.end(), system.unit_rows[u].begin(), system.unit_rows[u].end());
        dof -= static_cast<double>(system.unit_rows[u].size()) - system.unit_unknowns[u];
      }
      const Eigen::MatrixXd Af = system.A(rows, Eigen::all);
      const Eigen::VectorXd rf = system.r(rows);
      NormalEquations train;
      train.G = whole.G - Af.transpose() * Af;
      train.g = whole.g - Af.transpose() * rf;
      train.rr = whole.rr - rf.squaredNorm();
      std::optional<NormalEquations> held;  // train with the unexcited held (built once)
      for (size_t c = 0; c < n; ++c) {
        if (failed[c]) continue;
        std::optional<LinearEstimate> fit =
            estimate(train, dof, system, candidates[c], alpha, prior_scale);
        if (!fit && candidates[c].estimator != Estimator::kPrior) {
          if (!held) held = held_at_prior(train, whole, system);
          fit = estimate(*held, dof, system, candidates[c], alpha, prior_scale);
        }
        if (!fit) {
          failed[c] = true;
          continue;
        }
        const Eigen::VectorXd e = rf + Af * fit->x;
        Eigen::Index at = 0;
        for (int u : in_fold) {
          for (Eigen::Index row : system.unit_rows[u]) {
            error[c][u] += system.measuring[row] * e[at] * e[at] / plan.repeats;
            ++at;
          }
        }
      }
    }
  }
  for (size_t c = 0; c < n; ++c) {
    if (failed[c]) error[c].resize(0);
  }
  return error;
}

HeldOutSystem held_out_system(const KinematicProblem& problem, const Stack& at,
                              const std::vector<int>& columns, const Eigen::VectorXd& scale,
                              const Eigen::VectorXd& start, const Eigen::VectorXd& solution,
                              const Eigen::VectorXd& tolerance) {
  HeldOutSystem s;
  const std::vector<Eigen::Index> c = column_index(columns);
  s.slots = columns;
  s.A = at.J(Eigen::all, c) * scale(c).cwiseInverse().asDiagonal();
  s.r = at.r;
  s.back = scale(c).cwiseProduct(start(c) - solution(c));
  s.tolerance = scale(c).cwiseProduct(tolerance(c));
  s.rows = std::max(problem.rows, 1);
  s.dof_rows = static_cast<double>(at.residuals - problem.labels.unknowns());
  const RowsOf kind = rows_of(problem);
  const int d = kind.dimension();
  const int m = static_cast<int>(problem.joints.size());
  s.measuring = Eigen::VectorXd::Ones(s.r.size());
  const int length_rows = traits(kind.type).length_rows;
  for (Eigen::Index i = 0; i < static_cast<Eigen::Index>(m) * d; ++i) {
    if (i % d >= length_rows) s.measuring[i] = 0;
  }
  if (!problem.labelled()) {
    // A pose a unit; a tree's samples of one pose are one (pose_units).
    const std::vector<int> unit = pose_units(problem);
    for (int i = 0; i < m; ++i) {
      if (unit[i] == static_cast<int>(s.unit_rows.size())) {
        s.unit_rows.emplace_back();
        s.unit_unknowns.push_back(0);
      }
      for (int k = 0; k < d; ++k)
        s.unit_rows.back().push_back(static_cast<Eigen::Index>(i) * d + k);
    }
    return s;
  }
  // A fixture: the labels a known distance joins are one unit (union-find).
  const FixtureLabels& labels = problem.labels;
  std::vector<int> root(static_cast<size_t>(labels.count()));
  std::iota(root.begin(), root.end(), 0);
  const auto find = [&](int l) {
    while (root[l] != l) l = root[l] = root[root[l]];
    return l;
  };
  for (const FixtureLabels::Known& k : labels.distances) root[find(k.a)] = find(k.b);
  std::vector<int> unit_of_root(root.size(), -1);
  std::vector<int> unit_of_label(root.size());
  for (int l = 0; l < labels.count(); ++l) {
    int& u = unit_of_root[find(l)];
    if (u < 0) {
      u = static_cast<int>(s.unit_rows.size());
      s.unit_rows.emplace_back();
      s.unit_unknowns.push_back(0);
    }
    unit_of_label[l] = u;
    const bool known =
        l < static_cast<int>(labels.known_point.size()) && labels.known_point[l].has_value();
    if (!known) s.unit_unknowns[u] += 3;
  }
  for (int i = 0; i < m; ++i) {
    std::vector<Eigen::Index>& rows = s.unit_rows[unit_of_label[labels.of_pose[i]]];
    for (int k = 0; k < d; ++k) rows.push_back(static_cast<Eigen::Index>(i) * d + k);
  }
  for (size_t k = 0; k < labels.distances.size(); ++k) {
    s.unit_rows[unit_of_label[labels.distances[k].a]].push_back(static_cast<Eigen::Index>(m) * d +
                                                                static_cast<Eigen::Index>(k));
  }
  return s;
}

}  // namespace hapticcal::detail
