// `hapticcal calibrate`: the two-step identification (paper Fig. 6) of a log,
// its summary on the terminal and its output set.
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "commands.hpp"
#include "hapticcal/core/error.hpp"
#include "hapticcal/core/output_set.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/identification/markers.hpp"
#include "hapticcal/jobs/calibrate_job.hpp"
#include "number_options.hpp"
#include "output_summary.hpp"
#include "terminal.hpp"

namespace hapticcal::cli {

namespace {

// What step 2 fits and how: parameters held or freed, the joint-error
// families, the estimator, the prior's tolerances, the model search.
void add_model_options(CLI::App* c, CalibrateOptions& o) {
  c->add_option("--fix", o.fix, "Kinematic parameters held at nominal, e.g. j1.a,j2.d");
  c->add_option(
      "--joint-errors", o.joint_errors,
      "Joint-error families fitted with the geometry, instead of those the search finds: "
      "harmonic (first and second harmonic of each joint's angle, and of its motor's through a "
      "capstan), compliance (each joint's deflection k tau under the gravity torque of the "
      "model's masses), coupling (the coupling's coefficients between joints), backlash (an "
      "offset per approach direction, from the log's dir<i> columns), or none; the geometry "
      "alone is fitted beside them for comparison");
  c->add_option("--free", o.free,
                "Parameters added to the candidates, e.g. j2.beta (a beta is one by "
                "default only where neighbouring joint axes are parallel)");
  c->add_option("--point-distance", o.point_distance,
                "A known distance between two fixture points of the log (column point): "
                "A:B=METRES (repeatable)");
  c->add_option("--fixture", o.fixture,
                "Fixture file (YAML): known positions (points) and distances of the "
                "log's fixture points");
  c->add_flag("--keep-all", o.keep_all,
              "Plain least squares: fit every identifiable parameter the data excite, "
              "without the tolerance prior (the search compares least squares only)");
  c->add_flag("--select", o.select,
              "The significance cut: hold parameters whose change is below the 5 % "
              "family-wise threshold (plain least squares on the rest)");
  c->add_flag("--prior", o.prior,
              "The tolerance prior: each parameter pulled toward nominal by its "
              "tolerance, at the scale of highest evidence");
  c->add_flag("--no-search", o.no_search,
              "Fit exactly the model the other options name instead of searching: the "
              "joint-error families of --joint-errors (none if not given), the "
              "instrument's zero fitted (--fix instrument.zero: held), the estimator of "
              "--keep-all, --select or --prior (default the tolerance prior)");
  c->add_option("--tolerance", o.tolerances,
                "A tolerance of the prior, NAME=SD in SI units: length (default 0.0005 "
                "m), angle (0.005 rad) or a parameter, e.g. j2.a=0.001 (repeatable)");
  c->add_option("--prior-scale", o.prior_scale,
                "The common scale of the tolerances (default: the one of highest evidence)")
      ->check(within(option_range::kPriorScale));
}

}  // namespace

CLI::App* add_calibrate_command(CLI::App& app, CalibrateOptions& o) {
  auto* calibrate = app.add_subcommand("calibrate", "Two-step identification from a log");
  calibrate
      ->add_option("--model", o.model,
                   "The nominal model: a device file (YAML) or a URDF (.urdf, with --tip; then "
                   "calibrated.urdf is written too)")
      ->required();
  add_chain_options(calibrate, o.chain);
  calibrate
      ->add_option("--log", o.log,
                   "Measurement log (CSV); with --tracker the device's stream (t, q<i>)")
      ->required();
  auto* tracker = calibrate->add_option(
      "--tracker", o.tracker,
      "A tracker's stream (CSV: t and x, y, z [, qw..qz | x1, y1, z1, ...: a marker body], on "
      "its own clock): the clocks' offset is estimated with the kinematics, the readings "
      "interpolated at the tracker's samples");
  add_clock_options(calibrate, tracker, o.clock_search, o.clock_drift);
  calibrate->add_option("--markers", o.markers,
                        "A log of several markers on one rigid body (x1, y1, z1, x2, ...): their "
                        "positions in the tool frame, X1,Y1,Z1,X2,... [m] (default: estimated "
                        "from the log)");
  calibrate->add_flag("--no-transmission", o.no_transmission,
                      "Skip step 1: kinematic-only calibration");
  calibrate
      ->add_option("--samples", o.samples,
                   "Use N random poses of the log (0: all; repeated rows count as one pose)")
      ->check(whole_number(option_range::kSamples))
      ->capture_default_str();
  calibrate->add_option("--seed", o.seed, "Seed of the row sample")
      ->check(whole_number(0))
      ->capture_default_str();
  calibrate
      ->add_option("--sigma", o.sigma,
                   "Measurement noise sd [m] for the standard deviations (default: "
                   "estimated from the residuals)")
      ->check(within(option_range::kSigma));
  calibrate
      ->add_option("--polynomial-order", o.polynomial_order,
                   "Order of polynomial transmissions, exactly (refused where the samples do "
                   "not support it, 3 a coefficient); default: the order of least generalised "
                   "cross-validation error up to the device file's (else 10)")
      ->check(whole_number(option_range::kPolynomialOrder));
  calibrate
      ->add_option("--encoder-resolution", o.encoder_resolution,
                   "The external encoders' count [rad]: a step-1 fit that predicts left-out "
                   "samples worse than 2 counts is flagged (suspect)")
      ->check(within(option_range::kAngle));
  add_model_options(calibrate, o);
  calibrate
      ->add_option("--threads", o.threads,
                   "Threads of the model search (0: one a core; its choices do not depend on "
                   "it)")
      ->check(whole_number(option_range::kThreads))
      ->capture_default_str();
  calibrate
      ->add_option("--folds", o.folds,
                   "K of the K-fold cross-validated (held-out) RMS by pose (0: none)")
      ->check(whole_number(option_range::kFolds))
      ->capture_default_str();
  calibrate
      ->add_option("--loss", o.loss,
                   "Loss for poses the outlier test flags (residual beyond the Bonferroni "
                   "quantile in robust sds): cauchy, huber, or none (plain least squares; "
                   "outliers still named)")
      ->check(CLI::IsMember({"cauchy", "huber", "none"}))
      ->capture_default_str();
  calibrate->add_flag("--strict", o.strict,
                      "A suspect fit (training RMS beyond 100 x the repeatability, or held-out "
                      "RMS above the nominal model's with its base fitted) is unusable: exit 3, "
                      "the previous calibrated.yaml kept");
  calibrate->add_option("--columns", o.columns, "Column names of a log without header");
  calibrate
      ->add_option("--dependency-tolerance", o.tolerance,
                   "A parameter whose scaled Jacobian column lies within this relative "
                   "distance of the span of those before it is held")
      ->check(within(option_range::kDependencyTolerance))
      ->capture_default_str();
  calibrate->add_flag(
      "--force", o.force,
      "Calibrate even if the log looks implausible for the model (readings "
      "outside the joint limits, nominal error beyond 5 % of the reach with the base "
      "fitted)");
  calibrate->add_option(
      "--tool-point", o.tool_point,
      "Where device.yaml's tool ends: X,Y,Z in metres in the last link's frame (a stylus tip), "
      "or 'nominal' for the device file's tool (default: the point the instrument measured)");
  calibrate->add_option("--out", o.out,
                        "Output folder, replaced as a whole when the run succeeds (default "
                        "hapticcal-out/calibrate)");
  calibrate->footer(
      "Examples:\n"
      "  hapticcal calibrate --model examples/meca500/meca500.yaml --log "
      "examples/meca500/cal-norm_dist_data_0deg_160cube.csv --out meca500-cal\n"
      "  hapticcal calibrate --model geomagic-touch --log session/device.csv --tracker "
      "session/tracker.csv --clock-drift");
  return calibrate;
}

namespace {

// A stage's bar on standard error (a terminal only): "[####    ] clock search".
void progress_bar(const std::string& stage, double share) {
  constexpr int kWidth = 30;
  const int filled = static_cast<int>(kWidth * std::clamp(share, 0.0, 1.0));
  say(stderr, "\r[{}{}] {:<24}", std::string(static_cast<size_t>(filled), '#'),
      std::string(static_cast<size_t>(kWidth - filled), ' '), stage);
  if (share >= 1) say(stderr, "\n");
}

// --tool-point: "nominal", or X,Y,Z in metres (each within 10 m).
void read_tool_point(const std::string& text, hapticcal::CalibrateRequest& request) {
  if (text.empty()) return;
  if (text == "nominal") {
    request.nominal_tool = true;
    return;
  }
  request.tool_point = numbers<3>(text, "--tool-point");
  for (double x : *request.tool_point) {
    if (std::abs(x) > 10)
      throw hapticcal::InputError(
          fmt::format("--tool-point: {} is not a coordinate in metres (|x| <= 10)", x));
  }
}

}  // namespace

int run_calibrate(const CalibrateOptions& o) {
  hapticcal::CalibrateRequest request;
  read_tool_point(o.tool_point, request);
  request.model = o.model;
  request.tip = o.chain.tip;
  request.root = o.chain.root;
  request.log = o.log;
  request.columns = names(o.columns);
  request.fixture = o.fixture;
  request.point_distances = o.point_distance;
  request.out = o.out;
  hapticcal::CalibrationOptions& options = request.options;
  options.force = o.force;
  options.transmissions = !o.no_transmission;
  options.samples = o.samples;
  options.seed = o.seed;
  if (o.sigma > 0) options.sigma = o.sigma;
  if (o.polynomial_order > 0) options.polynomial_order = o.polynomial_order;
  if (o.encoder_resolution > 0) options.encoder_resolution = o.encoder_resolution;
  options.dependency_tolerance = o.tolerance;
  options.keep_all = o.keep_all;
  options.select = o.select;
  options.prior = o.prior;
  options.search = !o.no_search;
  for (const std::string& item : o.tolerances) hapticcal::add_tolerance(options.tolerances, item);
  if (o.prior_scale > 0) options.tolerances.scale = o.prior_scale;
  options.folds = o.folds;
  options.threads = o.threads;
  options.loss = hapticcal::robust_loss(o.loss);
  options.strict = o.strict;
  options.fix = names(o.fix);
  options.joint_errors = names(o.joint_errors);
  options.free = names(o.free);
  if (!o.markers.empty())
    options.marker_body = hapticcal::parse_marker_body(o.markers, "--markers");
  request.tracker = o.tracker;
  request.stream.search_range = o.clock_search;
  request.stream.drift = o.clock_drift;
  if (!o.tracker.empty() && isatty(2)) request.stream.progress = progress_bar;
  const hapticcal::CalibrateJob job = hapticcal::run_calibrate_job(request);
  for (const std::string& line : job.lines) fmt::print("{}\n", line);
  fmt::print("{}", report_said(job.written.figures, job.written.report_note, o.out));
  fmt::print("{}", output_summary(*job.out, o.out, fmt::format(" (seed {})", o.seed)));
  const char* model_file = "calibrated.yaml";
  if (!job.written.model_written) {
    fmt::print("status: {}: {}; {}\n", to_string(job.result.status), job.result.status_reason,
               job.written.previous_kept ? fmt::format("the previous {} is kept", model_file)
                                         : fmt::format("no {} written", model_file));
    return kExitUnusable;
  }
  fmt::print("status: {}\n", to_string(job.result.status));
  return 0;
}

}  // namespace hapticcal::cli
