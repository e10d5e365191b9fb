// ISO 9283's test simulated after a study's calibrations (study/iso9283.hpp:
// IsoSimulation), its expected AP from the calibration's covariance, and the
// tests summarised over the trials.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <Eigen/Dense>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <utility>

#include "hapticcal/identification/information.hpp"
#include "hapticcal/identification/two_step.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/study/iso9283.hpp"
#include "hapticcal/study/study.hpp"
#include "study/fitted_step_one.hpp"

namespace hapticcal {
namespace {

// The identified kinematic parameters' estimates, in the fit's order (that of
// its correlation matrix).
std::vector<const ParameterEstimate*> identified(const KinematicFit& fit) {
  std::vector<const ParameterEstimate*> out;
  for (const std::string& name : fit.identified_names) {
    for (const ParameterEstimate& e : fit.parameters) {
      if (e.name == name) out.push_back(&e);
    }
  }
  return out;
}

// The covariance the kinematic fit states: its sd and correlations.
Eigen::MatrixXd stated_covariance(const KinematicFit& fit,
                                  const std::vector<const ParameterEstimate*>& estimates) {
  const auto n = static_cast<Eigen::Index>(estimates.size());
  Eigen::MatrixXd C(n, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index j = 0; j < n; ++j)
      C(i, j) = estimates[i]->sd * estimates[j]->sd * fit.correlation(i, j);
  }
  return C;
}

// The covariance of the two-step estimate as calibrate computes it (least
// squares, each row weighted alike) when the rows' sd differ: step 2's
// kinematic covariance A J^T V J A (A = (J^T J)^-1, V the rows' variances: the
// sandwich), each step-1 block sigma_e^2 (J_e^T J_e)^-1 carried in through
// G = -A J^T J_t (information.hpp's two_step_covariance with one sd for every
// row); in its order: each joint's step-1 parameters, then the kinematic ones.
Eigen::MatrixXd two_step_sandwich(const TwoStepJacobians& J, const Eigen::VectorXd& row_variance,
                                  double sigma_encoder) {
  const Eigen::MatrixXd& Jk = J.kinematic;
  const Eigen::Index k = Jk.cols();
  Eigen::Index t = 0;
  for (const StepOneSensitivity& s : J.step_one) t += s.encoder.cols() - 1;
  // (J^T J)^-1 with an infinite variance where the rows do not see a
  // direction (parameter_covariance), so that the prediction is NaN, not small.
  const Eigen::MatrixXd A = parameter_covariance(Jk, 1.0);
  const Eigen::MatrixXd AJt = A * Jk.transpose();
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(t + k, t + k);
  C.bottomRightCorner(k, k) = AJt * row_variance.asDiagonal() * AJt.transpose();
  Eigen::Index at = 0;
  for (const StepOneSensitivity& s : J.step_one) {
    const Eigen::Index np = s.encoder.cols() - 1;
    const Eigen::MatrixXd C1 = parameter_covariance(s.encoder, sigma_encoder).topLeftCorner(np, np);
    const Eigen::MatrixXd GC1 = -AJt * s.measurement * C1;
    C.block(at, at, np, np) = C1;
    C.block(t, at, k, np) = GC1;
    C.block(at, t, np, k) = GC1.transpose();
    C.bottomRightCorner(k, k) += GC1 * (-AJt * s.measurement).transpose();
    at += np;
  }
  return C;
}

}  // namespace

std::vector<double> iso_predicted_ap(const CalibrationResult& calibration,
                                     const Log& identification, const IsoInstrumentNoise& noise,
                                     const IsoCubePlan& plan, double scatter) {
  const KinematicFit& fit = calibration.kinematics;
  const std::vector<const ParameterEstimate*> estimates = identified(fit);
  std::vector<int> slots;
  for (const ParameterEstimate* e : estimates) slots.push_back(e->slot);
  const bool fixture = is_fixture(fit.type);
  const std::vector<StepOneModel> step_one =
      fixture ? std::vector<StepOneModel>{} : detail::fitted_step_one(calibration);
  Eigen::MatrixXd C;
  if (fixture) {
    C = stated_covariance(fit, estimates);
  } else {
    const TwoStepJacobians at_identification = two_step_jacobians(
        calibration.calibrated, fit.type, fit.rotation_scale, slots, step_one, identification.q);
    // Each row's variance: a distance's or a position coordinate's, a pose's
    // rotation rows (the last three of each tip's six) scaled as the fit scales them.
    Eigen::VectorXd variance(at_identification.kinematic.rows());
    for (Eigen::Index r = 0; r < variance.size(); ++r) {
      variance[r] = rotation_row(fit.type, static_cast<int>(r))
                        ? std::pow(fit.rotation_scale * noise.rotation, 2)
                        : noise.measurement * noise.measurement;
    }
    C = two_step_sandwich(at_identification, variance, noise.encoder);
  }
  Eigen::MatrixXd readings(static_cast<Eigen::Index>(plan.poses.size()),
                           calibration.calibrated.dof());
  for (size_t k = 0; k < plan.poses.size(); ++k)
    readings.row(static_cast<Eigen::Index>(k)) = plan.poses[k].readings.transpose();
  const TwoStepJacobians at_poses = two_step_jacobians(
      calibration.calibrated, MeasurementType::kPosition, 1.0, slots, step_one, readings);
  // G: the step-1 columns of each joint (their order in C), then the kinematic ones.
  Eigen::MatrixXd G(at_poses.kinematic.rows(), C.cols());
  Eigen::Index column = 0;
  for (const StepOneSensitivity& s : at_poses.step_one) {
    G.middleCols(column, s.measurement.cols()) = s.measurement;
    column += s.measurement.cols();
  }
  G.rightCols(at_poses.kinematic.cols()) = at_poses.kinematic;
  std::vector<double> out;
  const double mean_scatter = 3 * scatter * scatter / plan.cycles;
  for (Eigen::Index k = 0; k < readings.rows(); ++k) {
    const Eigen::MatrixXd g = G.middleRows(3 * k, 3);
    const double v = (g * C * g.transpose()).trace() + mean_scatter;
    out.push_back(std::isfinite(v) && v >= 0 ? std::sqrt(v)
                                             : std::numeric_limits<double>::quiet_NaN());
  }
  return out;
}

IsoTrial simulate_iso_test(const Scenario& sc, const Log& identification,
                           const CalibrationResult& full, std::uint64_t seed) {
  const IsoSimulation& iso = *sc.iso9283;
  const PreparedModel truth(sc.actual), nominal(sc.nominal), calibrated(full.calibrated);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> scatter(0, iso.scatter > 0 ? iso.scatter : 1.0);
  std::vector<IsoPoseRuns> by_nominal, by_calibrated;
  for (const IsoTestPose& pose : iso.plan.poses) {
    IsoPoseRuns runs;
    runs.label = pose.label;
    const Frame<double> attained = truth.forward(pose.readings.data());
    for (int cycle = 1; cycle <= iso.plan.cycles; ++cycle) {
      Frame<double> at = attained;
      // One draw at a time (reproducible); none without scatter (an sd of 0
      // is not a normal distribution's).
      for (int a = 0; a < 3 && iso.scatter > 0; ++a) at.p[a] += scatter(rng);
      runs.cycles.push_back(cycle);
      runs.attained.push_back(at);
    }
    runs.commanded = nominal.forward(pose.readings.data());
    by_nominal.push_back(runs);
    runs.commanded = calibrated.forward(pose.readings.data());
    by_calibrated.push_back(std::move(runs));
  }
  IsoTrial t;
  t.nominal = iso_criteria(by_nominal);
  t.calibrated = iso_criteria(by_calibrated);
  const IsoInstrumentNoise noise{measurement_sigma(sc), sc.noise.sigma_orientation,
                                 sc.noise.sigma_ext};
  t.predicted_ap = iso_predicted_ap(full, identification, noise, iso.plan, iso.scatter);
  return t;
}

IsoStudy iso_study(const Scenario& sc, const std::vector<TrialResult>& trials) {
  std::vector<IsoTrial> tests;
  std::map<std::string, std::string> unseen;  // by name, over every trial
  for (const TrialResult& t : trials) {
    tests.push_back(*t.iso);
    for (const StudyRow& row : study_rows(sc, t.full)) {
      if (row.capstan || row.held.empty() || row.assigned == row.nominal) continue;
      unseen[row.name] =
          fmt::format("{} {:+.3f} {}", row.name, (row.assigned - row.nominal) * row.paper_scale,
                      row.paper_unit);
    }
  }
  IsoStudy study = summarise_iso_trials(sc.iso9283->plan, std::move(tests));
  if (!unseen.empty()) {
    std::vector<std::string> named;
    for (const auto& [name, text] : unseen) named.push_back(text);
    study.notes.push_back(fmt::format(
        "The truth deviates in parameters the calibration held ({}): their error is in the "
        "simulated AP, not in the prediction.",
        fmt::join(named, ", ")));
  }
  if (!sc.keep_all) {
    study.notes.push_back(
        "The trials ran calibrate's model search with its tolerance prior (calibration: "
        "{keep_all: false}); the prediction treats the parameters kept as a least-squares "
        "estimate and does not account for the prior.");
  }
  if (study.left_out > 0) {
    study.notes.push_back(fmt::format(
        "{} of {} poses of the trials have no prediction (the calibration's covariance is not "
        "finite) and are left out of the calibrated and predicted AP.",
        study.left_out, study.trials.size() * sc.iso9283->plan.poses.size()));
  }
  return study;
}

IsoStudy summarise_iso_trials(const IsoCubePlan& plan, std::vector<IsoTrial> trials) {
  IsoStudy out;
  const auto rms = [](double sum_of_squares, int n) {
    return n > 0 ? std::sqrt(sum_of_squares / n) : std::numeric_limits<double>::quiet_NaN();
  };
  double all_nominal = 0, all_calibrated = 0, all_predicted = 0;
  int all = 0, all_compared = 0;
  for (size_t k = 0; k < plan.poses.size(); ++k) {
    IsoPoseSummary pose;
    pose.label = plan.poses[k].label;
    pose.point = plan.poses[k].pose.p;
    double nominal = 0, calibrated = 0, predicted = 0, rp = 0;
    int n = 0, compared = 0, repeated = 0;
    for (const IsoTrial& t : trials) {
      const double ap = t.calibrated.poses[k].ap, expected = t.predicted_ap[k];
      nominal += std::pow(t.nominal.poses[k].ap, 2);
      ++n;
      // The calibrated model and its prediction side by side where both are numbers.
      if (std::isfinite(ap) && std::isfinite(expected)) {
        calibrated += ap * ap;
        predicted += expected * expected;
        ++compared;
      }
      if (std::isfinite(t.calibrated.poses[k].rp)) {
        rp += t.calibrated.poses[k].rp;
        ++repeated;
      }
    }
    pose.ap_nominal = rms(nominal, n);
    pose.ap_calibrated = rms(calibrated, compared);
    pose.ap_predicted = rms(predicted, compared);
    pose.rp = repeated > 0 ? rp / repeated : std::numeric_limits<double>::quiet_NaN();
    out.poses.push_back(pose);
    all_nominal += nominal;
    all_calibrated += calibrated;
    all_predicted += predicted;
    all += n;
    all_compared += compared;
  }
  out.ap_nominal = rms(all_nominal, all);
  out.ap_calibrated = rms(all_calibrated, all_compared);
  out.ap_predicted = rms(all_predicted, all_compared);
  out.left_out = all - all_compared;
  out.trials = std::move(trials);
  return out;
}

std::string iso_trials_csv(const IsoStudy& study) {
  std::string csv = "trial,pose,ap_nominal,ap_calibrated,ap_predicted,rp\n";
  for (size_t t = 0; t < study.trials.size(); ++t) {
    const IsoTrial& trial = study.trials[t];
    for (size_t k = 0; k < trial.calibrated.poses.size(); ++k) {
      csv += fmt::format("{},{},{},{},{},{}\n", t + 1, trial.calibrated.poses[k].label,
                         trial.nominal.poses[k].ap, trial.calibrated.poses[k].ap,
                         trial.predicted_ap[k], trial.calibrated.poses[k].rp);
    }
  }
  return csv;
}

}  // namespace hapticcal
