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
  o.bound.bind(evaluate, hapticcal::evaluate_options());
  evaluate->add_flag("--json", o.json,
                     "Print one JSON object (metres); writes no files unless --out is given");
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
  o.bound.apply(request);
  // --json writes no files unless --out is given.
  if (!o.json && !request.out) request.out = "hapticcal-out/evaluate";
  const hapticcal::EvaluateJob job = hapticcal::run_evaluate_job(request);
  if (o.json) {
    fmt::print("{}\n", job.json);
  } else {
    if (job.tips.empty()) {
      fmt::print("model: {} ({}, {} joints)\n", request.model, job.model.name, job.model.dof());
    } else {
      fmt::print("model: {} ({}, a tree of {} tips: {})\n", request.model, job.model.name,
                 job.tips.size(), fmt::join(job.tips, ", "));
    }
    if (request.tracker.empty()) {
      fmt::print("log:   {} ({} rows)\n", request.log, job.evaluation.n);
    } else {
      fmt::print("log:   {} and {} ({} tracker samples at the clocks found)\n", request.log,
                 request.tracker, job.evaluation.n);
    }
    for (const std::string& line : job.lines) fmt::print("{}\n", line);
  }
  if (!job.out) return 0;
  // With --json, stdout is the JSON object alone.
  std::FILE* said = o.json ? stderr : stdout;
  hapticcal::cli::say(said, "{}", report_said(job.figures, job.report_note, *request.out));
  hapticcal::cli::say(said, "{}", hapticcal::cli::output_summary(*job.out, *request.out));
  return 0;
}

}  // namespace hapticcal::cli
