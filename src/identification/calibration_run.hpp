// Internal: one calibration on its way through the stages of calibrate
// (calibrate.cpp), and the stage that chooses what step 2 changes
// (parameter_choice.cpp).
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "hapticcal/identification/identification.hpp"
#include "identification/problem/stack.hpp"

namespace hapticcal::detail {

constexpr int kDefaultFolds = 5;         // of the model selection when cross-validation is off
constexpr int kIterations = 100;         // Levenberg-Marquardt's limit
constexpr int kFixtureIterations = 500;  // for fixture points and planes

// One calibration on its way through the stages: what each stage leaves for
// the next.
struct CalibrationRun {
  const DeviceModel& nominal;
  const Log& log;
  // A copy: the model search runs each candidate model with options of its own.
  CalibrationOptions options;
  // Owned: a copy of the run (the choice between the prior, the significance cut
  // and least squares tries each on one) is a whole calibration of its own.
  CalibrationResult result;
  Log poses;                 // one row a pose: repeats averaged
  std::vector<int> repeats;  // per pose
  int m = 0;                 // poses
  DeviceModel model;         // step 1's transmissions; after step 2 the calibrated model
  // Step 2's parameter vector at the start: the nominal, with the instrument's
  // zero (at 0) if step 2 estimates it.
  DeviceModel step2_nominal;
  std::vector<std::string> fix;  // options.fix less instrument.zero
  KinematicProblem problem;
  std::vector<int> candidates;
  std::vector<int> identified;
  std::map<int, std::string> reason;  // held candidates: why
  std::vector<int> held_by_selection;
  Eigen::VectorXd scale;                        // per slot, from the identifiability analysis
  std::vector<Eigen::VectorXd> nominal_joints;  // the poses' joint values by the nominal model
  std::size_t checks_notes = 0;                 // result.notes before step 1's (the log's checks)
  Eigen::VectorXd plain_weights;                // before the robust reweighting
  KinematicSolution solution;
  Stack data;                       // residuals and Jacobian at the solution
  std::map<int, std::string> name;  // slot -> parameter name
  int iterations = kIterations;
  Eigen::VectorXd p;  // the solution, angles wrapped to the start's period
  Eigen::MatrixXd covariance;
  Eigen::VectorXd tolerance;     // per slot: the prior's (infinite: free)
  Eigen::VectorXd prior_weight;  // per slot: sqrt(lambda) / tolerance; empty: no prior
  Eigen::VectorXd data_share;    // per slot, with the prior
  // The tolerances' scale the evidence chose, whichever fit was kept (NaN: the
  // prior was not fitted: the plausibility check is the default's only).
  double prior_scale = std::numeric_limits<double>::quiet_NaN();

  CalibrationRun(const DeviceModel& nominal_, const Log& log_, const CalibrationOptions& options_)
      : nominal(nominal_), log(log_), options(options_) {}
  KinematicFit& fit() { return result.kinematics; }
  const KinematicFit& fit() const { return result.kinematics; }
  RowsOf kind() const { return rows_of(problem); }
  // Whether step 2 may estimate the instrument's zero: its kind reads one
  // (MeasurementKind::reads_zero) and the options do not turn it off.
  bool zero_offered() const { return kind_of(fit().type).reads_zero() && options.instrument_zero; }
};

// Rows far from their pose's other repeats (5 rows or more: a device at rest
// streaming samples of one reading; robust.cpp): each row's deviation from the
// pose's median against the pooled robust sd of every such deviation, beyond
// the Bonferroni level over those rows (at least 5 sds). Flagged rows are left
// out of their pose and named in `notes`.
void screen_repeats(const Log& log, std::vector<std::vector<int>>& poses, double alpha,
                    std::vector<std::string>& notes);

// The poses (repeats averaged, --samples drawn) and step 1 on them
// (calibrate.cpp): run.model is then the nominal with the fitted transmissions.
void step_one(CalibrationRun& run);
// The stages of one model (calibrate.cpp): step 2's problem up to its
// least-squares fit (the instrument's zero and the joint-error families the
// options name offered, the frame registered, the nominal checked, the rank
// test, Levenberg-Marquardt with the robust reweighting) ...
// `initial`: where Levenberg-Marquardt starts its first slots (a nearby fit's);
// `tolerance`: where it stops (solver_options.hpp).
void prepare_model(CalibrationRun& run, const Eigen::VectorXd& initial = Eigen::VectorXd(),
                   double tolerance = 1e-14);
// A least-squares fit stopped at a looser tolerance, continued to the optimum
// to rounding (the model search's kept candidate).
void polish(CalibrationRun& run);
// run.data again: the residuals and Jacobian at run.solution (the search
// releases them from the family fits it does not keep).
void restack(CalibrationRun& run);
// ... and, once an estimator has been applied (apply_estimator), the
// solution's cross-validation, statistics, estimates, notes and status.
CalibrationResult conclude_model(CalibrationRun& run);
// The model search (model_search.cpp, docs/calibrate.md, "The model search"): the candidate
// models compared on held-out poses, the one kept concluded.
CalibrationResult search_model(CalibrationRun& run);
// A small log's poses whose held-out error stood out in the search
// (ModelSearch::outliers): the calibration of `log` again without them, they
// named (robust.cpp).
CalibrationResult without_held_out_outliers(const DeviceModel& nominal, const Log& log,
                                            const CalibrationOptions& options,
                                            CalibrationResult result);
// The options a caller may get wrong, checked before anything is read (the
// CLI's ranges, for every caller: Python passed 1.0 and inf); input_checks.cpp.
void check_options(const CalibrationOptions& options);
// Too few measurements for `parameters` (the structural rank before these
// poses' own analysis, or the identifiable ones after it): an InputError.
void check_enough_rows(const CalibrationRun& run, std::size_t parameters, const char* what);
// The nominal model's error on the poses: finite on every row, and plausible
// for this device (check_reach). Sets fit.rms_before.
void check_nominal(CalibrationRun& run);
// The RMS [m] of the nominal model on the run's poses with `free` slots (the
// set-up's: base, tool, an instrument's zero) fitted by Levenberg-Marquardt
// (input_checks.cpp), and the fitted parameter vector.
double nominal_rms_with(const CalibrationRun& run, const std::vector<int>& free,
                        Eigen::VectorXd* fitted = nullptr);

// A log of external encoders only: step 1 is the calibration.
CalibrationResult conclude_step_one(CalibrationRun& run);
// The joint-error stages of options.joint_errors on run.model and step2_nominal.
void offer_joint_errors(CalibrationRun& run);
// The fitted stages folded into the links' transmissions; joint_errors cleared.
// Returns why a stage cannot be a transmission ("" if every one can).
std::string fold_joint_errors(DeviceModel& model);
// The run's options for its geometry alone (CalibrationResult::geometry): no
// joint-error family, and no --fix, --free or tolerance naming a family's
// parameter (the run's problem holds the families it fits).
CalibrationOptions geometry_options(const CalibrationRun& run);
// conclude_model, and where the model holds a joint-error family the geometry
// alone fitted as such with geometry_options (CalibrationResult::geometry).
CalibrationResult conclude_with_geometry(CalibrationRun& run);
// The joint-error families that apply to the run's model and log: compliance
// (a model with gravity), harmonic (a turning joint whose angle is its own
// reading), coupling (coefficients between joints), backlash (the log's dir<i>).
std::vector<std::string> applicable_families(const CalibrationRun& run);
// A fit whose poses' values were formed on the start's geometry (a joint or
// lateral compliance's gravity torques, held or fitted) formed again on the
// fit's geometry and solved again from the fit (kept if that converges).
void reform_on_fit(CalibrationRun& run);
// Whether the model's coupling has a coefficient between two joints.
bool coupled_between(const DeviceModel& model);

// Whether a held candidate's reason is that these poses do not excite it
// (identifiability.cpp): identifiable in general, unseen by this log.
inline bool unexcited(const std::string& reason) { return reason.rfind("not excited", 0) == 0; }

// `parameters` with every angle within pi of `centre`'s (angles are periodic: a
// step that went round, an 11 rad flange pitch of a real fit, is the same model).
inline Eigen::VectorXd angles_near(const DeviceModel& model, Eigen::VectorXd parameters,
                                   const Eigen::VectorXd& centre) {
  for (const ParameterInfo& pi : model.parameter_info()) {
    // Angles are periodic; a joint error's coefficients are not.
    if (pi.unit != ParameterUnit::kAngle || pi.block == ParameterBlock::kJointError) {
      continue;
    }
    parameters[pi.slot] =
        centre[pi.slot] + std::remainder(parameters[pi.slot] - centre[pi.slot], 2 * M_PI);
  }
  return parameters;
}

// What step 2 changes: the tolerance prior, the significance cut or least
// squares, from the least-squares fit of prepare_model.
void apply_estimator(CalibrationRun& run, Estimator estimator);
// The K-fold cross-validated RMS of the run's fit, with the prior's rows if it
// has them (NaN with the reason if it cannot be computed).
CrossValidation held_out(const CalibrationRun& run);

}  // namespace hapticcal::detail
