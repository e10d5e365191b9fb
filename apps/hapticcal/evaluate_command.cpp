// `hapticcal evaluate`: a model's errors on a log, optionally against a
// reference model and after fitting the measurement frame (--register).
#include <fmt/format.h>

#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "commands.hpp"
#include "hapticcal/core/output_set.hpp"
#include "hapticcal/identification/markers.hpp"
#include "hapticcal/jobs/evaluate_job.hpp"
#include "number_options.hpp"
#include "output_summary.hpp"
#include "terminal.hpp"

namespace hapticcal::cli {

CLI::App* add_evaluate_command(CLI::App& app, EvaluateOptions& o) {
  auto* evaluate = app.add_subcommand("evaluate", "RMS and max error of a model on a log");
  evaluate->add_option("--model", o.model, "Device file (YAML) or URDF (.urdf)")->required();
  add_chain_options(evaluate, o.chain);
  evaluate->add_option("--log", o.log, "Measurement log (CSV)")->required();
  evaluate->add_option("--iso9283", o.iso9283,
                       "An ISO 9283 test: the plan.csv of plan --iso9283, which the log follows "
                       "row by row; adds the pose and distance accuracy and repeatability (AP, "
                       "RP, AD, RD) of the model (and --reference)");
  evaluate->add_option("--conditions", o.conditions,
                       "The ISO 9283 test's conditions for its report, e.g. \"load 1 kg, speed "
                       "100 %, 21 C\"");
  evaluate->add_option("--markers", o.markers,
                       "A log of several markers on one rigid body: their positions in the tool "
                       "frame, X1,Y1,Z1,X2,... [m] (calibrate's results.json markers; default: "
                       "estimated from the log)");
  evaluate->add_flag("--json", o.json,
                     "Print one JSON object (metres); writes no files unless --out is given");
  evaluate->add_option("--out", o.out,
                       "Output directory: report.html, results.json (default "
                       "hapticcal-out/evaluate)");
  evaluate->add_option("--point-distance", o.point_distance,
                       "A known distance between two fixture points: A:B=METRES (repeatable)");
  evaluate->add_option("--fixture", o.fixture,
                       "Fixture file (YAML): known positions (points) and distances of the log's "
                       "fixture points");
  evaluate->add_option("--reference", o.reference,
                       "A second device file (e.g. the nominal one): adds the paper's eq. 9 "
                       "improvement of --model over it on the same log");
  evaluate->add_option("--columns", o.columns,
                       "Column names of a log without header, comma separated, _ skips one "
                       "(e.g. q1[deg],q2[deg],x,y,z,_)");
  evaluate->add_option("--register", o.register_what,
                       "frame or frame,tool: fit the measurement frame (the base pose), and the "
                       "tool point, on this log before scoring (a tracker moved since); each "
                       "model on its own with --reference");
  auto* tracker = evaluate->add_option(
      "--tracker", o.tracker,
      "A second session's tracker stream (t, x, y, z [, qw..qz | x1..]) on its own "
      "clock; --log is then the device's stream (t, q1..qn): the clocks are aligned "
      "with the model held, then the model is scored on the tracker's samples");
  add_clock_options(evaluate, tracker, o.clock_search, o.clock_drift);
  evaluate->footer(
      "Examples:\n"
      "  hapticcal evaluate --model calibrated.yaml --log validation.csv --reference "
      "geomagic-touch\n"
      "  hapticcal evaluate --model calibrated.yaml --log session2/device.csv --tracker "
      "session2/tracker.csv --clock-drift");
  return evaluate;
}

int run_evaluate(const EvaluateOptions& o) {
  hapticcal::EvaluateRequest request;
  request.model = o.model;
  request.reference = o.reference;
  request.tip = o.chain.tip;
  request.root = o.chain.root;
  request.log = o.log;
  if (!o.markers.empty())
    request.marker_body = hapticcal::parse_marker_body(o.markers, "--markers");
  request.columns = names(o.columns);
  request.fixture = o.fixture;
  request.point_distances = o.point_distance;
  if (o.register_given) request.registration = hapticcal::parse_register(o.register_what);
  request.tracker = o.tracker;
  request.iso9283 = o.iso9283;
  request.conditions = o.conditions;
  request.stream.search_range = o.clock_search;
  request.stream.drift = o.clock_drift;
  // --json writes no files unless --out is given.
  if (!o.json || o.out_given) request.out = o.out;
  const hapticcal::EvaluateJob job = hapticcal::run_evaluate_job(request);
  if (o.json) {
    fmt::print("{}\n", job.json);
  } else {
    if (job.tips.empty()) {
      fmt::print("model: {} ({}, {} joints)\n", o.model, job.model.name, job.model.dof());
    } else {
      fmt::print("model: {} ({}, a tree of {} tips: {})\n", o.model, job.model.name,
                 job.tips.size(), fmt::join(job.tips, ", "));
    }
    if (o.tracker.empty()) {
      fmt::print("log:   {} ({} rows)\n", o.log, job.evaluation.n);
    } else {
      fmt::print("log:   {} and {} ({} tracker samples at the clocks found)\n", o.log, o.tracker,
                 job.evaluation.n);
    }
    for (const std::string& line : job.lines) fmt::print("{}\n", line);
  }
  if (!job.out) return 0;
  // With --json, stdout is the JSON object alone.
  std::FILE* said = o.json ? stderr : stdout;
  hapticcal::cli::say(said, "{}", report_said(job.figures, job.report_note, o.out));
  hapticcal::cli::say(said, "{}", hapticcal::cli::output_summary(*job.out, o.out));
  return 0;
}

}  // namespace hapticcal::cli
