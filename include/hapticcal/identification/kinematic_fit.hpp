// What step 2's fit found (KinematicFit, CalibrationResult::kinematics): each
// parameter's estimate, the model selection's steps, the outliers and the robust
// reweighting, the suspect-fit checks and the tolerance prior's evidence.
#pragma once

#include <Eigen/Core>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "hapticcal/identification/information.hpp"
#include "hapticcal/identification/measurement.hpp"
#include "hapticcal/identification/search.hpp"
#include "hapticcal/model/model.hpp"

namespace hapticcal {

struct ParameterEstimate {
  std::string name;
  int slot = 0;
  ParameterUnit unit = ParameterUnit::kLength;
  double nominal = 0, value = 0;
  double sd = std::numeric_limits<double>::quiet_NaN();
  bool identifiable = false;
  std::string reason;  // why it is held at nominal, if it is
  double max_correlation = 0;
  std::string max_correlation_with;
  // Structurally identifiable and excited, but held at nominal by the model
  // selection (reason says why).
  bool held_by_selection = false;
  // The tolerance prior (CalibrationOptions::tolerances): this parameter's prior
  // sd (scale x tolerance; NaN: free, a set-up parameter, or no prior), the share
  // of its estimate the data determine (1 - posterior / prior variance in the
  // linearised problem: 1 where the prior does not bind, 0 where the data do
  // not see it), and whether the prior rather than the data set it (share < 1/2).
  double prior_sd = std::numeric_limits<double>::quiet_NaN();
  double data_share = std::numeric_limits<double>::quiet_NaN();
  bool set_by_prior = false;
  // The identified value moved more than kLargeChangeLength (metres) or
  // kLargeChangeAngle (rad) from nominal: plausible for a base pose, suspicious
  // for a link.
  bool large_change = false;
  // Identifiable, yet not determined by these data: its sd above its tolerance
  // (`tolerance`, Tolerances), or correlated beyond kUndeterminedCorrelation
  // with another (the data determine their combination, not each). Reported
  // apart from the identified parameters; the set-up's are exempt.
  bool determined = true;
  double tolerance = std::numeric_limits<double>::quiet_NaN();
};

// |correlation| beyond which two parameters are one unknown to the data.
constexpr double kUndeterminedCorrelation = 0.99;

// Bounds beyond which a parameter's change is flagged (ParameterEstimate::large_change).
constexpr double kLargeChangeLength = 0.02;  // m
constexpr double kLargeChangeAngle = 0.05;   // rad, about 2.9 deg

// One model of the model selection's path (select_model): the parameters in
// it, its cross-validated RMS, and the parameter removed next.
struct SelectionStep {
  int parameters = 0;
  // K-fold cross-validated RMS [m] of this model, from the linearised fits
  // (every residual row; infinite where a fold cannot determine the model).
  double cv_rms = 0;
  double rms = 0;        // of the linearised fit on every pose (every residual row) [m]
  std::string removed;   // dotted name of the parameter held next ("" at the end)
  double removed_t = 0;  // its estimated change from nominal in standard deviations
  double threshold = 0;  // the t it needed to stay (significance_threshold)
};

// The loss of the robust fit (CalibrationOptions::loss): how much a pose the
// outlier test flags still counts. kNone: plain least squares.
enum class RobustLoss { kNone, kCauchy, kHuber };
// "none", "cauchy", "huber".
const char* to_string(RobustLoss loss);
// From its name; throws InputError for any other.
RobustLoss robust_loss(const std::string& name);

// A pose whose residual the outlier test rejects (docs/outliers.md).
struct OutlierPose {
  int pose = 0;            // index in CalibrationResult::poses
  std::vector<int> lines;  // the log lines of its rows
  double residual = 0;     // norm of its (averaged) residual at the final fit [m]
  double statistic = 0;    // its weighted residual in robust sds (RMS over its components)
  double weight = 1;       // its robust weight in the final fit (1: not down-weighted)
};

// The outlier test and the robust reweighting of step 2 (reweight_outliers).
struct RobustFit {
  RobustLoss loss = RobustLoss::kCauchy;
  bool tested = false;  // false for fixture kinds (note says why)
  std::string note;
  // Robust sd [m] of one residual component of a single row (1.4826 MAD of the
  // components weighted by sqrt(repeats)), at the final fit.
  double robust_sd = std::numeric_limits<double>::quiet_NaN();
  // A pose is an outlier when its RMS component exceeds this many robust sds.
  double threshold = std::numeric_limits<double>::quiet_NaN();
  bool reweighted = false;  // the loss was applied (some pose was flagged, loss not none)
  int iterations = 0;       // of iteratively reweighted least squares
  std::vector<OutlierPose> outliers;
};

// A fit that converged but should not be trusted (check_suspect).
struct SuspectFit {
  bool suspect = false;
  std::vector<std::string> reasons;  // one sentence each, with the ratio
  // rms_after / repeatability (NaN without repeats), and its limit.
  double repeatability_ratio = std::numeric_limits<double>::quiet_NaN();
  double repeatability_limit = 0;
  // RMS [m] of the nominal model with only its base pose fitted (NaN if not
  // computed), and cv_rms over it.
  double nominal_base_fitted_rms = std::numeric_limits<double>::quiet_NaN();
  double cv_ratio = std::numeric_limits<double>::quiet_NaN();
  // The reason that cv_ratio is above kWorseThanNominalRatio (unusable even
  // without --strict), or empty.
  std::string worse_than_nominal;
};
// A held-out RMS more than this many times the nominal model's with its base
// fitted (on the same poses, in sample) is unusable without --strict: a fit of
// a device the nominal model describes exactly gives 1.01-1.05 (a held-out
// error against a training one); the mistakes this catches (points in mm, tips
// or markers in another order) give 29-200.
constexpr double kWorseThanNominalRatio = 1.5;
// A training RMS more than this many times the measured repeatability is
// suspect (docs/outliers.md: clean Meca500 sets give 15-20x, a tracker bumped 3 mm 670x).
constexpr double kSuspectRepeatabilityRatio = 100;
// A joint's play where its model gives no backlash: a reading this far beyond
// a limit is the joint at its stop (its play and its encoder's), not an error.
constexpr double kReadingPlayAngle = 0.01;   // rad
constexpr double kReadingPlayLength = 1e-4;  // m

// The tolerance prior of step 2 as fitted (docs/calibrate.md, "Step 2's estimators").
struct PriorFit {
  bool used = false;
  std::string note;  // why it was not used ("" if it was)
  // The tolerances' common scale: the evidence's choice, or the given one.
  double scale = std::numeric_limits<double>::quiet_NaN();
  bool scale_given = false;
  double lambda = 0;  // (noise sd / scale)^2: the weight of the prior's rows
  // The noise sd at the evidence's optimum [m], and the profile log evidence there.
  double sigma = std::numeric_limits<double>::quiet_NaN();
  double log_evidence = std::numeric_limits<double>::quiet_NaN();
  // Parameters the data pay for (the sum of the data shares, free ones 1 each)
  // of the `fitted` estimated.
  double effective_parameters = 0;
  int fitted = 0;
  int rounds = 0;  // evidence + MAP solve rounds
  // The profile log evidence over log10(lambda), for a figure.
  std::vector<std::pair<double, double>> curve;
};

struct KinematicFit {
  MeasurementType type = MeasurementType::kDistance;
  int rows = 0;   // log rows used
  int poses = 0;  // distinct poses among them: repeats are averaged into one
  // RMS scatter of a repeated pose's measurements about their mean [m]
  // (Euclidean for positions), with rows - poses degrees of freedom; NaN
  // without repeats.
  double repeatability = std::numeric_limits<double>::quiet_NaN();
  std::vector<ParameterEstimate> parameters;  // every candidate, in slot order
  int identified = 0;
  Eigen::MatrixXd correlation;  // of the identified parameters, in their order
  std::vector<std::string> identified_names;
  double condition_number = 0;
  ObservabilityIndices observability;
  double length_scale = 1;  // m: angle columns are scaled by it
  // m/rad: a pose's rotation error phi counts as rotation_scale * phi (the length scale)
  double rotation_scale = 1;
  // The base was first registered to the measurements in closed form (an
  // unknown measurement frame; see the notes).
  bool frame_registered = false;
  // RMS measurement error [m] of the nominal device and of the calibrated one,
  // as `evaluate` reports it: the distance error, or the Euclidean position
  // error (of a pose log too: its orientation error is evaluate's).
  double rms_before = 0, rms_after = 0;
  // A tree's: the same a tip (its samples' rows), in tip order; empty for a chain.
  std::vector<double> tip_rms_before, tip_rms_after;
  // K-fold cross-validated RMS [m] (the same measure as rms_after): each fold's
  // poses (repeats together) predicted by a fit on the other folds; NaN when
  // not computed (cv_note says why).
  double cv_rms = std::numeric_limits<double>::quiet_NaN();
  int cv_folds = 0;
  std::string cv_note;
  // Model selection (calibrate's default): its path (select_model), and the
  // number of parameters before it.
  bool model_selection = false;
  std::string selection_note;       // why it did not run or was undone ("" if it ran)
  int selection_folds = 0;          // K of the path's cross-validation
  int structurally_identified = 0;  // excited, before model selection
  std::vector<SelectionStep> selection_path;
  double sigma = 0;             // used for the standard deviations [m]
  bool sigma_given = false;     // else the residual estimate
  bool rank_deficient = false;  // the data leave structurally identifiable parameters unexcited
  bool converged = false;
  bool numerical_failure = false;  // Ceres's FAILURE: a residual or Jacobian not finite
  int iterations = 0;
  std::string termination;  // Ceres's report
  RobustFit robust;         // the outlier test and reweighting
  SuspectFit suspect;       // whether the fit should be trusted
  PriorFit prior;           // the tolerance prior (the default)
  // The joint-error families fitted (CalibrationOptions::joint_errors) and the
  // cross-validated RMS [m] of the same calibration without them (NaN: not run
  // or not computed): what the families bought on held-out poses.
  std::vector<std::string> joint_error_families;
  double cv_rms_without_joint_errors = std::numeric_limits<double>::quiet_NaN();
  // What the default kept by its cross-validated RMS: "tolerance prior",
  // "significance cut" or "least squares"; "" when not compared (an option
  // chose, or nothing could be cross-validated).
  std::string choice;
  // The estimator the fit used.
  Estimator estimator = Estimator::kPrior;
  // The model search (calibrate's default; ran false with --no-search).
  ModelSearch search;
};

// The distance instrument's zero the fit identified ("instrument.zero"; 0 if it
// was not estimated or was held): what the instrument's readings carry beyond
// the device's |p|, and what `calibrated` (which leaves it out) does not predict.
double identified_instrument_zero(const KinematicFit& fit);

}  // namespace hapticcal
