// `hapticcal compensate`: a program's targets compensated for a controller
// that runs the nominal model (jobs/compensate_job.hpp).
#include <fmt/format.h>

#include <string>

#include "commands.hpp"
#include "hapticcal/jobs/compensate_job.hpp"
#include "output_summary.hpp"

namespace hapticcal::cli {

CLI::App* add_compensate_command(CLI::App& app, CompensateOptions& o) {
  auto* compensate = app.add_subcommand(
      "compensate",
      "Targets for a controller that runs the nominal model: the readings at which the calibrated "
      "model reaches each target of a program, and the pose to give the controller for them");
  o.bound.bind(compensate, compensate_options());
  compensate->footer(
      "Examples:\n"
      "  hapticcal compensate --model cal/device.yaml --nominal examples/meca500/meca500.yaml "
      "--targets program.csv --out program-compensated");
  return compensate;
}

int run_compensate(const CompensateOptions& o) {
  CompensateRequest request;
  o.bound.apply(request);
  const CompensateJob job = run_compensate_job(request);
  for (const std::string& line : job.lines) fmt::print("{}\n", line);
  fmt::print("{}", output_summary(*job.out, request.out));
  return 0;
}

}  // namespace hapticcal::cli
