// The paper's simulation study (paper Tables 2-3, Figs 7, 8, 10)
// as a pipeline: synthetic logs in the format of a real experiment, the same
// `calibrate` procedure on them, and scoring against the truth; Monte Carlo over
// trials with Cramer-Rao bounds.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "hapticcal/identification/clock.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/model/model.hpp"
#include "hapticcal/study/iso9283.hpp"
#include "hapticcal/study/paper.hpp"
#include "hapticcal/study/session.hpp"
#include "hapticcal/study/simulation.hpp"

namespace hapticcal {

// Random deviations of the truth from nominal: each identifiable kinematic
// parameter (for the scenario's measurement, in calibrate's priority order) moved
// by a normal draw of its class's sd; a class at 0 is not moved.
struct RandomDeviations {
  double lengths = 0;      // sd [m]
  double angles = 0;       // sd [rad]
  std::uint64_t seed = 1;  // of the draws (the scenario's seed unless given)
  bool enabled() const { return lengths > 0 || angles > 0; }
};

// The random deviations of a device other than the paper's when its scenario
// names none: 1 mm and 1 mrad.
constexpr double kDefaultLengthDeviationSd = 1e-3;
constexpr double kDefaultAngleDeviationSd = 1e-3;
// Noise of a device other than the paper's unless the scenario gives it: a
// tracker of 10 um per coordinate (or a cable encoder of 10 um) and 10 urad.
constexpr double kDefaultSigmaM = 1e-5;
constexpr double kDefaultSigmaR = 1e-5;

struct Scenario {
  std::string device_path;  // the nominal device file (or URDF, with tip and root)
  std::string tip, root;    // a URDF's chain
  DeviceModel nominal;
  DeviceModel actual;  // the truth
  // The device is the paper's built-in one (is_paper_device): only then may the
  // truth be the paper's (Tables 2-3) and the paper's figures be compared.
  bool paper_device = true;
  // The truth's transmissions are the paper's Table 2 capstans and joint-4
  // linkage (paper device only); false: the device's own.
  bool paper_transmissions = true;
  // Kinematic truth: Table 3 (paper device, unless random deviations replace it)
  // or nominal, plus `random`, then the named `deviations` (SI, from nominal).
  RandomDeviations random;
  std::map<std::string, double> deviations;
  // What the identification log measures (the validation scores position and
  // orientation against the truth whatever it is). Fixture points and planes
  // are simulated by simulate_fixture_log and simulate_plane_log.
  MeasurementType measurement = MeasurementType::kDistance;
  // measurement: point (a fixture's sockets, the tool point put into each in
  // random configurations; sigma_m the placement error per axis; no external
  // encoders: an owner without instruments has none): the sockets in
  // the measurement frame (default: default_sockets of the nominal device), and
  // whether their distances are given to the calibration (--point-distance).
  std::vector<std::pair<std::string, Eigen::Vector3d>> sockets;
  bool socket_distances_known = true;
  // measurement: plane (the tool point touching unknown plates in random
  // configurations; sigma_m the contact error along the normal; no external
  // encoders): the plates in the measurement frame (default: default_planes of
  // the nominal device). No distance reaches the calibration: what planes
  // cannot see (the robot's size among it) the rank test holds.
  std::vector<SimulatedPlane> planes;
  int identification_poses = 200;
  // Readings to measure at (poses x dof, e.g. a plan.csv) instead of random
  // ones; identification_poses is then their count.
  Eigen::MatrixXd identification_readings;
  std::string identification_plan;  // the file they came from
  // CalibrationOptions::keep_all of the trials' calibrations. The paper's
  // procedure identifies every identifiable parameter by least squares, one
  // model (calibrate's model search off), so that its Monte Carlo compares with
  // the full model's Cramer-Rao bound; false: calibrate's default, the search.
  bool keep_all = true;
  std::vector<std::string> fix;  // CalibrationOptions::fix of the trials' calibrations
  int validation_poses = 200;
  double trajectory_seconds = 100;
  double trajectory_rate_hz = 1000;
  SimulationNoise noise;
  // "paper", "consistent", "given" or "default" (kDefaultSigmaM: not the paper's study)
  std::string sigma_m_formula = "paper";
  std::uint64_t seed = 1;
  int trials = 1;
  // session: a hand-guided session on two clocks instead of static poses
  // (run_session_study): the streams, the clocks' search and whether the drift
  // is fitted (default: when the session has one).
  std::optional<SessionOptions> session;
  double session_search_range = 10;
  bool session_fit_drift = false;
  // iso9283: ISO 9283's test after each trial's calibration (simulate_iso_test).
  std::optional<IsoSimulation> iso9283;

  // The paper's cable encoder: its device measured by distances (its sigma_m
  // formulas apply).
  bool paper_encoder() const { return paper_device && measures_distance(measurement); }
  // The paper's comparisons apply (its Table 2/3 I % column, its Fig. 10
  // percentages): the paper's device with the paper's truth, measured by distance.
  bool paper_comparison() const {
    return paper_encoder() && paper_transmissions && !random.enabled();
  }
};

// A hand-guided session's study (Scenario::session): the streams written to
// `dir` (device.csv, tracker.csv, validation.csv, nominal.yaml, actual.yaml),
// calibrated offset-aware (calibrated.yaml) and offset-blind
// (calibrated-offset-blind.yaml), scored on held-out static poses
// (results.json).
struct SessionStudy {
  StreamClock truth;
  ClockEstimate clock;
  CalibrationStatus status = CalibrationStatus::kConverged;
  std::string status_reason;
  int device_rows = 0, tracker_rows = 0, dropped = 0;
  // Held-out position RMS [m] against the validation log (with its noise), and
  // the distance from the truth's tool point.
  double rms_nominal = 0, rms_aware = 0, rms_blind = 0;
  double truth_aware = 0, truth_blind = 0;
  std::vector<std::string> lines;  // the terminal's
  std::string json;                // results.json as written
  // The offset-aware calibration and the samples it fitted (the report's).
  CalibrationResult aware;
  Log aware_poses;
};
// `progress(k, 100)`: the share done, through the streams' simulation, the
// clocks' search, their fit and the offset-blind fit (a terminal's bar).
SessionStudy run_session_study(const Scenario& scenario, const std::string& dir,
                               const std::function<void(int, int)>& progress = {});

// Whether `model` is the paper's built-in device (the same name, joint count,
// base kind and kinematic parameters as builtin_device_path()'s; limits and
// transmissions may differ).
bool is_paper_device(const DeviceModel& model);

// The paper's study on the built-in device file at `device_path`; on any other
// device (a device file, or a URDF with `tip` and `root`) the general study: the
// device's own transmissions as the truth, random deviations of
// kDefault*DeviationSd, distance measurements with kDefaultSigmaM.
Scenario default_scenario(const std::string& device_path, const std::string& tip = "",
                          const std::string& root = "");
// Sets the truth from the scenario's choices (paper_transmissions, random,
// deviations, measurement); throws InputError naming `source` when one does not
// apply to the device.
void assign_truth(Scenario& scenario, const std::string& source);
// A scenario file (YAML, `format: hapticcal-scenario/1`); every key optional:
//   device: PATH (relative to the file; a device file or a URDF)
//   tip: LINK, root: LINK                   a URDF's chain
//   seed: N     trials: N
//   measurement: distance | position | pose the identification log's (default distance)
//   transmissions: paper | device           the truth's (paper: the paper's device only)
//   random_deviations: {lengths: SD_M, angles: SD_RAD, seed: N}
//                                           normal deviations of every identifiable
//                                           kinematic parameter (replace Table 3)
//   poses: {identification: N | PLAN.csv, validation: N}
//                                           PLAN.csv (relative to the file; q1..qn as
//                                           `plan` writes it): measure exactly at its
//                                           readings, noise as usual
//   measurement: point,  sockets: {NAME: [X, Y, Z], ...}, socket_distances: known | unknown
//                                           a fixture (default: two sockets 50 mm apart)
//   measurement: plane,  planes: {NAME: {point: [X, Y, Z], normal: [X, Y, Z]}, ...}
//                                           plate contacts (default: default_planes)
//   poses.identification is spread over the sockets (at least 2 each) or the
//   planes (at least 4 each)
//   calibration: {keep_all: true | false,   CalibrationOptions::keep_all (true: the
//                                           paper's procedure; false: the model search)
//                 fix: [DOTTED_NAME, ...]}  and ::fix (e.g. what a plan reports held,
//                                           for plans with fewer measurements than
//                                           calibrate's candidates)
//   trajectory: {seconds: S, rate_hz: F}
//   noise: {sigma_e: RAD, sigma_m: paper | consistent | METRES, sigma_r: RAD,
//           motor_counts_per_rev: N}        sigma_m: of a distance or of each position
//                                           coordinate (the formulas: the paper's device
//                                           and distance only); sigma_r: a pose's rotation
//   deviations: {DOTTED_NAME: VALUE, ...}   replaces Table 3's (or the random) deviation
//                                           of a kinematic parameter (SI, added to nominal)
//   iso9283: {cycles: N, scatter: METRES,   ISO 9283's test after each calibration, at the
//             cube_size: METRES,            nominal model's test cube (plan_iso_cube: the
//             cube_centre: [X, Y, Z]}       largest in the workspace unless given)
// Anything that does not apply to the device is refused, never replaced.
// Unknown keys are errors naming the file, line and key.
Scenario load_scenario(const std::string& path, const std::string& default_device_path,
                       const std::string& default_tip = "", const std::string& default_root = "");

// The sd of one distance or position coordinate of the scenario's measurement [m].
double measurement_sigma(const Scenario& scenario);

// One trial's figures (metres, radians).
struct TrialResult {
  std::uint64_t seed = 0;
  CalibrationResult full, kinematic_only;
  // Validation poses (Fig. 8): RMS errors of the nominal and calibrated models
  // against the truth (per pose in fig8_validation.csv).
  double position_rms_before = 0, position_rms_after = 0;
  double orientation_rms_before = 0, orientation_rms_after = 0;
  double distance_rms_before = 0, distance_rms_after = 0;
  // Trajectory (Fig. 10): distance error RMS of the nominal, fully and kinematically calibrated
  // models.
  double trajectory_rms_before = 0, trajectory_rms_full = 0, trajectory_rms_kinematic = 0;
  // Cramer-Rao variances at the truth for this trial's poses, by dotted name.
  std::map<std::string, double> crlb_variance;
  // The series of the figures, for the report, in memory (the same numbers as
  // the trial's CSV files); filled when the trial writes its files.
  struct Figures {
    Log identification;  // as calibrated (read back from its file)
    std::vector<std::vector<double>>
        fig8;  // pose, position before, after, orientation before, after
    std::vector<std::vector<double>> fig10;  // t, distance, error nominal, full, kinematic-only
    std::map<std::string, std::vector<std::vector<double>>> fig7;  // by link: q, measured,
                                                                   // identified, truth
  } figures;
  std::optional<IsoTrial> iso;  // the scenario's ISO test
};

// The scenario's ISO 9283 test (Scenario::iso9283) of a trial's calibration
// `full` on `identification`, its scatter drawn from `seed`.
IsoTrial simulate_iso_test(const Scenario& scenario, const Log& identification,
                           const CalibrationResult& full, std::uint64_t seed);
// The trials' tests summarised (summarise_iso_trials) with their notes: the
// truth's deviations in parameters any trial's calibration held, and the
// model search's estimate beside a least-squares prediction.
IsoStudy iso_study(const Scenario& scenario, const std::vector<TrialResult>& trials);

// One trial with its seed. If `out` is not empty the logs (identification.csv,
// validation.csv, trajectory.csv), nominal.yaml, actual.yaml and calibrated.yaml
// are written there and calibration reads the logs back from the files.
TrialResult run_trial(const Scenario& scenario, std::uint64_t seed, const std::string& out);

// Paper eq. (8): (1 - |assigned - identified| / |assigned - nominal|) * 100.
double improvement_pct(double assigned, double nominal, double identified);

// One row of a trial's Table 2 (capstan) or Table 3 (kinematic) analogue.
struct StudyRow {
  std::string name;
  bool capstan = false;
  double assigned = 0, nominal = 0, identified = 0, improvement_pct = 0;
  std::string held;  // why a kinematic parameter whose truth deviates was not identified
  // The paper's units: Table 2 prints Re, r in mm, beta in deg; Table 3 deviations in mm, mrad.
  double paper_scale = 1;
  std::string paper_unit;
};

// The rows in table order: every identified capstan parameter, then every
// kinematic parameter that was identified or whose truth deviates from nominal.
std::vector<StudyRow> study_rows(const Scenario& scenario, const CalibrationResult& full);

// Seed of trial k of a study: a SplitMix64 step from the study seed, so that the
// trials are the same whatever the number of threads.
std::uint64_t trial_seed(std::uint64_t study_seed, int trial);

// Per dotted name, over the trials: assigned value, mean identified value, mean
// I % (paper eq. 8), RMSE, CRLB sd and efficiency RMSE / CRLB (crlb_sd 0 and
// efficiency NaN where no bound could be derived: the trials' information about
// the parameter was singular; the reports print "n/a", never a ratio of 0).
struct MonteCarloStats {
  double assigned = 0, nominal = 0, mean = 0, mean_improvement_pct = 0, rmse = 0, crlb_sd = 0,
         efficiency = 0;
  double improvement_p05 = 0, improvement_p95 = 0;  // 5th and 95th percentiles of I %
  int trials = 0;
};

struct StudyResult {
  TrialResult first;  // trial 0, whose files are written
  std::map<std::string, MonteCarloStats> monte_carlo;
  std::optional<IsoStudy> iso;  // the scenario's ISO tests over the trials (iso9283.csv)
  int trials = 0, threads = 1;
};

// Runs the trials on `threads` threads; progress(k, n) is called as trials finish.
StudyResult run_study(const Scenario& scenario, const std::string& out, int threads,
                      const std::function<void(int, int)>& progress = {});

}  // namespace hapticcal
