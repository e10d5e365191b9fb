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

CLI::App* add_calibrate_command(CLI::App& app, CalibrateOptions& o) {
  auto* calibrate = app.add_subcommand("calibrate", "Two-step identification from a log");
  o.bound.bind(calibrate, hapticcal::calibrate_options());
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

}  // namespace

int run_calibrate(const CalibrateOptions& o) {
  hapticcal::CalibrateRequest request;
  o.bound.apply(request);
  if (!request.out) request.out = "hapticcal-out/calibrate";
  if (!request.tracker.empty() && isatty(2)) request.stream.progress = progress_bar;
  const hapticcal::CalibrateJob job = hapticcal::run_calibrate_job(request);
  for (const std::string& line : job.lines) fmt::print("{}\n", line);
  const std::string& out = *request.out;
  fmt::print("{}", report_said(job.written.figures, job.written.report_note, out));
  fmt::print("{}", output_summary(*job.out, out, fmt::format(" (seed {})", request.options.seed)));
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
