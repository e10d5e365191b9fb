#include "hapticcal/study/study.hpp"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <limits>
#include <mutex>
#include <nlohmann/json.hpp>
#include <random>

#include "hapticcal/core/cancel.hpp"
#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/core/option_ranges.hpp"
#include "hapticcal/core/parallel.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/identification/information.hpp"
#include "hapticcal/identification/tree.hpp"
#include "hapticcal/identification/two_step.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/model_io/model_source.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "study/fitted_step_one.hpp"
#include "study/simulated_limits.hpp"

namespace hapticcal {
namespace {

double rms_of_values(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x * x;
  return v.empty() ? 0 : std::sqrt(s / v.size());
}

// Distance errors of a model on a log with distances.
double distance_rms(const DeviceModel& model, const Log& log) {
  return evaluate(model, log).figure("distance")->stats.rms;
}

Eigen::VectorXd readings(const Log& log, int r) { return log.q.row(r).transpose(); }

// Cramer-Rao variances at the truth for the two-step procedure. Step 1: each
// fitted transmission's parameters (and c) from its external encoder, Fisher
// information J^T J / sigma_e^2. Step 2: the kinematic parameters from the
// distances, J_k^T J_k / sigma_m^2, plus the step-1 bounds carried in through the
// compensated angles: d kin = G d trans with G = -(J_k^T J_k)^-1 J_k^T J_t, J_t
// the distances' sensitivity to the transmission parameters.
// A fixture's (points or planes, no external encoders): sigma^2 (J^T J)^-1 of
// the fit's own rows at the truth, the unknown sockets or planes projected out
// and a given distance's row included, as the fit weighs them
// (tests/fixture_test's two_socket_study), over the parameters this trial's
// calibration identified.
std::map<std::string, double> stacked_crlb(const Scenario& sc, const Log& ident,
                                           const CalibrationResult& full,
                                           const CalibrationOptions& options) {
  const KinematicProblem problem = kinematic_problem(sc.actual, ident, {}, options);
  const Eigen::VectorXd p = sc.actual.kinematic_parameters();
  std::vector<int> slots;
  std::vector<std::string> names;
  for (const ParameterEstimate& e : full.kinematics.parameters) {
    if (!e.identifiable || e.slot >= p.size()) continue;  // the instrument's zero: none here
    slots.push_back(e.slot);
    names.push_back(e.name);
  }
  if (slots.empty()) return {};
  const Eigen::MatrixXd all = problem_jacobian(problem, p);
  Eigen::MatrixXd J(all.rows(), static_cast<Eigen::Index>(slots.size()));
  for (size_t c = 0; c < slots.size(); ++c) J.col(static_cast<Eigen::Index>(c)) = all.col(slots[c]);
  const Eigen::MatrixXd information = J.transpose() * J;
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(information);
  if (ldlt.info() != Eigen::Success) return {};
  const Eigen::MatrixXd covariance =
      std::pow(measurement_sigma(sc), 2) *
      ldlt.solve(Eigen::MatrixXd::Identity(information.rows(), information.cols()));
  std::map<std::string, double> out;
  for (size_t c = 0; c < names.size(); ++c) {
    const double v = covariance(static_cast<Eigen::Index>(c), static_cast<Eigen::Index>(c));
    if (std::isfinite(v) && v > 0) out[names[c]] = v;
  }
  return out;
}

std::map<std::string, double> crlb(const Scenario& sc, const Log& ident,
                                   const CalibrationResult& full,
                                   const CalibrationOptions& options) {
  if (is_fixture(sc.measurement) || sc.actual.tree()) return stacked_crlb(sc, ident, full, options);
  std::vector<int> slots;
  std::vector<std::string> names;
  for (const ParameterEstimate& e : full.kinematics.parameters) {
    if (!e.identifiable) continue;
    if (e.name == "instrument.zero") continue;  // the study's instruments have none
    slots.push_back(e.slot);
    names.push_back(e.name);
  }
  // The step-1 models as fitted (a polynomial in its basis), at the truth's readings.
  const std::vector<StepOneModel> step_one = detail::fitted_step_one(full);
  // Every residual row with the sd sigma_m: a pose's rotation rows scaled by
  // sigma_m / sigma_r.
  const double sigma_m = measurement_sigma(sc);
  const double rotation_scale =
      traits(sc.measurement).rotation ? sigma_m / sc.noise.sigma_orientation : 1.0;
  const TwoStepJacobians J =
      two_step_jacobians(sc.actual, sc.measurement, rotation_scale, slots, step_one, ident.q);
  const TwoStepBound bound =
      two_step_crlb(J.kinematic, names, sigma_m, J.step_one, sc.noise.sigma_ext);
  std::map<std::string, double> out;
  for (size_t c = 0; c < bound.names.size(); ++c) out[bound.names[c]] = bound.variance[c];
  return out;
}

double rotation_angle(const Eigen::Matrix3d& R) { return Eigen::AngleAxisd(R).angle(); }

// The scenario's measurement of `poses` poses of `model`: a fixture's points
// (its sockets, the tool point at each) or plane contacts (its planes), the
// poses shared out among them; else the instrument's readings at uniform poses
// or at `readings`, with `noise` (a fixture's: its position sd).
Log simulated_log(const Scenario& sc, const SimulationNoise& noise, const DeviceModel& model,
                  int poses, const Eigen::MatrixXd& readings, std::uint64_t seed) {
  if (!sc.sockets.empty()) {
    return simulate_fixture_log(model, sc.sockets, poses / static_cast<int>(sc.sockets.size()),
                                noise.sigma_position, seed);
  }
  if (!sc.planes.empty()) {
    return simulate_plane_log(model, sc.planes, poses / static_cast<int>(sc.planes.size()),
                              noise.sigma_position, seed);
  }
  return simulate_measurement_log(model, sc.measurement, poses, readings, noise, seed);
}

// What calibrate and the bounds take of a scenario's log: a tree's as one
// sample a tip (tip_samples), a chain's as it is.
Log samples(const Scenario& sc, const Log& log) {
  return sc.nominal.tree() ? tip_samples(sc.nominal, log) : log;
}

}  // namespace

double measurement_sigma(const Scenario& sc) {
  return kind_of(sc.measurement).sigma(sc.noise.instrument());
}

double improvement_pct(double assigned, double nominal, double identified) {
  return (1 - std::abs(assigned - identified) / std::abs(assigned - nominal)) * 100;
}

namespace {

// Eq. (8), undefined (NaN) for a parameter whose truth is its nominal value.
double improvement_or_nan(double assigned, double nominal, double identified) {
  return assigned == nominal ? std::numeric_limits<double>::quiet_NaN()
                             : improvement_pct(assigned, nominal, identified);
}

}  // namespace

std::vector<StudyRow> study_rows(const Scenario& sc, const CalibrationResult& full) {
  std::vector<StudyRow> rows;
  for (const TransmissionFit& t : full.transmissions) {
    const Transmission& truth = sc.actual.links[t.joint].transmission;
    if (t.kind != TransmissionKind::kCapstan || truth.kind() != TransmissionKind::kCapstan)
      continue;
    const Eigen::VectorXd tv = truth.parameters();
    for (int c = 0; c < 5; ++c) {
      const DisplayUnit u = display_unit(t, c);
      rows.push_back({t.names[c], true, tv[c], t.nominal[c], t.value[c],
                      improvement_or_nan(tv[c], t.nominal[c], t.value[c]), "", u.scale, u.unit});
    }
  }
  const Eigen::VectorXd truth = sc.actual.kinematic_parameters();
  for (const ParameterEstimate& e : full.kinematics.parameters) {
    if (e.slot >= truth.size()) continue;  // the instrument's zero: not the device's
    const double assigned = truth[e.slot];
    if (!e.identifiable && assigned == e.nominal) continue;
    const DisplayUnit u = display_unit(e.unit);
    rows.push_back({e.name, false, assigned, e.nominal, e.value,
                    e.identifiable ? improvement_or_nan(assigned, e.nominal, e.value) : 0.0,
                    e.identifiable ? "" : e.reason, u.scale, u.unit});
  }
  return rows;
}

bool is_paper_device(const DeviceModel& model) {
  DeviceModel paper;
  try {
    paper = load_device(builtin_device_path());
  } catch (const std::exception&) {
    return false;  // no built-in device here: nothing can be the paper's
  }
  return model.name == paper.name && model.dof() == paper.dof() &&
         model.base_kind == paper.base_kind &&
         model.kinematic_parameters() == paper.kinematic_parameters();
}

namespace {

// Every pair of sockets' distance, as --point-distance gives it.
std::vector<PointDistance> socket_distances(
    const std::vector<std::pair<std::string, Eigen::Vector3d>>& sockets) {
  std::vector<PointDistance> out;
  for (size_t a = 0; a < sockets.size(); ++a) {
    for (size_t b = a + 1; b < sockets.size(); ++b) {
      out.push_back(
          {sockets[a].first, sockets[b].first, (sockets[a].second - sockets[b].second).norm()});
    }
  }
  return out;
}

// The distances between the scenario's sockets the calibration is given
// (--point-distance): every pair's if they are known, else none.
std::vector<PointDistance> given_distances(const Scenario& sc) {
  return sc.socket_distances_known ? socket_distances(sc.sockets) : std::vector<PointDistance>{};
}

// The kinematic parameters the scenario's measurement identifies on `nominal` (calibrate's
// candidates and priority order, its rank test on exact synthetic measurements
// over the joint limits): those random deviations move, so that the truth is
// one a calibration can recover.
std::vector<int> identifiable_slots(const DeviceModel& nominal, const Scenario& sc) {
  const std::vector<std::string>& fix = sc.fix;
  constexpr int kPoses = 200;
  constexpr std::uint64_t kSeed = 20130101;
  SimulationNoise exact;
  exact.sigma_ext = exact.sigma_distance = exact.sigma_position = exact.sigma_orientation = 0;
  CalibrationOptions options;
  options.fix = fix;
  const Log log = samples(sc, simulated_log(sc, exact, nominal, kPoses, {}, kSeed));
  options.point_distances = given_distances(sc);
  KinematicProblem problem = kinematic_problem(nominal, log, {}, options);
  const std::vector<int> candidates = candidate_slots(nominal, fix, {});
  // As calibrate orders them: a tracker's frame unknown, the base first.
  problem.frame_unknown = measurement_frame_unknown(problem, candidates, false);
  std::vector<int> slots = analyze_identifiability(problem, candidates).identified;
  std::sort(slots.begin(), slots.end());
  return slots;
}

}  // namespace

void assign_truth(Scenario& sc, const std::string& source) {
  if (sc.paper_transmissions && !sc.paper_device) {
    throw InputError(source, 0, "transmissions",
                     "the paper's capstans and joint-4 linkage (Table 2) are the truth of the "
                     "paper's device only: this device's own transmissions are its truth "
                     "(transmissions: device)");
  }
  if (sc.paper_transmissions && !sc.random.enabled()) {
    sc.actual = paper_actual_device(sc.nominal);  // the paper's study, as it always was
  } else {
    sc.actual = sc.nominal;
    if (sc.paper_transmissions) {
      const DeviceModel paper = paper_actual_device(sc.nominal);
      for (int j = 0; j < sc.nominal.dof(); ++j)
        sc.actual.links[j].transmission = paper.links[j].transmission;
    } else if (sc.paper_device && !sc.random.enabled()) {
      sc.actual.set_kinematic_parameters(paper_actual_device(sc.nominal).kinematic_parameters());
    }
  }
  const Eigen::VectorXd nominal = sc.nominal.kinematic_parameters();
  Eigen::VectorXd truth = sc.actual.kinematic_parameters();
  const std::vector<ParameterInfo> info = sc.nominal.parameter_info();
  if (sc.random.enabled()) {
    std::mt19937_64 rng(sc.random.seed);
    std::normal_distribution<double> gauss(0.0, 1.0);
    for (int slot : identifiable_slots(sc.nominal, sc)) {
      const bool angle = info[slot].unit == ParameterUnit::kAngle;
      truth[slot] = nominal[slot] + (angle ? sc.random.angles : sc.random.lengths) * gauss(rng);
    }
  }
  for (const auto& [dotted, value] : sc.deviations) {
    const std::string& name =
        dotted;  // (a structured binding is not captured before C++20's P1091)
    const auto it = std::find_if(info.begin(), info.end(),
                                 [&](const ParameterInfo& p) { return p.name == name; });
    if (it == info.end())
      throw InputError(source, 0, "deviations." + name, "not a kinematic parameter of the device");
    truth[it->slot] = nominal[it->slot] + value;
  }
  if (sc.random.enabled() || !sc.deviations.empty()) sc.actual.set_kinematic_parameters(truth);
}

Scenario default_scenario(const std::string& device_path, const std::string& tip,
                          const std::string& root) {
  Scenario sc;
  sc.device_path = device_path;
  sc.tip = tip;
  sc.root = root;
  sc.nominal = load_model(device_path, tip, root);
  // A tree is measured by one point a tip (simulate_measurement_log).
  if (sc.nominal.tree()) sc.measurement = MeasurementType::kPosition;
  sc.paper_device = is_paper_device(sc.nominal);
  sc.noise.sigma_orientation = kDefaultSigmaR;  // a pose's, if one is measured
  if (sc.paper_device) {
    sc.actual = paper_actual_device(sc.nominal);
    return sc;
  }
  sc.paper_transmissions = false;
  sc.random = {kDefaultLengthDeviationSd, kDefaultAngleDeviationSd, sc.seed};
  sc.noise.sigma_distance = sc.noise.sigma_position = kDefaultSigmaM;
  sc.sigma_m_formula = "default";
  detail::check_simulated_limits(sc);
  assign_truth(sc, device_path);
  return sc;
}

std::uint64_t trial_seed(std::uint64_t study_seed, int trial) {
  std::uint64_t z = study_seed + 0x9E3779B97F4A7C15ull * static_cast<std::uint64_t>(trial + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

namespace {

// Fig. 10: the continuous motion of the first trial (its files in `out`), and
// the series for the figures.
void trajectory_figure(const Scenario& sc, std::uint64_t seed, const std::string& out,
                       TrialResult& t) {
  Log traj = simulate_trajectory(sc.actual, sc.trajectory_seconds, sc.trajectory_rate_hz, sc.noise,
                                 trial_seed(seed, 2));
  write_file_atomically(out + "/trajectory.csv", log_to_csv(traj));
  traj = read_log(out + "/trajectory.csv");
  const Evaluation eb = evaluate(sc.nominal, traj), ef = evaluate(t.full.calibrated, traj),
                   ek = evaluate(t.kinematic_only.calibrated, traj);
  t.trajectory_rms_before = eb.figure("distance")->stats.rms;
  t.trajectory_rms_full = ef.figure("distance")->stats.rms;
  t.trajectory_rms_kinematic = ek.figure("distance")->stats.rms;
  std::string fig10 = "t,distance,error_nominal,error_full,error_kinematic_only\n";
  t.figures.fig10.assign(5, {});
  const int step = std::max(1, static_cast<int>(sc.trajectory_rate_hz / 100));  // 100 Hz
  for (int r = 0; r < traj.rows; r += step) {
    const double row[] = {traj.t[r], traj.distance[r], eb.figure("distance")->error[r],
                          ef.figure("distance")->error[r], ek.figure("distance")->error[r]};
    fig10 += fmt::format("{},{},{},{},{}\n", row[0], row[1], row[2], row[3], row[4]);
    for (int c = 0; c < 5; ++c) t.figures.fig10[c].push_back(row[c]);
  }
  write_file_atomically(out + "/fig10_trajectory.csv", fig10);
}

// Fig. 7: each polynomial transmission's error: measured (ext - q - c),
// identified, true.
void transmission_error_figures(const Scenario& sc, const Log& ident, const std::string& out,
                                TrialResult& t) {
  for (const TransmissionFit& f : t.full.transmissions) {
    if (f.kind != TransmissionKind::kPolynomial) continue;
    const Transmission& fitted = t.full.calibrated.links[f.joint].transmission;
    const Transmission& real = sc.actual.links[f.joint].transmission;
    std::string fig7 = "q,measured,identified,truth\n";
    auto& series = t.figures.fig7[t.full.calibrated.links[f.joint].name];
    series.assign(4, {});
    for (int r = 0; r < ident.rows; ++r) {
      const double q = ident.q(r, f.joint);
      const double row[] = {q, ident.ext(r, f.joint) - q - f.offset, fitted.error(q),
                            real.error(q)};
      fig7 += fmt::format("{},{},{},{}\n", row[0], row[1], row[2], row[3]);
      for (int c = 0; c < 4; ++c) series[c].push_back(row[c]);
    }
    write_file_atomically(out + fmt::format("/fig7_{}.csv", t.full.calibrated.links[f.joint].name),
                          fig7);
  }
}

}  // namespace

TrialResult run_trial(const Scenario& sc, std::uint64_t seed, const std::string& out) {
  throw_if_cancelled();  // Python's Ctrl-C (core/cancel.hpp); its solvers look too
  TrialResult t;
  t.seed = seed;
  Log ident = simulated_log(sc, sc.noise, sc.actual, sc.identification_poses,
                            sc.identification_readings, trial_seed(seed, 0));
  SimulationNoise exact = sc.noise;
  exact.sigma_position = 0;  // a perfect tracker: validation scores against the truth
  const bool tree = sc.actual.tree();
  Log val =
      tree ? simulate_measurement_log(sc.actual, MeasurementType::kPosition, sc.validation_poses,
                                      {}, exact, trial_seed(seed, 1))
           : simulate_log(sc.actual, sc.validation_poses, exact, trial_seed(seed, 1), true, true);
  const bool files = !out.empty();
  if (files) {
    // The honest pipeline: what calibration sees comes from the files a real
    // experiment would produce.
    save_device(sc.nominal, out + "/nominal.yaml");
    save_device(sc.actual, out + "/actual.yaml");
    write_file_atomically(out + "/identification.csv", log_to_csv(ident));
    write_file_atomically(out + "/validation.csv", log_to_csv(val));
    ident = read_log(out + "/identification.csv");
    val = read_log(out + "/validation.csv");
  }
  CalibrationOptions options;
  options.keep_all = sc.keep_all;
  // The paper's procedure is one model (every identifiable parameter by least
  // squares); keep_all false is calibrate's default, the model search.
  options.search = !sc.keep_all;
  options.fix = sc.fix;
  // The simulated instruments read without a zero error: the study is of the
  // device's parameters (and their Cramer-Rao bound), as the paper's.
  options.instrument_zero = false;
  options.point_distances = given_distances(sc);
  const Log fit_log = samples(sc, ident);
  const Log check_log = samples(sc, val);  // a tree's: one sample a tip, each with its tip
  t.full = calibrate(sc.nominal, fit_log, options);
  CalibrationOptions kin = options;
  kin.transmissions = false;
  t.kinematic_only = calibrate(sc.nominal, fit_log, kin);

  // Fig. 8: validation poses against the truth.
  const PreparedModel truth(sc.actual), before(sc.nominal), after(t.full.calibrated);
  std::vector<double> position_before, position_after, orientation_before, orientation_after;
  for (int r = 0; r < check_log.rows; ++r) {
    const Eigen::VectorXd q = readings(check_log, r);
    const int tip = check_log.tip.empty() ? 0 : check_log.tip[static_cast<size_t>(r)];
    const Frame<double> Ta = truth.forward(q.data(), tip), Tb = before.forward(q.data(), tip),
                        Tc = after.forward(q.data(), tip);
    position_before.push_back((Tb.p - Ta.p).norm());
    position_after.push_back((Tc.p - Ta.p).norm());
    orientation_before.push_back(rotation_angle(Ta.R.transpose() * Tb.R));
    orientation_after.push_back(rotation_angle(Ta.R.transpose() * Tc.R));
  }
  t.position_rms_before = rms_of_values(position_before);
  t.position_rms_after = rms_of_values(position_after);
  t.orientation_rms_before = rms_of_values(orientation_before);
  t.orientation_rms_after = rms_of_values(orientation_after);
  constexpr double kNone = std::numeric_limits<double>::quiet_NaN();
  t.distance_rms_before = tree ? kNone : distance_rms(sc.nominal, val);
  t.distance_rms_after = tree ? kNone : distance_rms(t.full.calibrated, val);
  t.crlb_variance = crlb(sc, fit_log, t.full, options);
  if (sc.iso9283) t.iso = simulate_iso_test(sc, ident, t.full, trial_seed(seed, 3));
  if (tree) {  // no trajectory: a cable encoder measures one tool point
    t.trajectory_rms_before = t.trajectory_rms_full = t.trajectory_rms_kinematic = kNone;
  }
  if (!files) return t;
  save_device(t.full.calibrated, out + "/calibrated.yaml");
  save_device(t.kinematic_only.calibrated, out + "/calibrated-kinematic-only.yaml");
  t.figures.identification = ident;
  std::string fig8 = "pose,position_before,position_after,orientation_before,orientation_after\n";
  t.figures.fig8.assign(5, {});
  for (size_t r = 0; r < position_before.size(); ++r) {
    const double row[] = {static_cast<double>(r + 1), position_before[r], position_after[r],
                          orientation_before[r], orientation_after[r]};
    fig8 += fmt::format("{},{},{},{},{}\n", r + 1, row[1], row[2], row[3], row[4]);
    for (int c = 0; c < 5; ++c) t.figures.fig8[c].push_back(row[c]);
  }
  write_file_atomically(out + "/fig8_validation.csv", fig8);

  if (!tree) trajectory_figure(sc, seed, out, t);  // Fig. 10
  transmission_error_figures(sc, ident, out, t);   // Fig. 7
  return t;
}

namespace detail {

// A simulation draws readings within the joint limits: limits of 1e308 would
// overflow its own log into inf. Refused, naming the device file.
void check_simulated_limits(const Scenario& sc) {
  constexpr double kWidest = 1e3;  // rad or m
  for (const DeviceModel* m : {&sc.actual, &sc.nominal}) {
    for (int i = 0; i < m->dof(); ++i) {
      const Link& l = m->links[i];
      // The study's validation, trajectories and fixtures have no approach sides.
      if (l.backlash != 0) {
        throw InputError(sc.device_path, 0, fmt::format("links[{}].backlash", i),
                         "the simulation study does not model backlash (calibrate and evaluate "
                         "do, from a log's dir<i> columns)");
      }
      if (std::abs(l.lower) <= kWidest && std::abs(l.upper) <= kWidest) continue;
      throw InputError(sc.device_path, 0, fmt::format("links[{}].limits", i),
                       fmt::format("[{}, {}]: a simulation draws readings within the limits; at "
                                   "most +-{:g} rad or m",
                                   l.lower, l.upper, kWidest));
    }
  }
}

}  // namespace detail

namespace {

// A trial's own pipeline failed (its identification log written and read back,
// then calibrated): the message names the trial, not a staging file that is
// gone by the time it is read, nor an option the user never gave.
InputError study_failure(const Scenario& sc, int trial, const InputError& e) {
  std::string what = e.message();
  for (const auto& [option, instead] :
       {std::pair<std::string, std::string>{"--point-distance", "the scenario's socket distances"},
        {"--fixture", "the scenario's sockets"}}) {
    what = replace_all(what, option, instead);
  }
  const bool simulated = e.file().find("/identification.csv") != std::string::npos ||
                         e.file().find("/validation.csv") != std::string::npos ||
                         e.file().find("/trajectory.csv") != std::string::npos;
  const std::string where =
      simulated
          ? fmt::format("its simulated {}{}", std::filesystem::path(e.file()).filename().string(),
                        e.line() > 0 ? fmt::format(" (line {})", e.line()) : "")
      : e.file().empty()
          ? std::string("its calibration")
          : fmt::format("{}{}", e.file(), e.line() > 0 ? fmt::format(":{}", e.line()) : "");
  return InputError(fmt::format("simulate: trial {} of {} (seed {}): {}: {}{}", trial + 1,
                                sc.trials, sc.seed, where, e.key().empty() ? "" : e.key() + ": ",
                                what));
}

}  // namespace

StudyResult run_study(const Scenario& sc, const std::string& out, int threads,
                      const std::function<void(int, int)>& progress) {
  // The command line's bounds, for every caller (Python's trials=10**9).
  check_option("--trials", sc.trials, option_range::kTrials);
  detail::check_simulated_limits(sc);
  const int n = sc.trials;
  std::vector<TrialResult> trials(n);
  std::atomic<int> done{0};
  std::mutex report;
  // A trial's bad input names the trial; the first failure stops the study.
  threads = std::max(1, std::min(threads, n));
  parallel_for(static_cast<size_t>(n), static_cast<size_t>(threads), [&](size_t k) {
    const int trial = static_cast<int>(k);
    try {
      trials[k] = run_trial(sc, trial_seed(sc.seed, trial), k == 0 ? out : "");
    } catch (const InputError& e) {
      throw study_failure(sc, trial, e);
    }
    const int finished = ++done;
    if (progress) {
      const std::lock_guard<std::mutex> lock(report);
      progress(finished, n);
    }
  });

  StudyResult result;
  result.trials = n;
  result.threads = threads;
  // Statistics in trial order, so the thread count cannot change them.
  std::map<std::string, std::vector<double>> identified, improvement_pct, variance;
  std::map<std::string, StudyRow> reference;
  for (const TrialResult& t : trials) {
    for (const StudyRow& row : study_rows(sc, t.full)) {
      if (!row.held.empty()) continue;
      identified[row.name].push_back(row.identified);
      improvement_pct[row.name].push_back(row.improvement_pct);
      reference[row.name] = row;
      const auto v = t.crlb_variance.find(row.name);
      if (v != t.crlb_variance.end()) variance[row.name].push_back(v->second);
    }
  }
  for (const auto& [name, values] : identified) {
    MonteCarloStats m;
    m.trials = static_cast<int>(values.size());
    m.assigned = reference[name].assigned;
    m.nominal = reference[name].nominal;
    double sum = 0, sq = 0, ip = 0;
    for (size_t k = 0; k < values.size(); ++k) {
      sum += values[k];
      sq += (values[k] - m.assigned) * (values[k] - m.assigned);
      ip += improvement_pct[name][k];
    }
    m.mean = sum / values.size();
    m.rmse = std::sqrt(sq / values.size());
    m.mean_improvement_pct = ip / values.size();
    std::vector<double> sorted = improvement_pct[name];
    std::sort(sorted.begin(), sorted.end());
    m.improvement_p05 = sorted[static_cast<size_t>(0.05 * (sorted.size() - 1))];
    m.improvement_p95 = sorted[static_cast<size_t>(0.95 * (sorted.size() - 1))];
    double var = 0;
    for (double v : variance[name]) var += v;
    m.crlb_sd = variance[name].empty() ? 0 : std::sqrt(var / variance[name].size());
    // No bound (none derived for the parameter): no ratio, never a fake 0.
    m.efficiency = m.crlb_sd > 0 ? m.rmse / m.crlb_sd : std::numeric_limits<double>::quiet_NaN();
    result.monte_carlo[name] = m;
  }
  if (sc.iso9283) {
    result.iso = iso_study(sc, trials);
    if (!out.empty()) write_file_atomically(out + "/iso9283.csv", iso_trials_csv(*result.iso));
  }
  result.first = std::move(trials[0]);
  return result;
}

}  // namespace hapticcal
