// calibrate's and evaluate's options (jobs/command_options.hpp): the one place
// their keywords, help, ranges and defaults are written; the defaults are those
// of a default-constructed request (CalibrationOptions, StreamOptions).
#include <cmath>

#include "hapticcal/identification/markers.hpp"
#include "hapticcal/jobs/calibrate_job.hpp"
#include "hapticcal/jobs/command_options.hpp"
#include "hapticcal/jobs/compensate_job.hpp"
#include "hapticcal/jobs/evaluate_job.hpp"
#include "hapticcal/jobs/force_job.hpp"
#include "hapticcal/jobs/simulate_job.hpp"
#include "hapticcal/study/evaluate.hpp"

namespace hapticcal {

namespace {

// --tracker and its clock options, for a request with `tracker` and `stream`.
template <class Request>
void add_tracker_options(CommandOptions<Request>& t, const std::string& tracker_help) {
  t.push_back(field_option<Request>(
      "tracker", tracker_help, [](Request & r) -> auto& { return r.tracker; }));
  auto search = field_option<Request>(
      "clock_search", "With --tracker: the clocks' offset is searched within +-SECONDS",
      [](Request & r) -> auto& { return r.stream.search_range; }, option_range::kClockSearch);
  search.needs = "tracker";
  t.push_back(search);
  auto drift = field_option<Request>(
      "clock_drift", "With --tracker: estimate the clocks' drift (rate difference) too",
      [](Request & r) -> auto& { return r.stream.drift; });
  drift.needs = "tracker";
  t.push_back(drift);
}

template <class Request>
CommandOption<Request> required(CommandOption<Request> o) {
  o.required = true;
  return o;
}

// --tool-point: "nominal", or X,Y,Z in metres (each within 10 m).
void read_tool_point(CalibrateRequest& r, const OptionValue& v, const std::string& as) {
  const std::string& text = std::get<std::string>(v);
  if (text == "nominal") {
    r.nominal_tool = true;
    return;
  }
  if (text.find(',') == std::string::npos) {
    throw InputError(
        fmt::format("{} '{}': expected X,Y,Z in metres or 'nominal'", as, printable(text)));
  }
  const std::array<double, 3> point = comma_numbers<3>(text, as);
  for (double x : point) {
    if (std::abs(x) > 10)
      throw InputError(fmt::format("{}: {} is not a coordinate in metres (|x| <= 10)", as, x));
  }
  r.tool_point = point;
}

// What step 2 fits and how: parameters held or freed, the joint-error
// families, the fixture, the estimator, the prior's tolerances, the search.
void add_model_options(CommandOptions<CalibrateRequest>& t) {
  using R = CalibrateRequest;
  t.push_back(field_option<R>(
      "fix", "Kinematic parameters held at nominal, e.g. j1.a,j2.d",
      [](R & r) -> auto& { return r.options.fix; }));
  t.push_back(field_option<R>(
      "joint_errors",
      "Joint-error families fitted with the geometry, instead of those the search finds: "
      "harmonic (first and second harmonic of each joint's angle, and of its motor's through a "
      "capstan), compliance (each joint's deflection k tau under the gravity torque of the "
      "model's masses), coupling (the coupling's coefficients between joints), backlash (an "
      "offset per approach direction, from the log's dir<i> columns), or none; the geometry "
      "alone is fitted beside them for comparison",
      [](R & r) -> auto& { return r.options.joint_errors; }));
  t.push_back(field_option<R>(
      "free",
      "Parameters added to the candidates, e.g. j2.beta (a beta is one by default only where "
      "neighbouring joint axes are parallel)",
      [](R & r) -> auto& { return r.options.free; }));
  t.push_back(field_option<R>(
      "point_distance",
      "A known distance between two fixture points of the log (column point): A:B=METRES "
      "(repeatable)",
      [](R & r) -> auto& { return r.point_distances; }));
  t.push_back(field_option<R>(
      "fixture",
      "Fixture file (YAML): known positions (points) and distances of the log's fixture points",
      [](R & r) -> auto& { return r.fixture; }));
  t.push_back(field_option<R>(
      "keep_all",
      "Plain least squares: fit every identifiable parameter the data excite, without the "
      "tolerance prior (the search compares least squares only)",
      [](R & r) -> auto& { return r.options.keep_all; }));
  t.push_back(field_option<R>(
      "select",
      "The significance cut: hold parameters whose change is below the 5 % family-wise "
      "threshold (plain least squares on the rest)",
      [](R & r) -> auto& { return r.options.select; }));
  t.push_back(field_option<R>(
      "prior",
      "The tolerance prior: each parameter pulled toward nominal by its tolerance, at the "
      "scale of highest evidence",
      [](R & r) -> auto& { return r.options.prior; }));
  t.push_back(field_option<R>(
      "search",
      "Fit exactly the model the other options name instead of searching: the joint-error "
      "families of --joint-errors (none if not given), the instrument's zero fitted (--fix "
      "instrument.zero: held), the estimator of --keep-all, --select or --prior (default the "
      "tolerance prior)",
      [](R & r) -> auto& { return r.options.search; }));
  t.push_back(parsed_option<R>(
      "tolerance", OptionKind::kList,
      "A tolerance of the prior, NAME=SD in SI units: length (default 0.0005 m), angle (0.005 "
      "rad) or a parameter, e.g. j2.a=0.001 (repeatable)",
      [](R& r, const OptionValue& v, const std::string&) {
        for (const std::string& item : std::get<std::vector<std::string>>(v))
          add_tolerance(r.options.tolerances, item);
      }));
  t.push_back(field_option<R>(
      "prior_scale", "The common scale of the tolerances (default: the one of highest evidence)",
      [](R & r) -> auto& { return r.options.tolerances.scale; }, option_range::kPriorScale));
}

CommandOptions<CalibrateRequest> calibrate_table() {
  using R = CalibrateRequest;
  CommandOptions<R> t;
  t.push_back(required(field_option<R>(
      "model",
      "The nominal model: a device file (YAML) or a URDF (.urdf, with --tip; then "
      "calibrated.urdf is written too)",
      [](R & r) -> auto& { return r.model; })));
  add_chain_options(t);
  t.push_back(required(field_option<R>(
      "log", "Measurement log (CSV); with --tracker the device's stream (t, q<i>)",
      [](R & r) -> auto& { return r.log; })));
  add_tracker_options(
      t,
      "A tracker's stream (CSV: t and x, y, z [, qw..qz | x1, y1, z1, ...: a marker body], on "
      "its own clock): the clocks' offset is estimated with the kinematics, the readings "
      "interpolated at the tracker's samples");
  t.push_back(of_numbers(parsed_option<R>(
      "markers", OptionKind::kText,
      "A log of several markers on one rigid body (x1, y1, z1, x2, ...): their positions in the "
      "tool frame, X1,Y1,Z1,X2,... [m] (default: estimated from the log)",
      [](R& r, const OptionValue& v, const std::string& as) {
        r.options.marker_body = parse_marker_body(std::get<std::string>(v), as);
      })));
  t.push_back(parsed_option<R>("no_transmission", OptionKind::kFlag,
                               "Skip step 1: kinematic-only calibration",
                               [](R& r, const OptionValue& v, const std::string&) {
                                 r.options.transmissions = !std::get<bool>(v);
                               }));
  t.push_back(field_option<R>(
      "samples", "Use N random poses of the log (0: all; repeated rows count as one pose)",
      [](R & r) -> auto& { return r.options.samples; }, option_range::kSamples));
  t.push_back(field_option<R>(
      "seed", "Seed of the row sample", [](R & r) -> auto& { return r.options.seed; },
      kAtLeastZero));
  t.push_back(field_option<R>(
      "sigma",
      "Measurement noise sd [m] for the standard deviations (default: estimated from the "
      "residuals)",
      [](R & r) -> auto& { return r.options.sigma; }, option_range::kSigma));
  t.push_back(field_option<R>(
      "polynomial_order",
      "Order of polynomial transmissions, exactly (refused where the samples do not support "
      "it, 3 a coefficient); default: the order of least generalised cross-validation error up "
      "to the device file's (else 10)",
      [](R & r) -> auto& { return r.options.polynomial_order; }, option_range::kPolynomialOrder));
  t.push_back(field_option<R>(
      "encoder_resolution",
      "The external encoders' count [rad]: a step-1 fit that predicts left-out samples worse "
      "than 2 counts is flagged (suspect)",
      [](R & r) -> auto& { return r.options.encoder_resolution; }, option_range::kAngle));
  add_model_options(t);
  t.push_back(field_option<R>(
      "threads", "Threads of the model search (0: one a core; its choices do not depend on it)",
      [](R & r) -> auto& { return r.options.threads; }, OptionRange{0, option_range::kThreads.hi}));
  t.push_back(field_option<R>(
      "folds", "K of the K-fold cross-validated (held-out) RMS by pose (0: none)",
      [](R & r) -> auto& { return r.options.folds; }, option_range::kFolds));
  auto loss = parsed_option<R>(
      "loss", OptionKind::kText,
      "Loss for poses the outlier test flags (residual beyond the Bonferroni quantile in "
      "robust sds): cauchy, huber, or none (plain least squares; outliers still named)",
      [](R& r, const OptionValue& v, const std::string&) {
        r.options.loss = robust_loss(std::get<std::string>(v));
      },
      std::string(to_string(R{}.options.loss)));
  loss.words = {"cauchy", "huber", "none"};
  t.push_back(loss);
  t.push_back(field_option<R>(
      "strict",
      "A suspect fit (training RMS beyond 100 x the repeatability, or held-out RMS above the "
      "nominal model's with its base fitted) is unusable: exit 3, the previous calibrated.yaml "
      "kept",
      [](R & r) -> auto& { return r.options.strict; }));
  t.push_back(field_option<R>(
      "columns", "Column names of a log without header", [](R & r) -> auto& { return r.columns; }));
  t.push_back(field_option<R>(
      "dependency_tolerance",
      "A parameter whose scaled Jacobian column lies within this relative distance of the "
      "span of those before it is held",
      [](R & r) -> auto& { return r.options.dependency_tolerance; },
      option_range::kDependencyTolerance));
  t.push_back(field_option<R>(
      "force",
      "Calibrate even if the log looks implausible for the model (readings outside the joint "
      "limits, nominal error beyond 5 % of the reach with the base fitted)",
      [](R & r) -> auto& { return r.options.force; }));
  t.push_back(of_numbers(parsed_option<R>(
      "tool_point", OptionKind::kText,
      "Where device.yaml's tool ends: X,Y,Z in metres in the last link's frame (a stylus tip), "
      "or 'nominal' for the device file's tool (default: the point the instrument measured)",
      read_tool_point)));
  t.push_back(field_option<R>(
      "out",
      "Output folder, replaced as a whole when the run succeeds (Python: none, nothing "
      "written; the command line: default hapticcal-out/calibrate)",
      [](R & r) -> auto& { return r.out; }));
  return t;
}

CommandOptions<EvaluateRequest> evaluate_table() {
  using R = EvaluateRequest;
  CommandOptions<R> t;
  t.push_back(required(field_option<R>(
      "model", "Device file (YAML) or URDF (.urdf)", [](R & r) -> auto& { return r.model; })));
  add_chain_options(t);
  t.push_back(required(field_option<R>(
      "log", "Measurement log (CSV)", [](R & r) -> auto& { return r.log; })));
  t.push_back(field_option<R>(
      "iso9283",
      "An ISO 9283 test: the plan.csv of plan --iso9283, which the log follows row by row; "
      "adds the pose and distance accuracy and repeatability (AP, RP, AD, RD) of the model (and "
      "--reference)",
      [](R & r) -> auto& { return r.iso9283; }));
  t.push_back(field_option<R>(
      "conditions",
      "The ISO 9283 test's conditions for its report, e.g. \"load 1 kg, speed 100 %, 21 C\"",
      [](R & r) -> auto& { return r.conditions; }));
  t.push_back(of_numbers(parsed_option<R>(
      "markers", OptionKind::kText,
      "A log of several markers on one rigid body: their positions in the tool frame, "
      "X1,Y1,Z1,X2,... [m] (calibrate's results.json markers; default: estimated from the log)",
      [](R& r, const OptionValue& v, const std::string& as) {
        r.marker_body = parse_marker_body(std::get<std::string>(v), as);
      })));
  t.push_back(field_option<R>(
      "out",
      "Output directory: report.html, results.json (Python: none, nothing written; the "
      "command line without --json: default hapticcal-out/evaluate)",
      [](R & r) -> auto& { return r.out; }));
  t.push_back(field_option<R>(
      "point_distance", "A known distance between two fixture points: A:B=METRES (repeatable)",
      [](R & r) -> auto& { return r.point_distances; }));
  t.push_back(field_option<R>(
      "fixture",
      "Fixture file (YAML): known positions (points) and distances of the log's fixture points",
      [](R & r) -> auto& { return r.fixture; }));
  t.push_back(field_option<R>(
      "reference",
      "A second device file (e.g. the nominal one): adds the paper's eq. 9 improvement of "
      "--model over it on the same log",
      [](R & r) -> auto& { return r.reference; }));
  t.push_back(field_option<R>(
      "columns",
      "Column names of a log without header, comma separated, _ skips one (e.g. "
      "q1[deg],q2[deg],x,y,z,_)",
      [](R & r) -> auto& { return r.columns; }));
  t.push_back(parsed_option<R>(
      "register", OptionKind::kText,
      "frame or frame,tool: fit the measurement frame (the base pose), and the tool point, on "
      "this log before scoring (a tracker moved since); each model on its own with --reference",
      [](R& r, const OptionValue& v, const std::string&) {
        r.registration = parse_register(std::get<std::string>(v));
      }));
  add_tracker_options(
      t,
      "A second session's tracker stream (t, x, y, z [, qw..qz | x1..]) on its own clock; --log "
      "is then the device's stream (t, q1..qn): the clocks are aligned with the model held, "
      "then the model is scored on the tracker's samples");
  return t;
}

CommandOptions<SimulateRequest> simulate_table() {
  using R = SimulateRequest;
  CommandOptions<R> t;
  auto scenario = field_option<R>(
      "scenario", "Scenario file (YAML; default: the paper's study on --device)",
      [](R & r) -> auto& { return r.scenario; });
  scenario.positional = true;
  t.push_back(scenario);
  t.push_back(field_option<R>(
      "trials", "Monte Carlo trials (default: the scenario's, else 1)",
      [](R & r) -> auto& { return r.trials; }, option_range::kTrials));
  t.push_back(field_option<R>(
      "seed", "Random seed (default: the scenario's, else 1)",
      [](R & r) -> auto& { return r.seed; }, kAtLeastZero));
  t.push_back(field_option<R>(
      "threads", "Threads (0: one a core)", [](R & r) -> auto& { return r.threads; },
      OptionRange{0, option_range::kThreads.hi}));
  t.push_back(field_option<R>(
      "device", "Nominal device file or URDF (default: the built-in 7-DOF)",
      [](R & r) -> auto& { return r.device; }));
  t.push_back(field_option<R>(
      "out", "Output directory", [](R & r) -> auto& { return r.out; }));
  add_chain_options(t);
  return t;
}

// --posture: readings q, comma separated.
void read_posture(ForceRequest& r, const OptionValue& v, const std::string& as) {
  std::vector<double> q;
  for (const std::string& item : split_columns(std::get<std::string>(v))) {
    size_t used = 0;
    double x = 0;
    try {
      x = std::stod(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    // nan and inf are read: the study names the reading (control.cpp).
    if (used != item.size())
      throw InputError(fmt::format("{}: '{}' is not a number", as, printable(item)));
    q.push_back(x);
  }
  r.posture = q;
}

CommandOptions<ForceRequest> force_table() {
  using R = ForceRequest;
  CommandOptions<R> t;
  t.push_back(required(field_option<R>(
      "actual", "Device file of the true device", [](R & r) -> auto& { return r.actual; })));
  t.push_back(required(field_option<R>(
      "nominal", "Controller model before calibration", [](R & r) -> auto& { return r.nominal; })));
  t.push_back(required(field_option<R>(
      "calibrated", "Controller model after calibration (the actual file: the truth as the model)",
      [](R & r) -> auto& { return r.calibrated; })));
  t.push_back(field_option<R>(
      "out", "Output directory", [](R & r) -> auto& { return r.out; }));
  t.push_back(field_option<R>(
      "gain", "Force-loop gain G", [](R & r) -> auto& { return r.scenario.gain; },
      option_range::kForceGain));
  t.push_back(field_option<R>(
      "noise", "Force sensor noise sd [N]", [](R & r) -> auto& { return r.scenario.sensor_noise; },
      option_range::kForceNoise));
  t.push_back(field_option<R>(
      "stiffness", "Wall stiffness [N/m]", [](R & r) -> auto& { return r.scenario.stiffness; },
      option_range::kWallStiffness));
  t.push_back(field_option<R>(
      "travel", "Wall travel along the handle's z [m]",
      [](R & r) -> auto& { return r.scenario.travel; }, option_range::kWallTravel));
  t.push_back(field_option<R>(
      "seconds", "Time the wall takes [s] (at most 600 s at the 1 kHz loop rate)",
      [](R & r) -> auto& { return r.scenario.move_seconds; }, option_range::kWallSeconds));
  t.push_back(of_numbers(parsed_option<R>(
      "posture", OptionKind::kText,
      "Readings q of the fixed handle, comma separated (default: home, j6 = 0.3 rad on a "
      "7-joint device)",
      read_posture)));
  t.push_back(field_option<R>(
      "seed", "Seed of the sensor noise", [](R & r) -> auto& { return r.scenario.seed; },
      kAtLeastZero));
  t.push_back(field_option<R>(
      "lock",
      "Joint to lock, 1-based; 0: none (default: joint 3 on a 7-joint device, none on a "
      "6-joint one; 6 joints must remain)",
      [](R & r) -> auto& { return r.lock; }, option_range::kLockedJoint));
  add_chain_options(t);
  return t;
}

CommandOptions<CompensateRequest> compensate_table() {
  using R = CompensateRequest;
  CommandOptions<R> t;
  t.push_back(required(field_option<R>(
      "model", "The calibrated model in the robot's frame (device.yaml; or a URDF)",
      [](R & r) -> auto& { return r.model; })));
  t.push_back(required(field_option<R>(
      "nominal",
      "The model the controller runs (its maker's nominal; a file or a built-in device's name)",
      [](R & r) -> auto& { return r.nominal; })));
  t.push_back(required(field_option<R>(
      "targets",
      "The program (CSV): q1..qn, its readings (joint targets), and for Cartesian targets x, y, "
      "z with qw, qx, qy, qz or rx, ry, rz (the readings then its configuration)",
      [](R & r) -> auto& { return r.targets; })));
  t.push_back(field_option<R>(
      "columns", "Column names of a targets file without header, comma separated",
      [](R & r) -> auto& { return r.columns; }));
  t.push_back(field_option<R>(
      "load", "A payload at the tool point [kg], for the model's joint compliance",
      [](R & r) -> auto& { return r.options.load; }, OptionRange{0, 1000, "kg"}));
  add_chain_options(t);
  t.push_back(field_option<R>(
      "out", "Output directory: compensated.csv, results.json",
      [](R & r) -> auto& { return r.out; }));
  return t;
}

CommandOptions<ConvertRequest> convert_table() {
  using R = ConvertRequest;
  CommandOptions<R> t;
  auto in = required(field_option<R>(
      "input", "Model to read", [](R & r) -> auto& { return r.in; }));
  in.argument = true;
  t.push_back(in);
  auto out = required(field_option<R>(
      "output", "File to write (replaced atomically)", [](R & r) -> auto& { return r.out; }));
  out.argument = true;
  t.push_back(out);
  add_chain_options(t);
  return t;
}

}  // namespace

const CommandOptions<ConvertRequest>& convert_options() {
  static const CommandOptions<ConvertRequest> table = convert_table();
  return table;
}

const CommandOptions<CompensateRequest>& compensate_options() {
  static const CommandOptions<CompensateRequest> table = compensate_table();
  return table;
}

const CommandOptions<ForceRequest>& force_options() {
  static const CommandOptions<ForceRequest> table = force_table();
  return table;
}

const CommandOptions<SimulateRequest>& simulate_options() {
  static const CommandOptions<SimulateRequest> table = simulate_table();
  return table;
}

const CommandOptions<CalibrateRequest>& calibrate_options() {
  static const CommandOptions<CalibrateRequest> table = calibrate_table();
  return table;
}

const CommandOptions<EvaluateRequest>& evaluate_options() {
  static const CommandOptions<EvaluateRequest> table = evaluate_table();
  return table;
}

}  // namespace hapticcal
