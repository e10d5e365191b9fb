// Outliers and suspect fits (docs/outliers.md): a per-pose
// test of step 2's residuals against the noise the fit itself estimates, the
// robust reweighting of the poses it flags, the refit of a small log without
// the poses its held-out errors name, and the checks that call a converged fit
// suspect.
#include <fmt/format.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/identification/measurement.hpp"
#include "hapticcal/identification/stream.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "identification/calibration_run.hpp"
#include "identification/problem/stack.hpp"

namespace hapticcal {
namespace {

constexpr double kMadToSd = 1.4826;  // 1 / Phi^-1(3/4): MAD -> sd of a normal
constexpr double kCauchyC = 2.3849;  // 95 % efficiency at the normal (Holland & Welsch)
constexpr double kHuberK = 1.345;    // likewise
// The threshold's floor in robust sds of a pose's RMS component: real residuals
// hold unmodelled errors with heavier tails than the normal (3 of the 7 clean
// Meca500 sets had a pose beyond the Bonferroni 2.38 sds; none beyond 5).
constexpr double kThresholdFloor = 5;
constexpr int kMaxReweightings = 30;       // iteratively reweighted least squares' limit
constexpr double kWeightTolerance = 1e-4;  // the weights have settled

// The weighted residual components of each pose (d a pose) at `parameters`.
Eigen::MatrixXd pose_residuals(const KinematicProblem& problem, const Eigen::VectorXd& parameters,
                               const Eigen::VectorXd& weights) {
  const detail::RowsOf kind = detail::rows_of(problem);
  const Eigen::VectorXd r = detail::residuals_at(problem.model.structure(), parameters,
                                                 problem.joints, kind, problem.measured, weights);
  const int d = kind.dimension();
  const int m = static_cast<int>(problem.joints.size());
  Eigen::MatrixXd e(m, d);
  for (int i = 0; i < m; ++i) e.row(i) = r.segment(static_cast<Eigen::Index>(i) * d, d).transpose();
  return e;
}

double median(std::vector<double> v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const size_t n = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(n), v.end());
  const double upper = v[n];
  if (v.size() % 2) return upper;
  return 0.5 * (upper + *std::max_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(n)));
}

// 1.4826 times the median absolute deviation of every component from their median.
double robust_sd(const Eigen::MatrixXd& e) {
  std::vector<double> all(e.data(), e.data() + e.size());
  const double centre = median(all);
  for (double& x : all) x = std::abs(x - centre);
  return kMadToSd * median(all);
}

// The outlier test's threshold on an RMS component in robust sds: the
// chi-square quantile with d dof at 1 - alpha / count (Bonferroni over `count`
// tested units), at least kThresholdFloor.
double outlier_threshold(double alpha, double count, int d) {
  return std::max(std::sqrt(chi_square_quantile(1 - alpha / count, d) / d), kThresholdFloor);
}

// Each pose's RMS component in robust sds.
Eigen::VectorXd statistics_of(const Eigen::MatrixXd& e, double sd) {
  return (e.rowwise().norm() / std::sqrt(static_cast<double>(e.cols()))) / sd;
}

// The loss's weight of a residual u robust sds (rho'(u^2), rho(0) = 0).
double loss_weight(RobustLoss loss, double u) {
  switch (loss) {
    case RobustLoss::kCauchy:
      return 1 / (1 + (u / kCauchyC) * (u / kCauchyC));
    case RobustLoss::kHuber:
      return u <= kHuberK ? 1 : kHuberK / u;
    case RobustLoss::kNone:
      return 1;
  }
  return 1;
}

}  // namespace

const char* to_string(RobustLoss loss) {
  switch (loss) {
    case RobustLoss::kNone:
      return "none";
    case RobustLoss::kCauchy:
      return "cauchy";
    case RobustLoss::kHuber:
      return "huber";
  }
  return "?";
}

namespace detail {

void screen_repeats(const Log& log, std::vector<std::vector<int>>& poses, double alpha,
                    std::vector<std::string>& notes) {
  constexpr size_t kMinRepeats = 5;  // a median and a spread worth the name
  constexpr size_t kNamed = 10;
  // Measured values only: a fixture's labels have none.
  if (kinds_in(log).empty() || holds_fixture(log)) return;
  // The measured lengths of a row (a pose's position, not its rotation).
  const MeasurementType type = measurement_type(log);
  const MeasurementTraits& t = traits(type);
  const int d = std::min(t.length_rows, t.width);
  Eigen::VectorXd value(t.width);
  const auto measured = [&](int r) {
    measured_values(type, log, r, value.data());
    return value.head(d);
  };
  // Each repeat's deviation from its pose's median, component by component.
  std::vector<std::pair<size_t, Eigen::MatrixXd>> deviations;
  std::vector<double> pooled;
  for (size_t g = 0; g < poses.size(); ++g) {
    const std::vector<int>& rows = poses[g];
    if (rows.size() < kMinRepeats) continue;
    Eigen::MatrixXd x(static_cast<Eigen::Index>(rows.size()), d);
    for (size_t k = 0; k < rows.size(); ++k)
      x.row(static_cast<Eigen::Index>(k)) = measured(rows[k]);
    for (int c = 0; c < d; ++c) {
      const Eigen::VectorXd column = x.col(c);
      x.col(c).array() -= median(std::vector<double>(column.data(), column.data() + column.size()));
    }
    for (Eigen::Index k = 0; k < x.size(); ++k) pooled.push_back(std::abs(x.data()[k]));
    deviations.emplace_back(g, std::move(x));
  }
  const double scale = kMadToSd * median(pooled);
  if (deviations.empty() || !(scale > 0)) return;
  const auto rows = static_cast<double>(pooled.size()) / d;
  const double threshold = outlier_threshold(alpha, rows, d);
  std::vector<std::string> named;
  int flagged = 0;
  for (auto& [g, x] : deviations) {
    std::vector<int> kept;
    for (size_t k = 0; k < poses[g].size(); ++k) {
      const Eigen::VectorXd e = x.row(static_cast<Eigen::Index>(k)).transpose();
      const double statistic = e.norm() / std::sqrt(d) / scale;
      if (statistic <= threshold) {
        kept.push_back(poses[g][k]);
        continue;
      }
      const int r = poses[g][k];
      if (++flagged <= static_cast<int>(kNamed)) {
        named.push_back(fmt::format(
            "warning: outlier among repeats: log line {}: {:.4f} mm from the median of its "
            "pose's {} rows, {:.1f} robust sds of {:.4g} mm (beyond {:.2f}): left out of the "
            "pose's mean",
            r < static_cast<int>(log.line.size()) ? log.line[r] : r + 2, 1e3 * e.norm(),
            poses[g].size(), statistic, 1e3 * scale, threshold));
      }
    }
    if (!kept.empty()) poses[g] = std::move(kept);
  }
  notes.insert(notes.end(), named.begin(), named.end());
  if (flagged > static_cast<int>(kNamed)) {
    notes.push_back(fmt::format("warning: outlier among repeats: and {} more rows left out",
                                flagged - static_cast<int>(kNamed)));
  }
}

}  // namespace detail

RobustLoss robust_loss(const std::string& name) {
  for (RobustLoss l : {RobustLoss::kCauchy, RobustLoss::kHuber, RobustLoss::kNone}) {
    if (name == to_string(l)) return l;
  }
  throw InputError(fmt::format("--loss {}: not one of cauchy, huber, none", name));
}

RobustFit reweight_outliers(KinematicProblem& problem, const std::vector<int>& identified,
                            KinematicSolution& solution, RobustLoss loss, double alpha,
                            int max_iterations) {
  if (!(alpha > 0 && alpha < 1)) {
    throw InputError(fmt::format("outlier test level {} is not in (0, 1)", alpha));
  }
  RobustFit out;
  out.loss = loss;
  if (problem.labelled()) {
    out.note =
        "not tested: a fixture's residuals are projections with its unknown points or planes "
        "eliminated, not one pose's error";
    return out;
  }
  const int m = static_cast<int>(problem.joints.size());
  const int d = traits(problem.type).dimension;
  if (identified.empty() || solution.termination != SolveTermination::kConverged) {
    out.note = "not tested: the fit did not converge";
    return out;
  }
  // With few residual degrees of freedom the fit follows every measurement and
  // the MAD of what is left measures nothing (30 distances for 28 parameters
  // scaled tiny residuals into "outliers" and the reweighted fit broke down).
  const int k = static_cast<int>(identified.size());
  if (m * d - k < std::max(k, 10)) {
    out.note = fmt::format(
        "not tested: {} residuals for {} parameters leave too few degrees of freedom (at least "
        "as many as the parameters, and 10)",
        m * d, k);
    return out;
  }
  const Eigen::VectorXd base = problem.weights.size() ? problem.weights : Eigen::VectorXd::Ones(m);
  // |e|^2 / s^2 > chi^2_d(1 - alpha / m), as a threshold on the RMS component.
  out.threshold = outlier_threshold(alpha, m, d);
  out.tested = true;
  Eigen::MatrixXd e = pose_residuals(problem, solution.parameters, base);
  out.robust_sd = robust_sd(e);
  if (!(out.robust_sd > 0)) {
    out.note = "not tested: the residuals' robust sd is zero";
    out.tested = false;
    return out;
  }
  Eigen::VectorXd u = statistics_of(e, out.robust_sd);
  std::set<int> flagged;
  for (int i = 0; i < m; ++i) {
    if (u[i] > out.threshold) flagged.insert(i);
  }
  const Eigen::MatrixXd least_squares_e = e;
  const Eigen::VectorXd least_squares_u = u;
  Eigen::VectorXd robust = Eigen::VectorXd::Ones(m);
  if (!flagged.empty() && loss != RobustLoss::kNone) {
    // Iteratively reweighted least squares, from the least-squares fit, with
    // the scale re-estimated at each fit.
    KinematicProblem warm = problem;
    KinematicSolution current = solution;
    for (int it = 0; it < kMaxReweightings; ++it) {
      Eigen::VectorXd next(m);
      for (int i = 0; i < m; ++i) next[i] = loss_weight(loss, u[i]);
      const double change = (next - robust).cwiseAbs().maxCoeff();
      robust = next;
      warm.weights = base.cwiseProduct(robust.cwiseSqrt());
      warm.model.set_kinematic_parameters(current.parameters);
      KinematicSolution refit = solve_kinematics(warm, identified, max_iterations);
      ++out.iterations;
      if (refit.termination != SolveTermination::kConverged) {
        out.note = "the reweighted fit did not converge (" + refit.message +
                   "): the least-squares fit is kept";
        robust.setOnes();
        current = solution;
        break;
      }
      current = refit;
      e = pose_residuals(problem, current.parameters, base);
      out.robust_sd = robust_sd(e);
      u = statistics_of(e, out.robust_sd);
      if (change < kWeightTolerance) break;
    }
    if (robust.minCoeff() < 1) {
      out.reweighted = true;
      problem.weights = base.cwiseProduct(robust.cwiseSqrt());
      // The iterations count on from the least-squares fit's.
      current.iterations += solution.iterations;
      solution = current;
    }
    // Named: the poses flagged at the robust fit (the least-squares fit's if none).
    std::set<int> robust_flagged;
    for (int i = 0; i < m; ++i) {
      if (u[i] > out.threshold) robust_flagged.insert(i);
    }
    if (robust_flagged.empty()) {
      e = least_squares_e;
      u = least_squares_u;
    } else {
      flagged = robust_flagged;
    }
  }
  for (int i : flagged) {
    OutlierPose o;
    o.pose = i;
    o.residual = e.row(i).norm() / base[i];
    o.statistic = u[i];
    o.weight = robust[i];
    out.outliers.push_back(o);
  }
  return out;
}

SuspectFit check_suspect(const KinematicFit& fit, const KinematicProblem& problem,
                         const DeviceModel& nominal_in_frame, const Log& poses,
                         const Eigen::VectorXd& weights) {
  SuspectFit out;
  out.repeatability_limit = kSuspectRepeatabilityRatio;
  if (std::isfinite(fit.repeatability) && fit.repeatability > 0) {
    out.repeatability_ratio = fit.rms_after / fit.repeatability;
    if (out.repeatability_ratio > kSuspectRepeatabilityRatio) {
      out.reasons.push_back(fmt::format(
          "the training RMS residual, {:.4g} mm, is {:.0f} times the repeatability measured on "
          "these data ({:.4g} mm; a fit of the model explains the poses to within {:.0f} times "
          "it): the set-up moved during the measurements, or the model lacks an error",
          fit.rms_after * 1e3, out.repeatability_ratio, fit.repeatability * 1e3,
          kSuspectRepeatabilityRatio));
    }
  }
  if (std::isfinite(fit.cv_rms) && !problem.labelled()) {
    // The nominal model, readings compensated by its own transmissions, with
    // its base pose alone fitted (Levenberg-Marquardt over the base slots).
    KinematicProblem base_only = problem;
    base_only.model = nominal_in_frame;
    base_only.weights = weights;
    const StepTwoJoints step_two(nominal_in_frame);
    for (int i = 0; i < poses.rows; ++i) base_only.joints[i] = step_two.row(poses, i);
    const ChainStructure s = nominal_in_frame.structure();
    std::vector<int> base_slots;
    for (int k = 0; k < s.base_slots(); ++k) base_slots.push_back(k);
    // The instrument's zero too if the fit identified it (a set-up unknown).
    if (s.instrument && identified_instrument_zero(fit) != 0) {
      base_slots.push_back(s.instrument_slot());
    }
    const KinematicSolution fitted = solve_kinematics(base_only, base_slots, 50);
    const detail::RowsOf kind = detail::rows_of(base_only);
    const double rss =
        detail::position_rss(detail::residuals_at(s, fitted.parameters, base_only.joints, kind,
                                                  base_only.measured, weights),
                             kind);
    out.nominal_base_fitted_rms = std::sqrt(rss / std::max(fit.rows, 1));
    out.cv_ratio = fit.cv_rms / out.nominal_base_fitted_rms;
    if (out.cv_ratio > 1) {
      out.reasons.push_back(fmt::format(
          "the cross-validated RMS, {:.4g} mm, is {:.2f} times the nominal model's with only its "
          "base pose fitted ({:.4g} mm): the calibration predicts new poses worse than no "
          "calibration",
          fit.cv_rms * 1e3, out.cv_ratio, out.nominal_base_fitted_rms * 1e3));
      if (out.cv_ratio > kWorseThanNominalRatio) out.worse_than_nominal = out.reasons.back();
    }
  }
  out.suspect = !out.reasons.empty();
  return out;
}

namespace detail {

// The rows of `rows` in all (ascending) that are not in `left_out`.
std::vector<int> kept_rows(int rows, const std::vector<int>& left_out) {
  std::vector<int> out;
  for (int r = 0; r < rows; ++r) {
    if (!std::binary_search(left_out.begin(), left_out.end(), r)) out.push_back(r);
  }
  return out;
}

// A small log's poses whose held-out error stood out (ModelSearch::outliers):
// the calibration again without them (at most held_out_outlier_rounds times),
// they named (weight 0); unusable (kImplausible) if too few poses are left.
CalibrationResult without_held_out_outliers(const DeviceModel& nominal, const Log& log,
                                            const CalibrationOptions& options,
                                            CalibrationResult result) {
  const ModelSearch& search = result.kinematics.search;
  if (search.outliers.empty() || options.held_out_outlier_rounds <= 0) return result;
  std::vector<int> rows;
  std::vector<OutlierPose> named;
  for (const ModelSearch::HeldOutOutlier& o : search.outliers) {
    rows.insert(rows.end(), o.rows.begin(), o.rows.end());
    OutlierPose pose;
    pose.pose = -1;  // not among the poses fitted
    for (int r : o.rows) pose.lines.push_back(log.line[static_cast<size_t>(r)]);
    pose.residual = o.error;
    pose.statistic = o.statistic;
    pose.weight = 0;
    named.push_back(std::move(pose));
  }
  std::sort(rows.begin(), rows.end());
  std::string lines;
  for (const OutlierPose& p : named) {
    for (int line : p.lines) lines += (lines.empty() ? "" : ", ") + std::to_string(line);
  }
  const std::string note = fmt::format(
      "outliers on few poses: log line{} {} held out predicted beyond {:.1f} robust scales of "
      "the poses' held-out errors (a pose held out cannot hide in the fit): calibrated again "
      "without {}",
      rows.size() == 1 ? "" : "s", lines, search.outlier_threshold,
      named.size() == 1 ? "it" : "them");
  CalibrationOptions once = options;
  --once.held_out_outlier_rounds;
  CalibrationResult again;
  try {
    again = calibrate(nominal, without_rows(log, rows), once);
  } catch (const InputError& e) {
    result.status = CalibrationStatus::kImplausible;
    result.status_reason = note + "; too few poses are left: " + e.message();
    return result;
  }
  RobustFit& robust = again.kinematics.robust;
  robust.outliers.insert(robust.outliers.begin(), named.begin(), named.end());
  if (robust.threshold == 0) robust.threshold = search.outlier_threshold;
  // The rows as the caller's log numbers them (a later round's are of fewer).
  std::vector<ModelSearch::HeldOutOutlier> all = search.outliers;
  const std::vector<int> kept = kept_rows(log.rows, rows);
  for (ModelSearch::HeldOutOutlier& o : again.kinematics.search.outliers) {
    for (int& r : o.rows) r = kept[static_cast<size_t>(r)];
    all.push_back(o);
  }
  again.kinematics.search.outliers = all;
  again.kinematics.search.outlier_threshold = search.outlier_threshold;
  again.notes.insert(again.notes.begin(), note);
  return again;
}

}  // namespace detail

}  // namespace hapticcal
