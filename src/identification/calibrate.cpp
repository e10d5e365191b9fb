// The whole calibration: step 1, step 2, the model selection
// and the fit's statistics, composed of the public stages.
#include <ceres/ceres.h>
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <map>
#include <numeric>
#include <random>
#include <unordered_map>

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/identification/log_fit.hpp"
#include "hapticcal/identification/markers.hpp"
#include "hapticcal/identification/measurement.hpp"
#include "hapticcal/identification/registration.hpp"
#include "hapticcal/identification/tree.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "identification/calibration_run.hpp"
#include "identification/families/family.hpp"
#include "identification/problem/measurement_cost.hpp"
#include "identification/problem/solver_options.hpp"
#include "identification/problem/stack.hpp"
#include "identification/search/prior.hpp"

namespace hapticcal {
namespace {

using detail::beta_left_out_reason;
using detail::CalibrationRun;
using detail::check_encoder_readings;
using detail::check_enough_rows;
using detail::check_joint_limits;
using detail::check_nominal;
using detail::check_options;
using detail::check_reach;
using detail::conclude_step_one;
using detail::fold_joint_errors;
using detail::kFixtureIterations;
using detail::kIterations;
using detail::measurement_cost;
using detail::measurement_rms;
using detail::names_of;
using detail::offer_joint_errors;
using detail::position_rss;
using detail::prepare_model;
using detail::residuals_at;
using detail::rows_of;
using detail::RowsOf;
using detail::Stack;
using detail::stack;

}  // namespace

double identified_instrument_zero(const KinematicFit& fit) {
  for (const ParameterEstimate& e : fit.parameters) {
    if (e.name == "instrument.zero" && e.identifiable) return e.value;
  }
  return 0;
}

namespace {

// What the identified zero of a distance instrument means for the user.
std::string instrument_zero_note(const ParameterEstimate& zero) {
  return fmt::format(
      "the distances carry an instrument zero (instrument.zero) of {:+.3f} +- {:.3f} mm, fitted "
      "with the device: the encoder's offset, not the device's, so the calibrated model leaves "
      "it out; subtract it from this encoder's readings (--fix instrument.zero assumes none)",
      zero.value * 1e3, zero.sd * 1e3);
}

// How far the measurement frame (base) and the tool point moved: the set-up's
// unknowns, reported, not flagged.
std::string setup_change_note(const DeviceModel& nominal, const DeviceModel& calibrated) {
  const Frame<double> b0 = pose_frame(nominal.base), b1 = pose_frame(calibrated.base);
  double tool = 0;  // the largest move of a tool point (a tree's tips each have one)
  for (int t = 0; t < nominal.tips(); ++t)
    tool = std::max(
        tool, (pose_frame(calibrated.tip_tool(t)).p - pose_frame(nominal.tip_tool(t)).p).norm());
  return fmt::format(
      "the measurement frame (base) moved {:.1f} mm and {:.2f} deg from the model's, the tool "
      "point {:.1f} mm: the set-up's unknowns (the tracker's frame, the marker's offset), not "
      "changes of the robot",
      (b1.p - b0.p).norm() * 1e3, Eigen::AngleAxisd(b0.R.transpose() * b1.R).angle() * 180 / M_PI,
      tool * 1e3);
}

// The outcome: a numerical failure, then no convergence, then parameters the
// data do not excite; else converged.
void set_status(CalibrationResult& result, const std::vector<int>& identified) {
  const KinematicFit& fit = result.kinematics;
  bool finite = std::isfinite(fit.rms_after) && std::isfinite(fit.rms_before) &&
                result.calibrated.kinematic_parameters().allFinite();
  std::string unexcited, transmissions_failed;
  for (const ParameterEstimate& e : fit.parameters) {
    finite = finite && (!e.identifiable || std::isfinite(e.sd));
    if (detail::unexcited(e.reason)) unexcited += (unexcited.empty() ? "" : ", ") + e.name;
  }
  for (const TransmissionFit& t : result.transmissions) {
    finite = finite && t.value.allFinite() && std::isfinite(t.offset) && std::isfinite(t.rms_after);
    if (!t.converged) {
      transmissions_failed +=
          (transmissions_failed.empty() ? "" : ", ") + result.calibrated.links[t.joint].name;
    }
  }
  if (!finite || fit.numerical_failure) {
    result.status = CalibrationStatus::kNumericalFailure;
    result.status_reason = fit.numerical_failure
                               ? "the solver failed: " + fit.termination
                               : "the fit produced non-finite values (a measurement too large "
                                 "for the model, or a degenerate model)";
  } else if (!transmissions_failed.empty()) {
    result.status = CalibrationStatus::kNotConverged;
    result.status_reason =
        "the transmission fit (step 1) did not converge for " + transmissions_failed;
  } else if (!identified.empty() && !fit.converged) {
    result.status = CalibrationStatus::kNotConverged;
    result.status_reason = fmt::format("Levenberg-Marquardt did not converge in {} iterations ({})",
                                       fit.iterations, fit.termination);
  } else if (identified.empty() && fit.model_selection && fit.structurally_identified > 0) {
    result.status = CalibrationStatus::kConverged;
    result.status_reason =
        "model selection: these data support no change from the model (every identifiable "
        "parameter held at nominal)";
  } else if (identified.empty()) {
    result.status = CalibrationStatus::kRankDeficient;
    result.status_reason = "no parameter is identifiable from these measurements";
  } else if (fit.rank_deficient) {
    result.status = CalibrationStatus::kRankDeficient;
    result.status_reason = "these measurements do not excite " + unexcited +
                           " (measure poses that move them, or hold them with --fix to calibrate "
                           "the rest)";
  } else {
    result.status = CalibrationStatus::kConverged;
    result.status_reason = fmt::format("converged in {} iterations", fit.iterations);
  }
}

// The outliers' log lines (the rows of their poses), and a note of how many
// were flagged and whether they were down-weighted.
void name_outliers(RobustFit& robust, const Log& log, const std::vector<std::vector<int>>& poses,
                   std::vector<std::string>& notes) {
  for (OutlierPose& o : robust.outliers) {
    for (int row : poses[static_cast<size_t>(o.pose)]) o.lines.push_back(log.line[row]);
  }
  if (robust.outliers.empty()) return;
  notes.push_back(fmt::format(
      "{} pose{} flagged as outlier{} (residual beyond {:.2f} robust sds of {:.4g} mm, Bonferroni "
      "over the poses): {}",
      robust.outliers.size(), robust.outliers.size() == 1 ? "" : "s",
      robust.outliers.size() == 1 ? "" : "s", robust.threshold, robust.robust_sd * 1e3,
      robust.reweighted ? fmt::format("down-weighted by the {} loss (--loss none: plain least "
                                      "squares)",
                                      to_string(robust.loss))
                        : std::string("not down-weighted") +
                              (robust.note.empty() ? " (--loss none)" : " (" + robust.note + ")")));
}

// --strict: a suspect fit is unusable; so is, always, one that predicts
// held-out poses worse than the nominal model with its frame registered.
void refuse_suspect(CalibrationResult& result, bool strict) {
  const SuspectFit& suspect = result.kinematics.suspect;
  if (!suspect.suspect || result.status != CalibrationStatus::kConverged) return;
  if (!strict && suspect.worse_than_nominal.empty()) return;
  result.status = CalibrationStatus::kSuspect;
  result.status_reason = strict ? "suspect fit (--strict): " + suspect.reasons.front()
                                : "suspect fit: " + suspect.worse_than_nominal;
}

}  // namespace

namespace {

// The poses of the fit: a sample of the log's (--samples), repeats of a pose
// averaged (one pose, one row of the fit).
void prepare_poses(CalibrationRun& run) {
  std::vector<std::vector<int>> all_poses = repeated_poses(run.log);
  detail::screen_repeats(run.log, all_poses, run.options.outlier_alpha, run.result.notes);
  for (int g :
       sample_rows(static_cast<int>(all_poses.size()), run.options.samples, run.options.seed)) {
    run.result.poses.push_back(all_poses[g]);
    run.result.rows.push_back(all_poses[g].front());
    run.repeats.push_back(static_cast<int>(all_poses[g].size()));
  }
  run.poses = average_repeats(run.log, run.result.poses);
  if (run.options.transmissions) {
    // Step 2 fits the coupling's coefficients (not a step-1-only log's run).
    const std::vector<std::string>& families = run.options.joint_errors;
    const bool coupling_fitted =
        !encoders_only(run.log) &&
        std::find(families.begin(), families.end(), "coupling") != families.end();
    encoders_at_readings(run.nominal, run.poses, run.result.notes, coupling_fitted);
  }
  run.m = run.poses.rows;
  KinematicFit& fit = run.fit();
  fit.type = measurement_type(run.log);
  fit.poses = run.m;
  fit.rows = std::accumulate(run.repeats.begin(), run.repeats.end(), 0);
  fit.repeatability = encoders_only(run.log)
                          ? std::numeric_limits<double>::quiet_NaN()
                          : detail::repeatability(run.log, run.result.poses, fit.type);
  if (holds(run.log, MeasurementType::kPosition) && holds(run.log, MeasurementType::kDistance)) {
    run.result.notes.push_back("the log has positions and distances: positions are used");
  }
}

// A distance instrument's own zero (a cable encoder's offset) is a candidate
// of step 2, after every parameter of the device. `step2_nominal` is the
// nominal with it (at zero): step 2's parameter vector.
// --fix instrument.zero (or options.instrument_zero false): no slot at all.
// (Other logs have no such parameter: fixing it is refused as unknown.)
void offer_instrument_zero(CalibrationRun& run) {
  const bool distances = run.zero_offered();
  run.fix = run.options.fix;
  const auto fixed_zero = std::find(run.fix.begin(), run.fix.end(), "instrument.zero");
  const bool zero_fixed = distances && fixed_zero != run.fix.end();
  if (zero_fixed) run.fix.erase(fixed_zero);
  if (distances && !zero_fixed) run.model.instrument_zero = 0.0;
  run.step2_nominal = run.nominal;
  run.step2_nominal.instrument_zero = run.model.instrument_zero;
}

// Step 2's problem: the poses with step 1's transmissions, the candidates,
// the measurement frame registered if it is unknown, the nominal checked.
void build_problem(CalibrationRun& run) {
  run.problem = kinematic_problem(run.model, run.poses, run.repeats, run.options);
  run.candidates = candidate_slots(run.model, run.fix, run.options.free);
  run.tolerance = detail::slot_tolerances(run.model, run.options.tolerances);
  if (run.m < 2) check_enough_rows(run, run.candidates.size(), "candidate");
  KinematicFit& fit = run.fit();
  fit.frame_registered = register_measurement_frame(run.problem, run.candidates, run.result.notes);
  run.problem.frame_unknown =
      measurement_frame_unknown(run.problem, run.candidates, fit.frame_registered);
  fit.length_scale = run.problem.length_scale;
  fit.rotation_scale = run.problem.rotation_scale;
  check_nominal(run);
}

// Identifiability, then Levenberg-Marquardt over the identified parameters,
// outliers named and down-weighted by the robust loss (problem.weights).
void identify_and_solve(CalibrationRun& run) {
  const IdentifiabilityAnalysis analysis =
      analyze_identifiability(run.problem, run.candidates, run.options.dependency_tolerance);
  run.identified = analysis.identified;
  run.reason = analysis.reason;
  run.scale = analysis.scale;
  KinematicFit& fit = run.fit();
  fit.rank_deficient = analysis.rank_deficient;
  check_enough_rows(run,
                    run.identified.size() +
                        std::count_if(run.reason.begin(), run.reason.end(),
                                      [](const auto& r) { return detail::unexcited(r.second); }),
                    "identifiable");
  fit.structurally_identified = static_cast<int>(run.identified.size());
  // A fixture problem's cost is flat along motions its unknown points nearly
  // absorb: Levenberg-Marquardt needs more steps (the MUKCa Panda: up to 130).
  run.iterations = run.problem.labelled() ? kFixtureIterations : kIterations;
  run.solution = solve_kinematics(run.problem, run.identified, run.iterations);
  reform_on_fit(run);
  run.plain_weights = run.problem.weights;
  fit.robust = reweight_outliers(run.problem, run.identified, run.solution, run.options.loss,
                                 run.options.outlier_alpha, run.iterations);
  name_outliers(fit.robust, run.log, run.result.poses, run.result.notes);
  detail::restack(run);
  for (const ParameterInfo& pi : run.model.parameter_info()) run.name[pi.slot] = pi.name;
}

// Cross-validation (--folds), the solver's outcome, and the calibrated model:
// angles are periodic, so a step that went round (a real fit turned a flange's
// pitch by 11 rad) is the same model with the deviation in (-pi, pi].
void finish_solution(CalibrationRun& run) {
  KinematicFit& fit = run.fit();
  const KinematicSolution& solution = run.solution;
  fit.identified = static_cast<int>(run.identified.size());
  if (run.options.folds >= 2 && solution.termination == SolveTermination::kConverged) {
    const CrossValidation cv = held_out(run);
    fit.cv_rms = cv.rms;
    fit.cv_folds = cv.folds;
    fit.cv_note = cv.note;
  } else if (run.options.folds >= 2) {
    fit.cv_note = "not computed: the fit did not converge";
  }
  fit.converged = solution.termination == SolveTermination::kConverged;
  fit.numerical_failure = solution.termination == SolveTermination::kFailure;
  fit.iterations = solution.iterations;
  fit.termination = solution.message;
  if (solution.termination == SolveTermination::kNothingToSolve) {
    run.result.notes.push_back(fit.termination);
  } else if (!fit.converged) {
    run.result.notes.push_back("step 2 did not converge: " + solution.message);
  }
  run.p = detail::angles_near(run.problem.model, solution.parameters,
                              run.problem.model.kinematic_parameters());
  const ChainStructure s = run.model.structure();
  run.model = run.problem.model;
  run.model.set_kinematic_parameters(run.p);
  const Eigen::VectorXd r = residuals_at(s, run.p, run.problem.joints, run.kind(),
                                         run.problem.measured, run.problem.weights);
  fit.rms_after = measurement_rms(position_rss(r, run.kind()), fit.rows);
  fit.tip_rms_after = detail::tip_rms(run.problem, r, run.kind(), run.plain_weights);
}

// The factor of the prior's rows in the covariance: 1, or with --sigma the
// given sigma over the evidence's.
double prior_row_scale(const CalibrationRun& run) {
  const PriorFit& prior = run.fit().prior;
  return run.options.sigma && prior.sigma > 0 ? *run.options.sigma / prior.sigma : 1.0;
}

// Uncertainty, conditioning and observability of the identified parameters.
void fit_statistics(CalibrationRun& run) {
  KinematicFit& fit = run.fit();
  const Stack& data = run.data;
  const int k = static_cast<int>(run.identified.size());
  // With the tolerance prior its rows below the measurements' (k of them, zero
  // for a free parameter): the posterior covariance; the residual's freedom
  // less the effective parameters.
  const bool prior = run.prior_weight.size() > 0;
  const Eigen::Index rows = data.J.rows() + (prior ? k : 0);
  Eigen::MatrixXd Ji = Eigen::MatrixXd::Zero(rows, k), Js(rows, k);
  for (int c = 0; c < k; ++c) {
    Ji.col(c).head(data.J.rows()) = data.J.col(run.identified[c]);
    // With --sigma the prior's rows are sigma / (scale t), not the evidence's
    // sigma / (scale t): the covariance is then sigma^2 (J^T J + ...)^-1.
    if (prior)
      Ji(data.J.rows() + c, c) = run.prior_weight[run.identified[c]] * prior_row_scale(run);
    Js.col(c) = Ji.col(c) / run.scale[run.identified[c]];
  }
  const double parameters = prior ? run.fit().prior.effective_parameters : k;
  // Each eliminated fixture point or plane is 3 unknowns the projection took out.
  const double dof_residual =
      static_cast<double>(data.residuals - run.problem.labels.unknowns()) - parameters;
  fit.sigma_given = run.options.sigma.has_value();
  fit.sigma =
      run.options.sigma ? *run.options.sigma : std::sqrt(data.rss / std::max(dof_residual, 1.0));
  // From the eigen-decomposition of the small normal matrices J^T J: the
  // covariance sigma^2 (J^T J)^-1, and the singular values of the scaled J.
  run.covariance = parameter_covariance(Ji, fit.sigma);
  // The data's conditioning: the measurements' rows only (the prior's would
  // make a parameter the data do not see look well conditioned).
  const Conditioning scaled_conditioning = conditioning(
      Js.topRows(data.J.rows()), static_cast<double>(fit.rows) * traits(fit.type).dimension);
  fit.condition_number = scaled_conditioning.condition_number;
  fit.observability = scaled_conditioning.observability;
  fit.correlation.resize(k, k);
  const Eigen::MatrixXd& covariance = run.covariance;
  for (int a = 0; a < k; ++a) {
    fit.identified_names.push_back(run.name[run.identified[a]]);
    for (int b = 0; b < k; ++b) {
      fit.correlation(a, b) = covariance(a, b) / std::sqrt(covariance(a, a) * covariance(b, b));
    }
  }
}

// One parameter's estimate: its value and sd if identified (with its largest
// correlation and whether it moved far), else why it was held.
ParameterEstimate parameter_estimate(const CalibrationRun& run, const ParameterInfo& pi) {
  ParameterEstimate e;
  e.name = pi.name;
  e.slot = pi.slot;
  e.unit = pi.unit;
  e.nominal = run.step2_nominal.kinematic_parameters()[pi.slot];
  e.value = run.p[pi.slot];
  const std::vector<int>& identified = run.identified;
  const Eigen::MatrixXd& covariance = run.covariance;
  const auto it = std::find(identified.begin(), identified.end(), pi.slot);
  if (it != identified.end()) {
    const int c = static_cast<int>(it - identified.begin());
    e.identifiable = true;
    e.sd = std::sqrt(covariance(c, c));
    if (run.prior_weight.size() && std::isfinite(run.tolerance[pi.slot])) {
      e.prior_sd = run.fit().prior.scale * run.tolerance[pi.slot];
      e.data_share = run.data_share[pi.slot];
      e.set_by_prior = e.data_share < 0.5;
    }
    // An unknown frame, a marker's offset and an instrument's zero are the
    // set-up's, not the robot's.
    const bool setup =
        (run.problem.frame_unknown && pi.setup()) || pi.block == ParameterBlock::kInstrument;
    e.large_change =
        !setup && std::abs(e.value - e.nominal) >
                      (e.unit == ParameterUnit::kAngle ? kLargeChangeAngle : kLargeChangeLength);
    for (int o = 0; o < static_cast<int>(identified.size()); ++o) {
      if (o == c) continue;
      const double rho = covariance(c, o) / std::sqrt(covariance(c, c) * covariance(o, o));
      if (std::abs(rho) > std::abs(e.max_correlation)) {
        e.max_correlation = rho;
        e.max_correlation_with = run.name.at(identified[o]);
      }
    }
    e.tolerance = run.tolerance[pi.slot];
    e.determined = setup || !((std::isfinite(e.tolerance) && e.sd > e.tolerance) ||
                              std::abs(e.max_correlation) > kUndeterminedCorrelation);
  } else if (run.reason.count(pi.slot)) {
    e.reason = run.reason.at(pi.slot);
    e.held_by_selection = std::find(run.held_by_selection.begin(), run.held_by_selection.end(),
                                    pi.slot) != run.held_by_selection.end();
  } else if (std::find(run.options.fix.begin(), run.options.fix.end(), pi.name) !=
             run.options.fix.end()) {
    e.reason = "fixed by the user";
  } else {  // a beta that candidate_slots left out
    e.reason = beta_left_out_reason(run.nominal, pi.joint);
  }
  return e;
}

// The notes on the outcome, the calibrated model (without the instrument's
// zero: the instrument's, not the device's), the suspect-fit checks and the status.
void conclude(CalibrationRun& run) {
  KinematicFit& fit = run.fit();
  CalibrationResult& result = run.result;
  DeviceModel& model = run.model;
  if (run.problem.frame_unknown) result.notes.push_back(setup_change_note(run.nominal, model));
  if (fit.rank_deficient) {
    result.notes.push_back(
        "rank-deficient: these measurements do not excite every parameter the model can "
        "identify; see the parameters marked 'not excited'");
  }
  if (model.instrument_zero) {
    const ParameterEstimate& zero =
        *std::find_if(fit.parameters.begin(), fit.parameters.end(),
                      [](const ParameterEstimate& e) { return e.name == "instrument.zero"; });
    if (zero.identifiable) result.notes.push_back(instrument_zero_note(zero));
    model.instrument_zero.reset();
  }
  const std::string unfoldable = fold_joint_errors(model);
  result.calibrated = model;
  if (fit.converged) {
    DeviceModel nominal_in_frame = run.step2_nominal;
    nominal_in_frame.base = run.problem.model.base;
    fit.suspect = check_suspect(fit, run.problem, nominal_in_frame, run.poses, run.plain_weights);
  }
  // A step-1 model that does not predict its encoder to the counts.
  for (const TransmissionFit& t : result.transmissions) {
    if (!t.flagged) continue;
    fit.suspect.suspect = true;
    fit.suspect.reasons.push_back(
        step_one_flag_reason(t, run.model, *run.options.encoder_resolution));
  }
  set_status(result, run.identified);
  if (!unfoldable.empty() && result.status == CalibrationStatus::kConverged) {
    result.status = CalibrationStatus::kImplausible;
    result.status_reason = unfoldable;
  }
  refuse_suspect(result, run.options.strict);
}

}  // namespace

namespace detail {

void step_one(CalibrationRun& run) {
  run.checks_notes = run.result.notes.size();
  prepare_poses(run);
  run.model = run.nominal;
  run.result.transmissions = fit_transmissions(run.model, run.poses, run.options, run.result.notes);
}

void polish(CalibrationRun& run) {
  if (run.problem.tolerance <= kTightTolerance ||
      run.solution.termination != SolveTermination::kConverged) {
    return;
  }
  run.problem.tolerance = kTightTolerance;
  run.problem.initial = run.solution.parameters;
  const int iterations = run.solution.iterations;
  const KinematicSolution polished = solve_kinematics(run.problem, run.identified, run.iterations);
  run.problem.initial.resize(0);
  if (polished.termination != SolveTermination::kConverged) return;
  run.solution = polished;
  run.solution.iterations += iterations;
  restack(run);
}

void restack(CalibrationRun& run) {
  // The residuals and Jacobian at the fit, for selection, cross-validation and statistics.
  run.data = stack(run.model.structure(), run.solution.parameters, run.problem.joints, run.kind(),
                   run.problem.measured, run.problem.weights, run.problem.compressed);
}

void prepare_model(CalibrationRun& run, const Eigen::VectorXd& initial, double tolerance) {
  offer_instrument_zero(run);
  offer_joint_errors(run);
  build_problem(run);
  run.problem.tolerance = tolerance;
  if (initial.size() > 0 && initial.size() <= run.problem.model.structure().num_slots()) {
    // A nearby fit's slots, the first ones (the geometry's and the set-up's).
    run.problem.initial = run.problem.model.kinematic_parameters();
    run.problem.initial.head(initial.size()) = initial;
  }
  identify_and_solve(run);
  run.problem.initial.resize(0);
}

CalibrationResult conclude_model(CalibrationRun& run) {
  finish_solution(run);
  fit_statistics(run);
  for (const ParameterInfo& pi : run.model.parameter_info())
    run.fit().parameters.push_back(parameter_estimate(run, pi));
  conclude(run);
  return std::move(run.result);
}

}  // namespace detail

// The stages in order: step 1 (fit_transmissions), then the model search
// (search_model) or the one model the options name: step 2's problem
// (kinematic_problem, register_measurement_frame), analyze_identifiability,
// solve_kinematics with the robust reweighting, the estimator, and the
// information of the fit.
CalibrationResult calibrate(const DeviceModel& nominal, const Log& log,
                            const CalibrationOptions& options) {
  check_tips(log, nominal);
  // Markers of one rigid body: the body's poses (markers.hpp), fitted as a pose log.
  if (log.marker_count > 0) {
    const MarkerPoses markers = markers_to_poses(log, options.marker_body);
    CalibrationOptions as_poses = options;
    as_poses.marker_body = markers.body;
    CalibrationResult r = calibrate(nominal, markers.poses, as_poses);
    r.notes.insert(r.notes.begin(), markers.note);
    r.marker_body = markers.body;
    return r;
  }
  const bool step_one_only = options.transmissions && encoders_only(log);
  check_log_fits(log, nominal, !step_one_only);
  check_options(options);
  CalibrationRun run(nominal, log, options);
  check_joint_limits(log, nominal, options.force, run.result.notes);
  check_encoder_readings(log);
  // The poses, and step 1: transmissions from the external encoders.
  detail::step_one(run);
  if (step_one_only) return conclude_step_one(run);
  if (options.search)
    return detail::without_held_out_outliers(nominal, log, options, detail::search_model(run));
  // Step 2: kinematic parameters from the compensated readings.
  prepare_model(run);
  detail::apply_estimator(run, options.keep_all ? Estimator::kLeastSquares
                               : options.select ? Estimator::kCut
                                                : Estimator::kPrior);
  return detail::conclude_with_geometry(run);
}

}  // namespace hapticcal
