// Pose and distance characteristics of ISO 9283:1998 (Manipulating industrial
// robots - Performance criteria and related test methods): pose accuracy AP
// and repeatability RP (position and orientation, clause 7.2), distance
// accuracy AD and repeatability RD (clause 7.3), from the poses a robot
// attained over n cycles against the poses it was commanded to.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "hapticcal/core/log.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/model/frame.hpp"
#include "hapticcal/model/model.hpp"
#include "hapticcal/study/iso9283_cube.hpp"

namespace hapticcal {

// One pose of the test (P1 .. P5): the commanded pose and what was attained in
// each cycle (cycle order; a cycle that missed the pose is absent).
struct IsoPoseRuns {
  std::string label;
  Frame<double> commanded = Frame<double>::Identity();
  std::vector<int> cycles;              // the cycle number of each attained pose
  std::vector<Frame<double>> attained;  // one a cycle
  bool orientation = false;             // the attained orientations were measured
};

// A pose's characteristics. Orientations as the standard's a, b, c: turns
// about the x, y and z axes (here URDF's roll, pitch, yaw: R = Rz(c) Ry(b)
// Rx(a)); an attained angle is taken relative to the commanded one, into
// (-pi, pi], so that a pose near +-pi is not split across the wrap.
struct IsoPoseCriteria {
  std::string label;
  int cycles = 0;                   // n
  Eigen::Vector3d commanded, mean;  // x_c, y_c, z_c; the barycentre [m]
  Eigen::Vector3d ap_xyz;           // AP_x, AP_y, AP_z = mean - commanded [m]
  double ap = 0;                    // AP_P = |mean - commanded| [m]
  double rp = 0;                    // RP_l = l_mean + 3 S_l [m]; NaN with n < 2
  bool orientation = false;
  Eigen::Vector3d ap_abc = Eigen::Vector3d::Zero();  // AP_a, AP_b, AP_c [rad]
  Eigen::Vector3d rp_abc = Eigen::Vector3d::Zero();  // RP_a, RP_b, RP_c = 3 S [rad]; NaN with n < 2
};

// The distance characteristics of two poses over the cycles that attained both:
// D_j = |P_1j - P_2j|, D_c = |P_1c - P_2c|, AD = mean D - D_c, RD = 3 S_D.
struct IsoDistanceCriteria {
  std::string from, to;
  int cycles = 0;
  double commanded = 0, mean = 0;  // D_c, mean D_j [m]
  double ad = 0, rd = 0;           // [m]; rd NaN with fewer than 2 cycles
};

IsoPoseCriteria iso_pose_criteria(const IsoPoseRuns& runs);
IsoDistanceCriteria iso_distance_criteria(const IsoPoseRuns& from, const IsoPoseRuns& to);

// Every pose's characteristics, and the distances: P2 to P4 (the standard's
// pair) if both are there, then P1 (the cube's centre; without one, the first
// pose) to each other pose.
struct IsoCriteria {
  std::vector<IsoPoseCriteria> poses;
  std::vector<IsoDistanceCriteria> distances;
};
IsoCriteria iso_criteria(const std::vector<IsoPoseRuns>& poses);

// The runs of a test log: row r attained the pose labels[r] (P1 .. P5, as the
// plan's plan.csv names them), the k-th row of a label in cycle k. A pose's
// commanded pose is the model's at the mean of its rows' readings; the
// attained ones the log's positions (and orientations, a pose log's). Poses in
// the order P1, P2, ... (other labels after them, by name). Throws InputError for a log without
// positions or labels of another count than its rows.
std::vector<IsoPoseRuns> iso_runs(const DeviceModel& model, const Log& log,
                                  const std::vector<std::string>& labels);

// The order plan --iso9283 writes each cycle's poses in.
inline constexpr const char* kIsoCycleOrder[] = {"P1", "P5", "P4", "P3", "P2"};

// A test plan's labels (its `point` column) follow its pattern: cycle after
// cycle the five poses in kIsoCycleOrder, every cycle whole (so each label
// counts the cycles). A log with labels of its own must have the plan's, row by
// row. InputError naming the first line that breaks the pattern.
void check_iso_labels(const Log& plan, const Log& log);

// The attained positions plausible for `model`: their RMS distance from the
// commanded poses within kImplausibleErrorFraction of the reach (the farthest
// commanded tool point from the base). Else InputError naming the log's x
// column and what the positions fit: read in mm or um as metres (the unit
// hint), the model's poses in another frame (--register), or nothing.
void check_iso_positions(const DeviceModel& model, const Log& log,
                         const std::vector<IsoPoseRuns>& runs);

// The test simulated after a calibration (a simulate scenario's `iso9283`
// key): at each pose of the nominal model's test cube the robot (the truth)
// attains the truth's tool point at the pose's joint targets, scattered by
// `scatter` per coordinate in each cycle; the nominal and the calibrated model
// command it (their tool points at the same targets). Positions only.
struct IsoSimulation {
  IsoCubeOptions cube;  // centre, edge and cycles (the standard's 30)
  // sd of each coordinate of an attained position [m]: the robot's repetition
  // and the instrument's noise together.
  double scatter = 1e-5;
  IsoCubePlan plan;  // on the nominal model
};

struct IsoTrial {
  IsoCriteria nominal, calibrated;  // commanded by the nominal, by the calibrated model
  // The calibrated model's expected AP at each pose (iso_predicted_ap) [m].
  std::vector<double> predicted_ap;
};

// The instruments' noise as a user states it (their data sheets): the sd of
// a distance or of each position coordinate [m], of a pose's rotation about
// each axis [rad], of an external encoder [rad].
struct IsoInstrumentNoise {
  double measurement = 0, rotation = 0, encoder = 0;
};

// The calibrated model's expected AP at each pose of `plan` from the
// covariance C of the calibration's parameters:
//   sqrt(trace(G C G^T) + 3 scatter^2 / cycles),
// G the tool point's derivatives by the parameters at the pose's targets; the
// second term the mean of `cycles` scattered positions. C: that of calibrate's
// least-squares estimate on `identification` at the calibrated model, each row
// with the instruments' noise (a pose's rotation rows differ from its position
// rows), with step-1 transmissions fitted from external encoders carried into
// the kinematic parameters (the two-step covariance); a fixture's: the
// covariance the calibration states (its sd and correlations, the unknown
// sockets or planes accounted for). NaN where C is not finite.
std::vector<double> iso_predicted_ap(const CalibrationResult& calibration,
                                     const Log& identification, const IsoInstrumentNoise& noise,
                                     const IsoCubePlan& plan, double scatter);

// A study's tests over its trials: per pose (the plan's order) the RMS of AP
// over the trials for each model and predicted, the mean RP; over every pose
// and trial the RMS of each. The calibrated model's AP and its prediction are
// taken where both are numbers (a prediction is NaN where the calibration's
// covariance is not finite): left_out counts the poses of trials left out.
struct IsoPoseSummary {
  std::string label;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();  // the commanded (nominal) position [m]
  double ap_nominal = 0, ap_calibrated = 0, ap_predicted = 0, rp = 0;  // [m]
};
struct IsoStudy {
  std::vector<IsoPoseSummary> poses;
  double ap_nominal = 0, ap_calibrated = 0, ap_predicted = 0;  // [m]
  std::vector<IsoTrial> trials;                                // in trial order
  int left_out = 0;
  // What a reader of the numbers should know, one sentence each (run_study
  // adds them): the truth's deviations in parameters a trial's calibration
  // held, whose error is in the simulated AP and not in the prediction; a
  // prediction of least squares beside calibrate's model search.
  std::vector<std::string> notes;
};
IsoStudy summarise_iso_trials(const IsoCubePlan& plan, std::vector<IsoTrial> trials);
// iso9283.csv: trial,pose,ap_nominal,ap_calibrated,ap_predicted,rp [m], a row a
// pose of a trial.
std::string iso_trials_csv(const IsoStudy& study);

}  // namespace hapticcal
