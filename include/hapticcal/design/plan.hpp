// Experiment design: which N poses to measure so that
// the two-step calibration (paper Fig. 6) predicts best.
//
// The parameters are the structurally identifiable kinematic ones
// (candidate_slots, then analyze_identifiability on the candidates' predicted
// measurements) and, for every joint with a transmission, its step-1
// parameters and the encoder zero c. A pose contributes its measurement rows
// (1, 3 or 6, sd sigma_m; a 6-D pose's rotation rows scaled by the length scale
// as the measurement family does) and one external-encoder row per joint with a
// transmission (sd sigma_e). The design maximises a criterion of the summed
// Fisher information M of the scaled parameters (each scaled to unit mean
// information per candidate pose):
//   D: log det M        A: -trace(M^-1)        E: smallest eigenvalue of M
//   I: -mean over a validation sample of the workspace of the prediction
//      variance of the measurement, -trace(M^-1 W), W = mean g g^T
// The two-step estimate (step 1 from the encoders alone) has the information
//   Lambda = E + L K^-1 L^T  (E: encoder rows; L = sum m m_k^T, K = sum m_k m_k^T
// over measurement rows m, m_k their kinematic part), the inverse of
// two_step_covariance: less than the joint information M = E + sum m m^T by
// what the measurements say of the transmissions beyond the kinematic fit.
// The design maximises the criterion of Lambda by (1) a greedy start in batches
// on M (additive, cheap), (2) a Fedorov exchange on Lambda: one design pose
// swapped for one candidate while the criterion improves, each swap's value
// exact (adding or removing a pose is a signed low-rank update of Lambda,
// Woodbury), candidates screened by their gain, (3) for random candidates only,
// a continuous refinement of each pose's readings within the joint limits
// (gradient steps: the criterion's analytic derivative w.r.t. the pose's rows,
// the rows' derivatives by central differences), and (4) a path through the
// poses: nearest neighbour in joint space (max |dq_j|) improved by 2-opt. The
// figures reported are from the exact two-step covariance.
//
// Linearisation: the nominal model. A capstan with zero eccentricities has no
// first-order effect of its phases; the plan linearises it at eccentricities of
// kPlanCapstanEccentricity * D (the same span of error shapes). Every joint with
// a transmission is assumed to have an external encoder in the experiment.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "hapticcal/identification/information.hpp"
#include "hapticcal/identification/measurement.hpp"
#include "hapticcal/identification/two_step.hpp"
#include "hapticcal/model/model.hpp"

namespace hapticcal {

enum class PlanCriterion { kD, kA, kI, kE };
const char* to_string(PlanCriterion criterion);  // "D", "A", "I", "E"
// "d", "a", "i", "e" (either case); nullopt for anything else.
std::optional<PlanCriterion> plan_criterion(const std::string& text);
// "distance", "position", "pose"; nullopt for anything else.
std::optional<MeasurementType> measurement_kind(const std::string& text);

constexpr double kPlanCapstanEccentricity = 0.01;  // of the drum distance D
// Default measurement sd of a position or 6-D pose (a laser tracker) [m]; a
// distance's is the paper's sigma_m.
constexpr double kPlanSigmaPosition = 1e-5;

// Where the tool point may be measured (optional): a distance range (a cable
// encoder's) and a box in the measurement frame.
struct PlanConstraints {
  double min_distance = 0, max_distance = INFINITY;  // |p_meas| [m]
  std::optional<std::array<double, 6>> box;          // xmin, xmax, ymin, ymax, zmin, zmax [m]
  bool admits(const Eigen::Vector3d& p_meas) const;
  bool any() const { return min_distance > 0 || std::isfinite(max_distance) || box.has_value(); }
};

// The linearised two-step problem of a model and a kind of measurement.
// The model step 1 can fit from `samples` poses: each polynomial transmission's
// order capped at what they support (samples / kStepOneSamplesPerParameter - 1,
// at least 1; its higher coefficients dropped), so that a plan of that many poses
// predicts the calibration it will get. Capstans are kept whole (6 parameters
// need 18 samples; a plan below that predicts the whole model).
DeviceModel step_one_model(DeviceModel model, int samples);

class PlanProblem {
 public:
  // `analysis`: readings (poses x dof) on which the kinematic parameters' identifiability
  // is tested (the candidates); fix / free as calibrate's.
  PlanProblem(const DeviceModel& model, MeasurementType type, double sigma_m, double sigma_e,
              const Eigen::MatrixXd& analysis, const std::vector<std::string>& fix = {},
              const std::vector<std::string>& free = {});

  const DeviceModel& model() const { return model_; }
  MeasurementType type() const { return type_; }
  int dimension() const { return d_; }
  int parameters() const { return static_cast<int>(names_.size()); }
  // Rows a pose: the measurement's, then one a step-1 encoder.
  int rows_per_pose() const { return d_ + static_cast<int>(step_one_.size()); }
  // Every parameter: each step-1 joint's, then its encoder zero, then the kinematic ones.
  const std::vector<std::string>& names() const { return names_; }
  const std::vector<int>& kinematic_slots() const { return slots_; }
  const std::map<std::string, std::string>& held() const { return held_; }
  double sigma_m() const { return sigma_m_; }
  double sigma_e() const { return sigma_e_; }
  double length_scale() const { return length_scale_; }

  // Whitened Fisher rows of each pose (parameters x poses * rows_per_pose):
  // measurement rows / sigma_m and encoder rows / sigma_e, so M = F F^T.
  Eigen::MatrixXd fisher_rows(const Eigen::MatrixXd& readings) const;
  // d predicted measurement / d parameters (parameters x poses * dimension).
  Eigen::MatrixXd prediction_rows(const Eigen::MatrixXd& readings) const;
  // The exact two-step covariance of the parameters after calibrating on
  // `design` (poses x dof), in the order of names() (encoder zeros: 0).
  Eigen::MatrixXd covariance(const Eigen::MatrixXd& design) const;
  // The predicted RMS sd of the measured tip quantity (the distance; the
  // position, Euclidean, for positions and poses) over `validation` poses.
  double predicted_rms_sd(const Eigen::MatrixXd& design, const Eigen::MatrixXd& validation) const;
  // The same from a covariance and the validation poses' prediction_rows.
  double rms_sd_of(const Eigen::MatrixXd& covariance,
                   const Eigen::MatrixXd& validation_prediction_rows) const;
  // Conditioning and observability indices O1-O4 of the design's kinematic
  // Jacobian (angle columns times the length scale, as calibrate reports them).
  Conditioning conditioning(const Eigen::MatrixXd& design) const;

 private:
  DeviceModel model_;
  MeasurementType type_;
  int d_ = 1;
  double sigma_m_ = 0, sigma_e_ = 0, length_scale_ = 1, rotation_scale_ = 1;
  std::vector<int> slots_;
  std::vector<StepOneModel> step_one_;
  std::vector<int> step_one_offset_;  // first column of each joint's block
  int kinematic_offset_ = 0;
  std::vector<std::string> names_;
  std::map<std::string, std::string> held_;  // kinematic candidates held: why
};

struct PlanOptions {
  int poses = 0;
  // Candidates: the user's readings (poses x dof; no continuous refinement), or
  // if empty `pool` random readings within the joint limits and constraints.
  Eigen::MatrixXd candidates;
  int pool = 10000;
  PlanCriterion criterion = PlanCriterion::kI;
  std::uint64_t seed = 1;
  PlanConstraints constraints;
  int refine_passes = 8;       // continuous refinement passes at most (0: none)
  int max_sweeps = 6;          // exchange sweeps at most (each screens <= 3000 candidates)
  int validation_poses = 500;  // the I criterion's sample of the workspace
  // The report's comparison: predicted figures over `evaluation_poses` (a
  // sample independent of the I criterion's) against `random_draws` random
  // designs of the same size (random readings, or random subsets of the candidates).
  int evaluation_poses = 2000;
  int random_draws = 20;
  std::function<void(const std::string&)> progress;  // a stage or sweep done
};

struct DesignFigures {
  double rms_sd = 0;          // predicted RMS sd of the measured tip quantity [m]
  Eigen::VectorXd sd;         // per parameter (names())
  Conditioning conditioning;  // of the kinematic Jacobian
};

struct Plan {
  Eigen::MatrixXd readings;    // poses x dof, in path order [rad, m]
  std::vector<int> candidate;  // each pose's candidate (row of options.candidates or the pool)
  PlanCriterion criterion = PlanCriterion::kI;
  std::uint64_t seed = 1;
  int pool = 0;  // candidates considered
  int swaps = 0, sweeps = 0, refined_moves = 0;
  // Criterion (larger is better, scaled parameters): of the joint information
  // (encoders and measurements together) after the greedy start; of the exact
  // two-step information after the greedy start, the exchange and the refinement.
  double criterion_greedy = 0;
  double two_step_greedy = 0, two_step_exchange = 0, two_step_refined = 0;
  double path_length = 0, path_length_unordered = 0;  // sum of max |dq_j| between poses
  DesignFigures planned;
  DesignFigures random;               // of the random draw with the median rms_sd
  std::vector<double> random_rms_sd;  // every random draw's, sorted
  double random_median_rms_sd = 0;
  double seconds = 0;
};

// Random readings uniform within [lower, upper] per joint whose tool point (of
// `model`) the constraints admit; InputError if too few are admitted.
Eigen::MatrixXd random_readings(const DeviceModel& model, int count, std::uint64_t seed,
                                const PlanConstraints& constraints = {},
                                const Eigen::VectorXd& lower = {},
                                const Eigen::VectorXd& upper = {});

// Plans options.poses poses (InputError for a number the candidates cannot give).
Plan plan_poses(const PlanProblem& problem, const PlanOptions& options);

// plan.csv: header q1..qn, one row per pose, radians (metres for prismatic joints).
std::string plan_to_csv(const Eigen::MatrixXd& readings);

// The order of a short path through the poses: nearest neighbour from the pose
// nearest home (q = 0) in the max |dq_j| metric, then 2-opt.
std::vector<int> short_path(const Eigen::MatrixXd& readings);
double path_length(const Eigen::MatrixXd& readings);

}  // namespace hapticcal
