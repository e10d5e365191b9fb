// One fit of every tip of a tree (identification/tree.hpp: calibrate_tree).
#include <ceres/ceres.h>
#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <map>

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/registration.hpp"
#include "hapticcal/identification/tree.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "identification/solver_options.hpp"
#include "identification/stack.hpp"
#include "identification/tree_internal.hpp"

namespace hapticcal {
namespace {

using detail::RankVerdict;
using detail::TreeData;

// The rows' weights, joint values and measured points of each chain.
TreeData tree_data(const DeviceTree& tree, const Log& log, bool force,
                   std::vector<std::string>& notes) {
  TreeData data;
  for (size_t c = 0; c < tree.chains.size(); ++c) {
    const DeviceModel& m = tree.chains[c];
    const Log lc = chain_log(tree, log, static_cast<int>(c));
    detail::check_joint_limits(lc, m, force, notes);
    data.s.push_back(m.structure());
    std::vector<Eigen::VectorXd> joints;
    for (int r = 0; r < log.rows; ++r) joints.push_back(m.compensate(lc.q.row(r).transpose()));
    data.joints.push_back(std::move(joints));
    data.measured.push_back(lc.position);
    data.weights.emplace_back();
  }
  return data;
}

// The tips' predicted points at `values` and the measured ones, 3 x (rows x tips).
void tree_points(const DeviceTree& tree, const TreeData& data, const Eigen::VectorXd& values,
                 Eigen::Matrix3Xd& predicted, Eigen::Matrix3Xd& measured) {
  Eigen::Index n = 0;
  for (const auto& j : data.joints) n += static_cast<Eigen::Index>(j.size());
  predicted.resize(3, n);
  measured.resize(3, n);
  Eigen::Index at = 0;
  for (size_t c = 0; c < tree.chains.size(); ++c) {
    DeviceModel m = tree.chains[c];
    m.set_kinematic_parameters(tree.chain_values(values, static_cast<int>(c)));
    const detail::RowMatrix p = detail::predicted_values(m.structure(), m.kinematic_parameters(),
                                                         data.joints[c], detail::tree_rows());
    for (Eigen::Index r = 0; r < p.rows(); ++r, ++at) {
      predicted.col(at) = p.row(r).transpose();
      measured.col(at) = data.measured[c].row(r).transpose();
    }
  }
}

// An unknown frame (the base a free pose the URDF leaves at its root, or the
// points far from the model's): the base registered onto every tip's points in
// closed form. Returns whether it was.
bool register_tree_frame(const DeviceTree& tree, const TreeData& data, Eigen::VectorXd& values,
                         double length_scale, const std::vector<std::string>& fix,
                         std::vector<std::string>& notes) {
  if (!tree.chains[0].base_is_pose()) return false;
  for (int k = 0; k < kPoseSlots; ++k) {  // a base held (--fix) is not moved
    if (std::count(fix.begin(), fix.end(), tree.parameters[static_cast<size_t>(k)].name))
      return false;
  }
  Eigen::Matrix3Xd predicted, measured;
  tree_points(tree, data, values, predicted, measured);
  const double before = std::sqrt((predicted - measured).colwise().squaredNorm().mean());
  const bool given = std::any_of(tree.chains[0].base.begin(), tree.chains[0].base.end(),
                                 [](double v) { return v != 0; });
  if (given && before < 0.01 * length_scale) return false;
  Registration reg;
  try {
    reg = register_points(predicted, measured);
  } catch (const InputError& e) {
    notes.push_back(std::string("the measurement frame could not be registered in closed form (") +
                    e.what() + "): Levenberg-Marquardt starts from the model's base");
    return false;
  }
  const Frame<double> B =
      pose_frame(values[0], values[1], values[2], values[3], values[4], values[5]);
  const Frame<double> moved = Frame<double>{reg.R, reg.t} * B;
  const Eigen::Vector3d rpy = matrix_rpy(moved.R);
  values.head<3>() = moved.p;
  values.segment<3>(3) = rpy;
  notes.push_back(fmt::format(
      "the measurement frame was registered onto the {} tips' points in closed form (RMS {:.3f} "
      "mm before, {:.3f} mm after)",
      tree.tips.size(), 1e3 * before, 1e3 * reg.rms));
  return true;
}

// The structural and the data's rank test: the identified slots, and why the
// others are held.
std::vector<int> tree_identifiable(const DeviceTree& tree, const TreeData& data,
                                   const Eigen::VectorXd& values, const std::vector<int>& order,
                                   const Eigen::VectorXd& scale, double tolerance,
                                   TreeCalibration& out) {
  const auto name_list = [&](const std::vector<int>& slots) {
    std::vector<std::string> names;
    for (int s : slots) names.push_back(tree.parameters[static_cast<size_t>(s)].name);
    return fmt::format("{}", fmt::join(names, ", "));
  };
  TreeData synthetic = data;
  synthetic.joints = detail::tree_synthetic_joints(tree);
  for (size_t c = 0; c < tree.chains.size(); ++c) {
    DeviceModel m = tree.chains[c];
    m.set_kinematic_parameters(tree.chain_values(values, static_cast<int>(c)));
    synthetic.measured[c] = detail::predicted_values(m.structure(), m.kinematic_parameters(),
                                                     synthetic.joints[c], detail::tree_rows());
  }
  const Eigen::MatrixXd structural =
      detail::tree_stack(tree, synthetic, values).J * scale.cwiseInverse().asDiagonal();
  const std::map<int, RankVerdict> general = detail::rank_test(structural, order, tolerance);
  std::vector<int> excitable;
  for (int slot : order) {
    const RankVerdict& v = general.at(slot);
    ParameterEstimate& p = out.parameters[static_cast<size_t>(slot)];
    if (v.kind == RankVerdict::kIdentified) {
      excitable.push_back(slot);
    } else if (v.kind == RankVerdict::kNoEffect) {
      p.reason = "no effect on the tips' points";
    } else {
      p.reason = "its effect is that of " + name_list(v.on);
    }
  }
  const Eigen::MatrixXd J =
      detail::tree_stack(tree, data, values).J * scale.cwiseInverse().asDiagonal();
  const std::map<int, RankVerdict> excited = detail::rank_test(J, excitable, tolerance);
  std::vector<int> identified;
  for (int slot : excitable) {
    if (excited.at(slot).kind == RankVerdict::kIdentified) {
      identified.push_back(slot);
    } else {
      out.rank_deficient = true;
      out.parameters[static_cast<size_t>(slot)].reason =
          "identifiable, but these poses do not excite it";
    }
  }
  return identified;
}

// Standard deviations, correlations and the condition number at the solution.
void tree_statistics(const DeviceTree& tree, const TreeData& data, const Eigen::VectorXd& values,
                     const std::vector<int>& identified, const Eigen::VectorXd& scale,
                     std::optional<double> sigma, TreeCalibration& out) {
  const detail::TreeStack at = detail::tree_stack(tree, data, values);
  const Eigen::Index k = static_cast<Eigen::Index>(identified.size());
  Eigen::MatrixXd Jk(at.J.rows(), k);
  for (Eigen::Index i = 0; i < k; ++i)
    Jk.col(i) = at.J.col(identified[static_cast<size_t>(i)]) / scale[identified[i]];
  const double dof = static_cast<double>(at.r.size() - k);
  out.sigma = sigma ? *sigma : dof > 0 ? std::sqrt(at.r.squaredNorm() / dof) : 0.0;
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(Jk);
  const Eigen::VectorXd sv = svd.singularValues();
  out.condition_number = sv.size() && sv[sv.size() - 1] > 0
                             ? sv[0] / sv[sv.size() - 1]
                             : std::numeric_limits<double>::infinity();
  const Eigen::MatrixXd JtJ = Jk.transpose() * Jk;
  const Eigen::MatrixXd cov = JtJ.ldlt().solve(Eigen::MatrixXd::Identity(k, k));
  for (Eigen::Index i = 0; i < k; ++i) {
    ParameterEstimate& p = out.parameters[static_cast<size_t>(identified[i])];
    p.sd = out.sigma * std::sqrt(std::max(cov(i, i), 0.0)) / scale[identified[i]];
    for (Eigen::Index j = 0; j < k; ++j) {
      const double rho = cov(i, j) / std::sqrt(cov(i, i) * cov(j, j));
      if (j != i && std::abs(rho) > std::abs(p.max_correlation)) {
        p.max_correlation = rho;
        p.max_correlation_with = tree.parameters[static_cast<size_t>(identified[j])].name;
      }
    }
  }
}

// Each tip's RMS position error at `values`, and each pose's.
std::vector<double> tip_rms(const DeviceTree& tree, const TreeData& data,
                            const Eigen::VectorXd& values, std::vector<Eigen::VectorXd>& errors) {
  const detail::TreeStack at = detail::tree_stack(tree, data, values, false);
  std::vector<double> out;
  errors.clear();
  Eigen::Index row = 0;
  for (size_t c = 0; c < at.rss.size(); ++c) {
    const Eigen::Index n = static_cast<Eigen::Index>(data.joints[c].size());
    out.push_back(std::sqrt(at.rss[c] / std::max<double>(1, static_cast<double>(n))));
    Eigen::VectorXd e(n);
    for (Eigen::Index i = 0; i < n; ++i, row += 3) e[i] = at.r.segment<3>(row).norm();
    errors.push_back(e);
  }
  return out;
}

}  // namespace

void check_tree_log(const DeviceTree& tree, const Log& log) {
  const auto bad = [&](const std::string& key, const std::string& why) {
    throw InputError(log.origin, log.line.empty() ? 0 : log.line[0], key, why);
  };
  if (log.dof() != tree.dof())
    bad("header", fmt::format("{} joint columns for a tree of {} joints ({})", log.dof(),
                              tree.dof(), fmt::join(tree.joints, ", ")));
  if (log.marker_count != static_cast<int>(tree.tips.size()))
    bad("header", fmt::format("{} tips ({}) need the points x1, y1, z1 .. x{}, y{}, z{}; the log "
                              "has {}",
                              tree.tips.size(), fmt::join(tree.tips, ", "), tree.tips.size(),
                              tree.tips.size(), tree.tips.size(),
                              log.marker_count ? fmt::format("{} point{}", log.marker_count,
                                                             log.marker_count > 1 ? "s" : "")
                                               : std::string("none")));
  for (bool e : log.has_ext) {
    if (e) bad("ext", "external encoders on a tree: fit each joint's transmission on its chain");
  }
  if (log.has_distance || log.has_orientation || log.has_position || log.has_point || log.has_plane)
    bad("header", "a tree's log measures its tips' points (x1, y1, z1, ...) and nothing else");
  if (log.any_direction()) bad("dir", "approach directions on a tree: not supported yet");
}

namespace detail {

// The candidates in the rank test's order, tree slots.
std::vector<int> tree_candidates(const DeviceTree& tree, const std::vector<std::string>& fix,
                                 bool frame_unknown) {
  std::vector<int> links, tools, base;
  std::map<std::string, bool> named;
  for (const std::string& f : fix) named[f] = false;
  for (size_t c = 0; c < tree.chains.size(); ++c) {
    for (int slot : candidate_slots(tree.chains[c], {}, {})) {
      const int t = tree.slot_of[c][static_cast<size_t>(slot)];
      const ParameterInfo& p = tree.parameters[static_cast<size_t>(t)];
      if (named.count(p.name)) {
        named[p.name] = true;
        continue;
      }
      std::vector<int>& to = p.joint == -1 ? base : p.joint <= -2 ? tools : links;
      if (std::find(to.begin(), to.end(), t) == to.end()) to.push_back(t);
    }
  }
  for (const auto& [name, used] : named) {
    if (!used) throw InputError(fmt::format("--fix {}: not a parameter of the tree", name));
  }
  std::vector<int> out;
  for (const auto* part :
       frame_unknown ? std::array{&base, &tools, &links} : std::array{&links, &tools, &base})
    out.insert(out.end(), part->begin(), part->end());
  return out;
}

}  // namespace detail

TreeCalibration calibrate_tree(const DeviceTree& nominal, const Log& log,
                               const CalibrationOptions& options) {
  check_tree_log(nominal, log);
  if (!options.joint_errors.empty() || !options.free.empty() || options.select)
    throw InputError(fmt::format("{} on a tree: not supported yet (a single chain's)",
                                 !options.joint_errors.empty() ? "--joint-errors"
                                 : options.select              ? "--select"
                                                               : "--free"));
  // The dense Jacobian (no compression on a tree yet) within the single chain's bound.
  if (3.0 * log.rows * static_cast<double>(nominal.tips.size()) * nominal.num_slots() *
          sizeof(double) >
      static_cast<double>(options.max_jacobian_bytes))
    throw InputError(log.origin, 0, "rows",
                     fmt::format("{} poses are more than a tree's fit holds in memory ({} MB "
                                 "for its Jacobian): give fewer",
                                 log.rows, options.max_jacobian_bytes >> 20));
  TreeCalibration out;
  out.poses = log.rows;
  const TreeData data = tree_data(nominal, log, options.force, out.notes);
  Eigen::VectorXd values = nominal.values();
  // The length scale: RMS distance of the tips' points from the base origin.
  Eigen::Matrix3Xd predicted, measured;
  tree_points(nominal, data, values, predicted, measured);
  {
    const Eigen::Vector3d origin = measured.rowwise().mean();
    out.length_scale =
        std::max(std::sqrt((measured.colwise() - origin).colwise().squaredNorm().mean()), 1e-3);
  }
  out.frame_registered =
      register_tree_frame(nominal, data, values, out.length_scale, options.fix, out.notes);
  const bool frame_unknown = nominal.chains[0].base_is_pose() &&
                             (out.frame_registered || detail::tree_base_unset(nominal));
  out.rms_before = tip_rms(nominal, data, values, out.errors_before);
  const Eigen::VectorXd start = nominal.values();
  for (const ParameterInfo& p : nominal.parameters) {
    ParameterEstimate e;
    e.name = p.name;
    e.slot = p.slot;
    e.unit = p.unit;
    e.nominal = start[p.slot];
    e.value = values[p.slot];
    e.reason = "held (not a candidate)";
    out.parameters.push_back(e);
  }
  const Eigen::VectorXd scale = detail::tree_column_scale(nominal, out.length_scale);
  const std::vector<int> order = detail::tree_candidates(nominal, options.fix, frame_unknown);
  const std::vector<int> identified =
      tree_identifiable(nominal, data, values, order, scale, options.dependency_tolerance, out);
  out.identified = static_cast<int>(identified.size());
  out.calibrated = nominal;
  out.calibrated.set_values(values);  // a registered base, as the parameters report it
  if (identified.empty()) {
    out.rms_after = out.rms_before;
    out.errors_after = out.errors_before;
    out.status = CalibrationStatus::kRankDeficient;
    out.status_reason = "no parameter of the tree is identifiable from these points";
    return out;
  }
  std::vector<int> constant;
  for (int k = 0; k < nominal.num_slots(); ++k)
    if (std::find(identified.begin(), identified.end(), k) == identified.end())
      constant.push_back(k);
  ceres::Problem lm;
  lm.AddResidualBlock(detail::tree_cost(nominal, data), nullptr, values.data());
  if (!constant.empty())
    lm.SetManifold(values.data(), new ceres::SubsetManifold(nominal.num_slots(), constant));
  ceres::Solver::Summary summary;
  ceres::Solve(detail::levenberg_marquardt(100), &lm, &summary);
  out.iterations = std::max(static_cast<int>(summary.iterations.size()) - 1, 0);
  out.termination = summary.message;
  out.calibrated.set_values(values);
  out.rms_after = tip_rms(nominal, data, values, out.errors_after);
  for (int slot : identified) {
    ParameterEstimate& p = out.parameters[static_cast<size_t>(slot)];
    p.identifiable = true;
    p.reason.clear();
    p.value = values[slot];
  }
  for (ParameterEstimate& p : out.parameters) {
    if (p.slot < kPoseSlots) p.value = values[p.slot];  // a registered base
  }
  tree_statistics(nominal, data, values, identified, scale, options.sigma, out);
  if (summary.termination_type != ceres::CONVERGENCE) {
    out.status = summary.termination_type == ceres::FAILURE ? CalibrationStatus::kNumericalFailure
                                                            : CalibrationStatus::kNotConverged;
    out.status_reason = "Levenberg-Marquardt did not converge: " + summary.message;
  } else if (out.rank_deficient) {
    out.status = CalibrationStatus::kRankDeficient;
    out.status_reason = "these poses leave identifiable parameters of the tree unexcited";
  } else {
    out.status_reason = fmt::format("{} parameters of the tree identified from {} poses",
                                    out.identified, out.poses);
  }
  out.notes.push_back(
      "a tree is fitted by plain least squares: no tolerance prior, model selection or robust "
      "loss yet");
  return out;
}

}  // namespace hapticcal
