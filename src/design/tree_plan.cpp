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

// The greedy start: each pose the candidate of the largest gain, the gains of
// every candidate from two products of the stacked rows a step.
std::vector<int> greedy(const std::vector<Eigen::MatrixXd>& pool, int poses,
                        PlanCriterion criterion, const Eigen::MatrixXd& W, double sigma) {
  const Eigen::Index k = pool[0].cols(), r = pool[0].rows();
  Eigen::MatrixXd C(static_cast<Eigen::Index>(pool.size()) * r, k);
  for (size_t i = 0; i < pool.size(); ++i)
    C.middleRows(static_cast<Eigen::Index>(i) * r, r) = pool[i] / sigma;
  const double mean_diagonal = C.squaredNorm() / static_cast<double>(pool.size() * k);
  Eigen::MatrixXd Minv = Eigen::MatrixXd::Identity(k, k) / (1e-9 * mean_diagonal);
  std::vector<int> chosen;
  std::vector<bool> used(pool.size(), false);
  const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(r, r);
  for (int n = 0; n < poses; ++n) {
    const Eigen::MatrixXd G = C * Minv;  // each candidate's F M^-1
    Eigen::MatrixXd GW;
    if (criterion == PlanCriterion::kI) GW = G * W;
    double best = -std::numeric_limits<double>::infinity();
    int at = -1;
    for (size_t i = 0; i < pool.size(); ++i) {
      if (used[i]) continue;
      const Eigen::Index row = static_cast<Eigen::Index>(i) * r;
      const Eigen::MatrixXd S = I + G.middleRows(row, r) * C.middleRows(row, r).transpose();
      // D: log det(M + F^T F) - log det M; I: the drop of trace(M^-1 W).
      const double gain =
          criterion == PlanCriterion::kD
              ? std::log(S.determinant())
              : S.ldlt().solve(GW.middleRows(row, r) * G.middleRows(row, r).transpose()).trace();
      if (gain > best) {
        best = gain;
        at = static_cast<int>(i);
      }
    }
    if (at < 0) throw InputError("plan: the criterion is not finite for any candidate pose");
    const Eigen::Index row = static_cast<Eigen::Index>(at) * r;
    const Eigen::MatrixXd Gi = G.middleRows(row, r);
    const Eigen::MatrixXd S = I + Gi * C.middleRows(row, r).transpose();
    Minv -= Gi.transpose() * S.ldlt().solve(Gi);
    used[static_cast<size_t>(at)] = true;
    chosen.push_back(at);
  }
  return chosen;
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
  const std::vector<int> chosen =
      greedy(candidates, options.poses, options.criterion, W, options.sigma);
  Eigen::MatrixXd design(options.poses, tree.dof());
  std::vector<Eigen::MatrixXd> design_rows;
  for (int i = 0; i < options.poses; ++i) {
    design.row(i) = pool.row(chosen[static_cast<size_t>(i)]);
    design_rows.push_back(candidates[static_cast<size_t>(chosen[static_cast<size_t>(i)])]);
  }
  const std::optional<Eigen::MatrixXd> cov = covariance(design_rows, options.sigma);
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
