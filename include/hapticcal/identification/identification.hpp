// Two-step identification (paper Fig. 6): transmission models
// from external encoders, then the kinematic parameters from distance (paper
// eq. 5, 7) or position measurements by Levenberg-Marquardt (Ceres), after an
// identifiability analysis that holds parameters without effect or with a
// dependent effect at nominal and says why.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "hapticcal/core/log.hpp"
#include "hapticcal/identification/clock.hpp"
#include "hapticcal/identification/information.hpp"
#include "hapticcal/identification/joint_errors.hpp"
#include "hapticcal/identification/kinematic_fit.hpp"
#include "hapticcal/identification/measurement.hpp"
#include "hapticcal/identification/search.hpp"
#include "hapticcal/model/model.hpp"

namespace hapticcal {

// The outcome of a calibration, like Ceres's Solver::Summary::termination_type.
// Only kConverged gives a usable model: the others keep the previous one.
enum class CalibrationStatus {
  kConverged,         // LM converged, every value finite, every candidate excited
  kNotConverged,      // LM stopped at its iteration limit or without progress
  kNumericalFailure,  // a non-finite residual, parameter or standard deviation
  kRankDeficient,     // the data leave identifiable parameters unexcited
  kSuspect,           // converged, but the fit is suspect and --strict refuses it
  // converged, but no description of the device: it predicts held-out poses
  // worse than the nominal model with the set-up registered (a wrong step 1,
  // model or log), or a joint error as fitted is no transmission
  kImplausible,
};
// "converged", "not converged", "numerical failure", "rank-deficient", "suspect",
// "implausible".
const char* to_string(CalibrationStatus status);

// Step 1 cannot overfit (docs/calibrate.md, "The procedure"): a model is fitted only with at least
// this many samples a parameter (the encoder zero c counted), and among the
// models the samples support (polynomials of order 1 up to the model's; a
// capstan with both, one or no eccentric drum) the one of least generalised
// cross-validation error is kept; its leave-one-out error is reported.
constexpr int kStepOneSamplesPerParameter = 3;
// The highest polynomial order `samples` samples support under that rule (the
// encoder zero counted; below 1: none): step 1's cap, its notes' and plan's.
constexpr int step_one_supported_order(int samples) {
  return samples / kStepOneSamplesPerParameter - 1;
}
// A fit whose leave-one-out RMS exceeds this many times the external encoder's
// resolution (CalibrationOptions::encoder_resolution) is flagged: the model
// does not predict the transmission to the encoder's counts.
constexpr double kStepOneResolutionFactor = 2;

// One model step 1 compared: its label ("order 3", "eccentric drums"), its
// parameters (c counted), its leave-one-out RMS (PRESS) and its generalised
// cross-validation RMS (the choice's criterion) [rad].
struct StepOneCandidate {
  std::string label;
  int parameters = 0;
  double held_out_rms = 0;
  double gcv_rms = 0;
};

// Step 1 for one joint: ext - q = c + dtheta(q).
struct TransmissionFit {
  int joint = 0;                                    // zero-based
  TransmissionKind kind = TransmissionKind::kNone;  // fitted: capstan, polynomial or extension
  std::string type;  // its device-file type: "capstan", "polynomial" or a registered kind's
  int n = 0;         // samples
  std::vector<std::string> names;  // dotted: "j1.r_out", "j4.c3"
  Eigen::VectorXd nominal, value, sd;
  double offset = 0, offset_sd = 0;  // c, the external encoder's zero (nuisance)
  double rms_before = 0;             // RMS of ext - q - c: the error left by an ideal model
  double rms_after = 0;              // RMS of the fit residual
  // Leave-one-out RMS [rad] of the model kept (PRESS; for a capstan,
  // linearised at its fit), the models compared and the one kept; a
  // polynomial's largest order allowed (the model's or --polynomial-order).
  double held_out_rms = std::numeric_limits<double>::quiet_NaN();
  std::vector<StepOneCandidate> candidates;
  std::string model_choice;
  int requested_order = 0;
  // held_out_rms > kStepOneResolutionFactor x the encoder's resolution.
  bool flagged = false;
  bool converged = true;
  std::string message;
  std::vector<double> monomial;  // polynomial: k_0..k_n in q (derived view)
};

// How the terminal and the reports print a step-1 parameter: the paper's
// Table 2 units (capstan radii and parallelogram lengths in mm, eccentricity
// angles in deg; the ratio error is dimensionless, polynomial coefficients are
// in rad). Files are SI.
struct DisplayUnit {
  double scale = 1;       // display value = SI value * scale
  std::string unit = "";  // "" for dimensionless
};
// By the parameter's name ("j1.r_out", "j4.stage2.L1", "j4.c3").
DisplayUnit display_unit(const std::string& parameter);
// The fit's k-th parameter's.
DisplayUnit display_unit(const TransmissionFit& fit, int k);
// A kinematic parameter's: lengths in mm, angles in mrad.
DisplayUnit display_unit(ParameterUnit unit);

// The tolerance prior's widths (docs/calibrate.md, "Step 2's estimators"): a link parameter's
// change from nominal is a priori normal with sd scale x its tolerance; the base,
// the tool and an instrument's zero (the set-up's, not manufactured) are free.
// Defaults from ISO 2768-m general tolerances (lengths of 120-400 mm +-0.5 mm;
// angles with legs of 50-120 mm +-0 deg 20', 5.8 mrad, rounded to 5 mrad).
struct Tolerances {
  double length = 0.5e-3;  // m
  double angle = 5e-3;     // rad
  // Per dotted parameter name (SI), over the family's.
  std::map<std::string, double> by_name;
  // The common scale of the tolerances; none: the one of highest evidence.
  std::optional<double> scale;
  // Per joint-error family name, over the family's own (JointErrorFamily::tolerance).
  std::map<std::string, double> by_family;
  // A joint-error family's (ParameterInfo::family): by_family's, else the
  // family's own; infinite for a name no family has.
  double family(std::string_view name) const;
};

// One --tolerance item, NAME=SD in SI units: "length" and "angle" set a family's
// tolerance, a dotted parameter name ("j2.a") its own. Throws InputError for
// other text or a value that is not a positive number.
void add_tolerance(Tolerances& tolerances, const std::string& item);

struct CalibrationOptions {
  bool transmissions = true;    // false: the paper's kinematic-only calibration
  int samples = 0;              // 0: every row
  std::uint64_t seed = 1;       // for samples
  std::optional<double> sigma;  // measurement noise sd [m]
  // The polynomial order of step 1, exactly (refused where the samples do not
  // support it); none: the order of least generalised cross-validation error up
  // to the device file's (10 where it has none).
  std::optional<int> polynomial_order;
  // The external encoders' resolution [rad] (one count): step 1 fits whose
  // leave-one-out error exceeds kStepOneResolutionFactor counts are flagged.
  std::optional<double> encoder_resolution;
  std::vector<std::string> fix, free;  // kinematic parameters by dotted name
  double dependency_tolerance = 1e-6;  // relative residual of a column: "dependent"
  // Plausibility checks that refuse a log (readings outside the joint limits,
  // a nominal error beyond kImplausibleErrorFraction of the reach) only warn.
  bool force = false;
  // The rows x parameters identification Jacobian is held in memory up to this
  // size; beyond, step 2 works on its R factor, accumulated pose block by pose
  // block (the same fit to rounding, memory independent of the log's length).
  std::size_t max_jacobian_bytes = std::size_t{256} << 20;
  // What step 2 changes. The default: every identifiable parameter, each pulled
  // toward nominal by its tolerance (the tolerance prior, MAP). keep_all: every
  // structurally identifiable, excited parameter by plain least squares. select:
  // the significance cut (model selection): identifiable parameters the data do
  // not support are held at nominal (the default before the prior).
  bool keep_all = false;
  bool select = false;
  bool prior = false;  // the tolerance prior alone
  // The model search (docs/calibrate.md, "The model search"): the candidate models (estimator
  // x joint-error families x an instrument's zero held or fitted) compared on
  // held-out poses, the simplest within one standard error of the best kept.
  // keep_all, select, prior, a given prior scale, joint_errors and --fix /
  // --free instrument.zero restrict it to what they name. false: exactly the
  // model they name (the tolerance prior where no estimator is named, the
  // geometry alone where no family is, the instrument's zero fitted).
  bool search = true;
  // Threads of the model search (its family sets fitted at once); 0: one a core.
  // The result does not depend on it.
  int threads = 0;
  Tolerances tolerances;
  // Known distances between fixture points (--point-distance A:B=METRES).
  std::vector<PointDistance> point_distances;
  // Known positions of fixture points in the measurement frame (a fixture file's
  // `points`): those labels are not eliminated, and the base pose becomes visible.
  std::vector<KnownPoint> known_points;
  double selection_alpha = 0.05;  // family-wise significance level of the model selection
  // Joint-error families step 2 fits with the geometry from the measurements
  // (docs/joint-errors.md): "harmonic", the first and second harmonic
  // of each turning joint's angle, and of its motor's where a capstan gives the
  // ratio; "compliance", each joint's k; "coupling", the coupling's
  // coefficients between joints; "backlash", an offset per approach direction
  // (the log's dir<i>). They enter the tolerance prior (Tolerances) and the
  // identifiability analysis, are folded into the calibrated model, and the
  // same calibration without them is run for comparison.
  std::vector<std::string> joint_errors;
  // K of the K-fold cross-validated RMS (poses, repeats together, in K folds);
  // 0: no cross-validation.
  int folds = 5;
  // The loss of step 2 for poses the outlier test flags (docs/outliers.md: "Outliers and
  // suspect fits"); no pose flagged: plain least squares whatever it is.
  RobustLoss loss = RobustLoss::kCauchy;
  double outlier_alpha = 0.05;  // family-wise level of the outlier test (Bonferroni over poses)
  // Where the poses are too few for that test, the model search's held-out
  // errors are tested instead and the calibration fitted again without the
  // poses named (docs/outliers.md, "Few poses"), at most this many times.
  int held_out_outlier_rounds = 3;
  // A suspect fit (SuspectFit) is unusable: status kSuspect.
  bool strict = false;
  // A distance log: the instrument's own zero d0 (a cable encoder reads
  // |p| + d0) is a candidate parameter, "instrument.zero", after every
  // parameter of the device; reported, and left out of the calibrated model.
  // false: the instrument's zero is known (a simulation's).
  bool instrument_zero = true;
  // A log of several markers on one rigid body (x1, y1, z1, ...): their
  // positions in the tool frame (3 x K, m); empty: estimated from the log
  // (markers_to_poses).
  Eigen::Matrix3Xd marker_body;
};

// A log whose nominal RMS error exceeds this fraction of the device's reach
// (the largest distance of the tool point from the base over the log's poses),
// even after the base pose alone is fitted, is refused unless forced: it is
// probably from another device. A Meca500 log: 0.8 mm of 324 mm (0.25 %); the
// paper study's: see docs/calibrate.md, "Plausibility".
constexpr double kImplausibleErrorFraction = 0.05;

struct CalibrationResult {
  CalibrationStatus status = CalibrationStatus::kConverged;
  std::string status_reason;  // one sentence: why the status is what it is
  DeviceModel calibrated;
  std::vector<TransmissionFit> transmissions;
  KinematicFit kinematics;
  std::vector<int> rows;                // log rows used, zero-based: the first row of each pose
  std::vector<std::vector<int>> poses;  // every row of each pose used
  std::vector<std::string> notes;       // things a user should know (one sentence each)
  // The log had external encoders and no measurements: step 1 alone ran, and
  // `kinematics` is empty (the calibrated model keeps the kinematic parameters).
  bool step_one_only = false;
  // Two streams on two clocks (calibrate_streams): the clock's estimate.
  std::optional<ClockEstimate> clock;
  // A marker log's body as used (given or estimated), 3 x K [m]; empty: none.
  Eigen::Matrix3Xd marker_body;
  // The best model a format that holds the geometry alone can express (a URDF,
  // a DH table, a driver's file): the model search's best geometry-only
  // candidate refitted on every pose by its own estimator, fitted as such, not
  // the whole model with its joint-error families dropped. Its status says
  // whether it may be written (not kConverged: it predicts held-out poses no
  // better than the nominal model with the set-up fitted). Null when the whole
  // model holds no joint-error family: it is that model.
  std::shared_ptr<const CalibrationResult> geometry;
};

// The model a geometry-only format (a URDF, a DH table, a driver's file) is
// written from: result.geometry, or result itself when that is null.
const CalibrationResult& geometry_model(const CalibrationResult& result);

// The stages of calibrate, callable one by one.

// Step 1 for every joint with an external encoder in `poses` (one row a pose):
// fits its transmission and installs it in `model` (capstans with their c).
// Notes say what a user should know (a polynomial fitted where the model had
// none, a fit that did not converge, step 1 skipped).
std::vector<TransmissionFit> fit_transmissions(DeviceModel& model, const Log& poses,
                                               const CalibrationOptions& options,
                                               std::vector<std::string>& notes);

// Why a step-1 fit is flagged (TransmissionFit::flagged), one sentence.
std::string step_one_flag_reason(const TransmissionFit& fit, const DeviceModel& model,
                                 double resolution);

// Step 2's data: the poses' compensated joint values and measured values (the
// family's width a pose, measurement.hpp), weighted by their repeat counts.
struct KinematicProblem {
  DeviceModel model;  // the start: nominal geometry, step-1 transmissions
  MeasurementType type = MeasurementType::kDistance;
  std::vector<Eigen::VectorXd> joints;  // q + dtheta(q), one a pose
  MeasuredValues measured;              // one row a pose
  Eigen::VectorXd weights;              // sqrt(repeats) a pose; empty: all 1
  int rows = 0;                         // log rows behind the poses
  double length_scale = 1;              // m: RMS distance of the tool from the base origin
  double rotation_scale = 1;            // m/rad of a pose's rotation rows: the length scale
  bool compressed = false;              // the Jacobian too large: work on its R factor
  FixtureLabels labels;                 // fixture points or planes: the poses' labels
  // The poses are a fixture's labelled samples: nothing measured, each label's
  // point or plane eliminated from the rows (fixture_residuals).
  bool labelled() const { return labels.count() > 0; }
  // The tolerance prior's rows in solve_kinematics, per slot: weight
  // sqrt(lambda) / tolerance (0: none) and centre (the nominal); empty: none.
  Eigen::VectorXd prior_weight, prior_centre;
  // Positions or poses in a frame of their own (a tracker's, a mocap system's)
  // with the base a free pose: the base is that frame, identified first
  // (measurement_frame_unknown).
  bool frame_unknown = false;
  // The model's joint-error stages (joint_error_stages).
  std::vector<JointErrorStage> joint_errors;
  // Where each pose's values hold its links' lateral bends (a lateral
  // compliance step 2 holds: StepTwoJoints::bends), if they do.
  std::optional<int> bends;
  // A tree's (DeviceModel::tree): where each pose's values hold the tip it
  // measures (StepTwoJoints::tip); none: a chain.
  std::optional<int> tip;
  // Where Levenberg-Marquardt starts (every slot), if not at the model: a
  // nearby fit's (the model search's family sets start at the geometry's).
  // The model stays the start of everything else (the prior's centre, what a
  // held parameter returns to).
  Eigen::VectorXd initial;
  // Levenberg-Marquardt's relative tolerance of the cost and the parameters
  // (the optimum to rounding; the model search's candidates stop sooner).
  double tolerance = 1e-14;
};
// From the poses (a log, one row a pose) and each pose's repeat count (empty:
// one each).
KinematicProblem kinematic_problem(const DeviceModel& model, const Log& poses,
                                   const std::vector<int>& repeats,
                                   const CalibrationOptions& options);
// The Jacobian of the problem's residual rows, weighted as the fit weighs
// them (a fixture's unknown points projected out, a given distance's row
// included), by every slot of the kinematic vector at `parameters`.
Eigen::MatrixXd problem_jacobian(const KinematicProblem& problem,
                                 const Eigen::VectorXd& parameters);

// An unknown measurement frame: when the base is a free pose (every base slot
// among the candidates) and the model's tool points lie far from the measured
// positions, registers the base in closed form (Horn / Kabsch on predicted and
// measured points) and says so in the notes. False if it was not needed or not
// possible (distances, a DH base, collinear points).
bool register_measurement_frame(KinematicProblem& problem, const std::vector<int>& candidates,
                                std::vector<std::string>& notes);

// Whether the problem's measured positions or poses are in a frame the model
// does not know: the base is a pose whose six slots are all candidates, the
// log measures positions or poses (not distances from the base, not a fixture),
// and the model gives no base (the identity: a URDF's root) or the log's frame
// was far from it (`registered`, register_measurement_frame).
// Then the base is the measurement frame and the tool the marker: the rank test
// takes the base first and the tool next (order base -> tool -> links: the first
// joint's origin keeps only what a rigid frame cannot express, the last joint
// only what a marker offset cannot), and neither the base's change nor the
// tool's is a large change.
bool measurement_frame_unknown(const KinematicProblem& problem, const std::vector<int>& candidates,
                               bool registered);

// Which candidates (slots, in priority order: candidate_slots) the problem can
// identify: a greedy rank test of the column-scaled Jacobian on these poses and
// on synthetic poses over the joint limits; the others with a reason.
struct IdentifiabilityAnalysis {
  std::vector<int> identified;        // slots, in priority order
  std::map<int, std::string> reason;  // held candidates: why
  bool rank_deficient = false;        // identifiable in general but not excited by these poses
  Eigen::VectorXd scale;              // per slot: angle columns' length scale, else 1
};
IdentifiabilityAnalysis analyze_identifiability(const KinematicProblem& problem,
                                                const std::vector<int>& candidates,
                                                double tolerance = 1e-6);

// Model selection (docs/calibrate.md, "Model selection"): backward elimination over the
// identified parameters, linearised at the full fit `solution`. At each step
// the parameter whose estimated change from its start value is the fewest
// standard deviations (t, the residual's sigma) is the candidate to hold; the
// elimination stops at the first model whose weakest parameter is significant
// at the family-wise level alpha (Bonferroni over the k parameters in the
// model: t >= the normal quantile 1 - alpha / 2k). Every model of the path is
// scored by K-fold cross-validation of the linearised fit over poses (repeats
// together), for the record.
struct ModelSelection {
  std::vector<int> kept;              // slots, in the order of `identified`
  std::map<int, std::string> reason;  // the held ones: why
  std::vector<SelectionStep> path;  // from every identified parameter to 3 models past the kept one
  int chosen = 0;                   // index in path
};
ModelSelection select_model(const KinematicProblem& problem, const std::vector<int>& identified,
                            const Eigen::VectorXd& solution, double alpha, int folds,
                            std::uint64_t seed);
// The two-sided Bonferroni threshold of the selection: the t with
// P(|T| > t) = alpha / parameters for Student's T with `dof` degrees of
// freedom (the residual's: rows - parameters); infinite below one.
double significance_threshold(double alpha, int parameters, double dof);
// P(|T| > t) for Student's T with `dof` degrees of freedom.
double student_t_tail(double t, double dof);
// The p-quantile x of the chi-square distribution with `dof` degrees of
// freedom: P(X <= x) = p, from the regularised incomplete gamma function
// P(dof / 2, x / 2) (DLMF 8.2.4). Used for the band of RMSE / CRLB that n
// trials of an efficient estimator spread over: n RMSE^2 / CRLB^2 ~ chi^2_n.
double chi_square_quantile(double p, double dof);

// Fold of each of `poses` poses (0..folds-1, sizes differing by at most one),
// a reproducible shuffle for a seed on every platform.
std::vector<int> pose_folds(int poses, int folds, std::uint64_t seed);

// K-fold cross-validated RMS of the fit `solution` over `identified` (the
// measure of KinematicFit::rms_after): each fold's poses predicted by the fit on
// the other folds, linearised at `solution` (one Gauss-Newton step from it,
// which is the refit to second order in the parameters' change). NaN with a
// reason when there are fewer than two poses, the problem is compressed, or a
// fold's other poses cannot determine the parameters.
struct CrossValidation {
  double rms = std::numeric_limits<double>::quiet_NaN();
  int folds = 0;
  std::string note;  // why rms is NaN
};
CrossValidation cross_validate(const KinematicProblem& problem, const std::vector<int>& identified,
                               const Eigen::VectorXd& solution, int folds, std::uint64_t seed);

// How Levenberg-Marquardt ended (like Ceres's TerminationType).
enum class SolveTermination { kConverged, kNoConvergence, kFailure, kNothingToSolve };
const char* to_string(SolveTermination termination);
struct KinematicSolution {
  Eigen::VectorXd parameters;  // every slot; the unidentified ones at the start's values
  SolveTermination termination = SolveTermination::kNothingToSolve;
  int iterations = 0;
  std::string message;  // Ceres's
};
// Levenberg-Marquardt (Ceres, analytic derivatives) over the identified slots
// from the problem's model.
KinematicSolution solve_kinematics(const KinematicProblem& problem,
                                   const std::vector<int>& identified, int max_iterations = 100);

// The outlier test at the fit `solution` (docs/outliers.md):
// each pose's weighted residual e_i (d components) against the robust sd s of
// all components (1.4826 MAD); the pose is an outlier when |e_i|^2 / s^2
// exceeds the chi-square quantile with d dof at 1 - alpha / m (Bonferroni over
// the m poses; d = 1: the two-sided normal quantile at alpha / m). If a pose
// is flagged and `loss` is not kNone, iteratively reweighted least squares:
// each pose's weight in problem.weights is multiplied by the square root of
// the loss's weight of its RMS component in robust sds (Cauchy c = 2.3849,
// Huber k = 1.345; s re-estimated each iteration), and `solution` refitted,
// until the weights settle. Outliers (pose indices, lines empty) are then those
// flagged at the final fit (at the least-squares fit if none). Not for fixture kinds.
RobustFit reweight_outliers(KinematicProblem& problem, const std::vector<int>& identified,
                            KinematicSolution& solution, RobustLoss loss, double alpha,
                            int max_iterations);

// Whether a converged fit is suspect: its training RMS above
// kSuspectRepeatabilityRatio times the repeatability, or its cross-validated
// RMS above the nominal model's with its base pose fitted (`nominal_in_frame`:
// the nominal device in the problem's measurement frame; `poses`: one row a
// pose, as the problem's; weights: the problem's before any reweighting).
SuspectFit check_suspect(const KinematicFit& fit, const KinematicProblem& problem,
                         const DeviceModel& nominal_in_frame, const Log& poses,
                         const Eigen::VectorXd& weights);

// The whole procedure. Throws InputError for logs that cannot be used (joint
// count, no measurements, too few poses, a joint or encoder that never moves,
// and unless options.force, readings outside the joint limits or errors too
// large for this device); a solver that does not converge or data that do not
// excite the model are reported in the result's status, not hidden. Rows with
// the same joint readings are repeats of one pose: they are averaged, so that
// standard deviations, condition numbers and --samples count poses.
CalibrationResult calibrate(const DeviceModel& nominal, const Log& log,
                            const CalibrationOptions& options);

// Step 1 for one joint from its readings and external encoder. `order` sets
// the polynomial order (else it is chosen up to the model's). Returns the
// fitted transmission (without c).
Transmission fit_transmission(const DeviceModel& model, int joint, const Eigen::VectorXd& q,
                              const Eigen::VectorXd& ext, std::optional<int> order,
                              TransmissionFit& fit);

// Hayati's beta is what a joint axis parallel to its neighbour needs (paper,
// after eq. 3: "used for the sequential parallel joints"): there the four DH
// parameters cannot express a small tilt. The neighbouring joint whose axis link
// `link`'s beta tilts against, if the two are within kParallelAxesDeg of
// parallel in the model; otherwise none.
constexpr double kParallelAxesDeg = 5.0;
std::optional<int> parallel_axis_partner(const DeviceModel& model, int link);

// Candidate kinematic parameters in priority order (links, then tool, then
// base, then the instrument's zero if the model carries one): a dependent
// parameter is held in favour of those before it. A beta is a
// candidate where parallel_axis_partner finds a partner, where the model's beta
// is not zero, or when freed. Throws InputError for unknown names in fix / free.
std::vector<int> candidate_slots(const DeviceModel& model, const std::vector<std::string>& fix,
                                 const std::vector<std::string>& free);

// Rows with bit-identical joint readings (and approach directions, if the log
// has any and by_direction), grouped: the poses of a log in order of first
// appearance, each the list of its rows.
std::vector<std::vector<int>> repeated_poses(const Log& log, bool by_direction = true);
// One row per group: the joint readings and directions of its first row, the
// external encoders and measurements averaged over the group.
Log average_repeats(const Log& log, const std::vector<std::vector<int>>& groups);
// A coupled model's external encoders measure joint angles, theta = C u + c
// (u_k = q_k + dtheta_k(q_k), each reading through its own transmission);
// step 1 fits each reading's transmission, so poses.ext's column k becomes u_k
// + a constant: sum_i w_i ext_i over the joints A with an encoder, where
// C[A, :]^T w = e_k has an exact solution (has_ext[k] false where none does,
// with a note). Unchanged for an uncoupled model. fitted_coupling (--joint-errors
// coupling): the encoders of joints whose angle uses another joint's reading are
// left out (their C rows are what step 2 fits: mapped back through the nominal
// C, a coefficient's error would enter a transmission), with a note.
void encoders_at_readings(const DeviceModel& model, Log& poses, std::vector<std::string>& notes,
                          bool fitted_coupling = false);

// Draws `samples` distinct row indices of `rows` (all if samples <= 0 or >= rows),
// reproducibly for a seed on every platform; sorted.
std::vector<int> sample_rows(int rows, int samples, std::uint64_t seed);

}  // namespace hapticcal
