// Experiment design for a tree (design/tree_plan.hpp).
#include "hapticcal/design/tree_plan.hpp"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>

#include "hapticcal/core/error.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "identification/stack.hpp"
#include "identification/tree_internal.hpp"

namespace hapticcal {
namespace {

constexpr std::uint64_t kValidationSeed = 0x5eed7a11;
constexpr std::uint64_t kEvaluationSeed = 0x5eed7a12;

// The tree's rows at these readings: a pose's 3 x tips rows (tip by tip) of
// every tree slot, the tips' points predicted by the nominal tree.
std::vector<Eigen::MatrixXd> pose_rows(const DeviceTree& tree, const Eigen::MatrixXd& readings) {
  detail::TreeData data;
  const Eigen::VectorXd values = tree.values();
  for (size_t c = 0; c < tree.chains.size(); ++c) {
    const DeviceModel& m = tree.chains[c];
    data.s.push_back(m.structure());
    std::vector<Eigen::VectorXd> joints;
    for (Eigen::Index i = 0; i < readings.rows(); ++i)
      joints.push_back(
          m.compensate(tree.chain_reading(readings.row(i).transpose(), static_cast<int>(c))));
    data.measured.push_back(detail::predicted_values(m.structure(), m.kinematic_parameters(),
                                                     joints, detail::tree_rows()));
    data.joints.push_back(std::move(joints));
    data.weights.emplace_back();
  }
  const detail::TreeStack at = detail::tree_stack(tree, data, values);
  const Eigen::Index n = readings.rows(), k = static_cast<Eigen::Index>(tree.chains.size());
  std::vector<Eigen::MatrixXd> out(static_cast<size_t>(n),
                                   Eigen::MatrixXd(3 * k, tree.num_slots()));
  for (Eigen::Index c = 0; c < k; ++c) {
    for (Eigen::Index i = 0; i < n; ++i)
      out[static_cast<size_t>(i)].middleRows(3 * c, 3) = at.J.middleRows(3 * (c * n + i), 3);
  }
  return out;
}

// The rows of the identified slots, scaled (angle columns / length scale).
struct Scaled {
  std::vector<int> slots;
  Eigen::VectorXd scale;  // a slot's
  Eigen::MatrixXd of(const Eigen::MatrixXd& rows) const {
    Eigen::MatrixXd out(rows.rows(), static_cast<Eigen::Index>(slots.size()));
    for (size_t j = 0; j < slots.size(); ++j)
      out.col(static_cast<Eigen::Index>(j)) = rows.col(slots[j]) / scale[slots[j]];
    return out;
  }
};

// The identified slots: the rank test on the pool's rows, base -> tools ->
// joints where the frame is unknown; the held candidates' reasons.
Scaled identify(const DeviceTree& tree, const std::vector<Eigen::MatrixXd>& rows,
                const Eigen::MatrixXd& readings, std::map<std::string, std::string>& held) {
  Scaled out;
  // The length scale: RMS distance of the tips' points from their centroid.
  std::vector<Eigen::Vector3d> points;
  for (size_t c = 0; c < tree.chains.size(); ++c) {
    const PreparedModel prepared(tree.chains[c]);
    for (Eigen::Index i = 0; i < readings.rows(); ++i) {
      const Eigen::VectorXd q =
          tree.chain_reading(readings.row(i).transpose(), static_cast<int>(c));
      points.push_back(prepared.forward(q.data()).p);
    }
  }
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : points) centre += p / static_cast<double>(points.size());
  double sum = 0;
  for (const Eigen::Vector3d& p : points) sum += (p - centre).squaredNorm();
  const double length = std::max(std::sqrt(sum / static_cast<double>(points.size())), 1e-3);
  out.scale = detail::tree_column_scale(tree, length);
  const std::vector<int> order = detail::tree_candidates(tree, {}, detail::tree_base_unset(tree));
  Eigen::MatrixXd J(static_cast<Eigen::Index>(rows.size()) * rows[0].rows(), tree.num_slots());
  for (size_t i = 0; i < rows.size(); ++i)
    J.middleRows(static_cast<Eigen::Index>(i) * rows[0].rows(), rows[0].rows()) = rows[i];
  J = J * out.scale.cwiseInverse().asDiagonal();
  for (const auto& [slot, v] : detail::rank_test(J, order, 1e-6)) {
    const std::string& name = tree.parameters[static_cast<size_t>(slot)].name;
    if (v.kind == detail::RankVerdict::kIdentified) continue;
    std::vector<std::string> on;
    for (int s : v.on) on.push_back(tree.parameters[static_cast<size_t>(s)].name);
    held[name] = v.kind == detail::RankVerdict::kNoEffect
                     ? "no effect on the tips' points"
                     : fmt::format("its effect is that of {}", fmt::join(on, ", "));
  }
  for (int slot : order) {
    if (!held.count(tree.parameters[static_cast<size_t>(slot)].name)) out.slots.push_back(slot);
  }
  return out;
}

// The covariance (scaled parameters) of a design's rows over sigma, or none
// when they do not determine every parameter.
std::optional<Eigen::MatrixXd> covariance(const std::vector<Eigen::MatrixXd>& design,
                                          double sigma) {
  const Eigen::Index k = design.empty() ? 0 : design[0].cols();
  if (k == 0) return {};
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(k, k);
  for (const Eigen::MatrixXd& F : design) M += F.transpose() * F;
  M /= sigma * sigma;
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(M);
  const Eigen::VectorXd d = ldlt.vectorD();
  if (ldlt.info() != Eigen::Success || !(d.minCoeff() > 1e-12 * d.maxCoeff())) return {};
  return Eigen::MatrixXd(ldlt.solve(Eigen::MatrixXd::Identity(k, k)));
}

// The RMS sd of a tip's point over the evaluation rows, from a covariance.
double rms_sd(const Eigen::MatrixXd& cov, const std::vector<Eigen::MatrixXd>& evaluation) {
  double sum = 0;
  Eigen::Index n = 0;
  for (const Eigen::MatrixXd& G : evaluation) {
    sum += (G * cov * G.transpose()).trace();
    n += G.rows() / 3;
  }
  return std::sqrt(sum / static_cast<double>(std::max<Eigen::Index>(n, 1)));
}

// A design on the candidates' stacked rows C (over sigma): the inverse of its
// information M (regularised by 1e-9 of the pool's mean diagonal, as the
// greedy start begins), changed one pose at a time by Woodbury's identity.
class TreeDesign {
 public:
  TreeDesign(const std::vector<Eigen::MatrixXd>& pool, PlanCriterion criterion,
             const Eigen::MatrixXd& W, double sigma)
      : criterion_(criterion), W_(W), r_(pool[0].rows()), used_(pool.size(), false) {
    const Eigen::Index k = pool[0].cols();
    C_.resize(static_cast<Eigen::Index>(pool.size()) * r_, k);
    for (size_t i = 0; i < pool.size(); ++i)
      C_.middleRows(static_cast<Eigen::Index>(i) * r_, r_) = pool[i] / sigma;
    const double mean_diagonal = C_.squaredNorm() / static_cast<double>(pool.size() * k);
    regularisation_ = 1e-9 * mean_diagonal;
    Minv_ = Eigen::MatrixXd::Identity(k, k) / regularisation_;
  }

  // Each candidate's gain of the criterion if added (-inf: in the design):
  // D: log det(M + F^T F) - log det M; I: the drop of trace(M^-1 W).
  std::vector<double> gains(int also = -1) const {
    const Eigen::MatrixXd G = C_ * Minv_;  // each candidate's F M^-1
    Eigen::MatrixXd GW;
    if (criterion_ == PlanCriterion::kI) GW = G * W_;
    const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(r_, r_);
    std::vector<double> out(used_.size(), -std::numeric_limits<double>::infinity());
    for (size_t i = 0; i < used_.size(); ++i) {
      if (used_[i] && static_cast<int>(i) != also) continue;
      const Eigen::Index row = static_cast<Eigen::Index>(i) * r_;
      const Eigen::MatrixXd S = I + G.middleRows(row, r_) * C_.middleRows(row, r_).transpose();
      out[i] =
          criterion_ == PlanCriterion::kD
              ? std::log(S.determinant())
              : S.ldlt().solve(GW.middleRows(row, r_) * G.middleRows(row, r_).transpose()).trace();
      if (!std::isfinite(out[i])) out[i] = -std::numeric_limits<double>::infinity();
    }
    return out;
  }
  void add(int i) { update(i, 1); }
  void remove(int i) { update(i, -1); }
  // M^-1 formed again from the design's poses (the rank-r updates drift where
  // a pose carries most of a parameter's information).
  void refresh() {
    const Eigen::Index k = C_.cols();
    Eigen::MatrixXd M = regularisation_ * Eigen::MatrixXd::Identity(k, k);
    for (size_t i = 0; i < used_.size(); ++i) {
      if (!used_[i]) continue;
      const auto F = C_.middleRows(static_cast<Eigen::Index>(i) * r_, r_);
      M.noalias() += F.transpose() * F;
    }
    Minv_ = M.ldlt().solve(Eigen::MatrixXd::Identity(k, k));
  }
  // The criterion to maximise: log det M, or -trace(M^-1 W).
  double value() const {
    if (criterion_ == PlanCriterion::kI) return -(Minv_ * W_).trace();
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(Minv_);
    return -ldlt.vectorD().array().log().sum();
  }

 private:
  // M +- F^T F: M^-1 -+ M^-1 F^T (I +- F M^-1 F^T)^-1 F M^-1.
  void update(int i, int sign) {
    const Eigen::MatrixXd F = C_.middleRows(static_cast<Eigen::Index>(i) * r_, r_);
    const Eigen::MatrixXd G = F * Minv_;
    const Eigen::MatrixXd S =
        Eigen::MatrixXd::Identity(r_, r_) + static_cast<double>(sign) * G * F.transpose();
    Minv_ -= static_cast<double>(sign) * G.transpose() * S.ldlt().solve(G);
    used_[static_cast<size_t>(i)] = sign > 0;
  }

  PlanCriterion criterion_;
  double regularisation_ = 0;
  Eigen::MatrixXd W_, C_, Minv_;
  Eigen::Index r_;
  std::vector<bool> used_;
};

int best_of(const std::vector<double>& gains) {
  const auto it = std::max_element(gains.begin(), gains.end());
  if (it == gains.end() || !std::isfinite(*it))
    throw InputError("plan: the criterion is not finite for any candidate pose");
  return static_cast<int>(it - gains.begin());
}

// The greedy start: each pose the candidate of the largest gain.
std::vector<int> greedy(TreeDesign& design, int poses) {
  std::vector<int> chosen;
  for (int n = 0; n < poses; ++n) {
    chosen.push_back(best_of(design.gains()));
    design.add(chosen.back());
  }
  return chosen;
}

// Fedorov's exchange, one design pose at a time: taken out, the candidate of
// the largest gain put in its place if it gains more than the pose itself (by
// 1e-9 relative), in sweeps until one makes no swap (at most `max_sweeps`).
// Returns the number of swaps; `sweeps` the sweeps run.
int exchange(TreeDesign& design, std::vector<int>& chosen, int max_sweeps, int& sweeps) {
  int swaps = 0;
  for (sweeps = 0; sweeps < max_sweeps;) {
    ++sweeps;
    int accepted = 0;
    for (int& pose : chosen) {
      design.remove(pose);
      const std::vector<double> gains = design.gains(pose);
      const int best = best_of(gains);
      const double own = gains[static_cast<size_t>(pose)];
      if (best != pose && gains[static_cast<size_t>(best)] > own + 1e-9 * std::abs(own)) {
        pose = best;
        ++accepted;
      }
      design.add(pose);
    }
    design.refresh();
    swaps += accepted;
    if (accepted == 0) break;
  }
  return swaps;
}

std::vector<Eigen::MatrixXd> scaled_rows(const Scaled& s,
                                         const std::vector<Eigen::MatrixXd>& rows) {
  std::vector<Eigen::MatrixXd> out;
  for (const Eigen::MatrixXd& r : rows) out.push_back(s.of(r));
  return out;
}

}  // namespace

TreePlan plan_tree(const DeviceTree& tree, const TreePlanOptions& options) {
  if (options.poses < 1 || options.poses > 100000)
    throw InputError(fmt::format("--poses {}: expected 1 to 100000", options.poses));
  if (options.validation_poses < 1 || options.evaluation_poses < 1)
    throw InputError("plan: the validation and evaluation samples need a pose each at least");
  if (options.criterion != PlanCriterion::kD && options.criterion != PlanCriterion::kI)
    throw InputError("--criterion: a tree's plan is D- or I-optimal");
  TreePlan out;
  out.pool = std::max(options.pool, options.poses);
  const Eigen::MatrixXd pool = tree_random_readings(tree, out.pool, options.seed);
  const std::vector<Eigen::MatrixXd> raw = pose_rows(tree, pool);
  const Scaled s = identify(tree, raw, pool, out.held);
  if (s.slots.empty())
    throw InputError(
        fmt::format("{}: the tips' points identify no parameter of the tree", tree.name));
  const int rows_a_pose = 3 * static_cast<int>(tree.chains.size());
  if (options.poses * rows_a_pose < static_cast<int>(s.slots.size()))
    throw InputError(fmt::format(
        "--poses {}: {} poses of {} tips measure {} values, fewer than the {} parameters to "
        "identify",
        options.poses, options.poses, tree.chains.size(), options.poses * rows_a_pose,
        s.slots.size()));
  for (int slot : s.slots)
    out.parameters.push_back(tree.parameters[static_cast<size_t>(slot)].name);
  const std::vector<Eigen::MatrixXd> candidates = scaled_rows(s, raw);
  const std::vector<Eigen::MatrixXd> validation = scaled_rows(
      s, pose_rows(tree, tree_random_readings(tree, options.validation_poses, kValidationSeed)));
  const std::vector<Eigen::MatrixXd> evaluation = scaled_rows(
      s, pose_rows(tree, tree_random_readings(tree, options.evaluation_poses, kEvaluationSeed)));
  Eigen::MatrixXd W = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(s.slots.size()),
                                            static_cast<Eigen::Index>(s.slots.size()));
  for (const Eigen::MatrixXd& G : validation) W += G.transpose() * G;
  W /= static_cast<double>(validation.size());
  TreeDesign information(candidates, options.criterion, W, options.sigma);
  std::vector<int> chosen = greedy(information, options.poses);
  auto rows_of = [&](const std::vector<int>& poses) {
    std::vector<Eigen::MatrixXd> out;
    for (int i : poses) out.push_back(candidates[static_cast<size_t>(i)]);
    return out;
  };
  information.refresh();
  out.criterion_greedy = information.value();
  if (const auto c = covariance(rows_of(chosen), options.sigma)) {
    out.rms_sd_greedy = rms_sd(*c, evaluation);
  }
  out.swaps = exchange(information, chosen, options.max_sweeps, out.sweeps);
  out.criterion_exchange = information.value();
  Eigen::MatrixXd design(options.poses, tree.dof());
  for (int i = 0; i < options.poses; ++i) design.row(i) = pool.row(chosen[static_cast<size_t>(i)]);
  const std::optional<Eigen::MatrixXd> cov = covariance(rows_of(chosen), options.sigma);
  if (!cov)
    throw InputError(fmt::format("--poses {}: too few to determine the tree's {} parameters",
                                 options.poses, s.slots.size()));
  out.sd.resize(static_cast<Eigen::Index>(s.slots.size()));
  for (size_t j = 0; j < s.slots.size(); ++j) {
    const Eigen::Index i = static_cast<Eigen::Index>(j);
    out.sd[i] = std::sqrt((*cov)(i, i)) / s.scale[s.slots[j]];
  }
  out.rms_sd = rms_sd(*cov, evaluation);
  for (int d = 0; d < options.random_draws; ++d) {
    const Eigen::MatrixXd random =
        tree_random_readings(tree, options.poses, options.seed + 1000 + static_cast<unsigned>(d));
    const std::optional<Eigen::MatrixXd> c =
        covariance(scaled_rows(s, pose_rows(tree, random)), options.sigma);
    out.random_rms_sd.push_back(c ? rms_sd(*c, evaluation)
                                  : std::numeric_limits<double>::infinity());
  }
  std::sort(out.random_rms_sd.begin(), out.random_rms_sd.end());
  if (!out.random_rms_sd.empty())
    out.random_median_rms_sd = out.random_rms_sd[out.random_rms_sd.size() / 2];
  out.path_length_unordered = path_length(design);
  const std::vector<int> order = short_path(design);
  out.readings.resize(design.rows(), design.cols());
  for (size_t i = 0; i < order.size(); ++i)
    out.readings.row(static_cast<Eigen::Index>(i)) = design.row(order[i]);
  out.path_length = path_length(out.readings);
  return out;
}

double tree_predicted_rms_sd(const DeviceTree& tree, const Eigen::MatrixXd& design,
                             const Eigen::MatrixXd& validation, double sigma) {
  std::map<std::string, std::string> held;
  const std::vector<Eigen::MatrixXd> raw = pose_rows(tree, validation);
  const Scaled s = identify(tree, raw, validation, held);
  const std::optional<Eigen::MatrixXd> cov =
      covariance(scaled_rows(s, pose_rows(tree, design)), sigma);
  return cov ? rms_sd(*cov, scaled_rows(s, raw)) : std::numeric_limits<double>::infinity();
}

}  // namespace hapticcal
