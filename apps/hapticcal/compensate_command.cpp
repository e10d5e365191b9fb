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
  compensate
      ->add_option("--model", o.model,
                   "The calibrated model in the robot's frame (device.yaml; or a URDF)")
      ->required();
  compensate
      ->add_option("--nominal", o.nominal,
                   "The model the controller runs (its maker's nominal; a file or a built-in "
                   "device's name)")
      ->required();
  compensate
      ->add_option("--targets", o.targets,
                   "The program (CSV): q1..qn, its readings (joint targets), and for "
                   "Cartesian targets x, y, z with qw, qx, qy, qz or rx, ry, rz (the "
                   "readings then its configuration)")
      ->required();
  compensate->add_option("--columns", o.columns,
                         "Column names of a targets file without header, comma separated");
  compensate
      ->add_option("--load", o.load,
                   "A payload at the tool point [kg], for the model's joint compliance")
      ->check(CLI::Range(0.0, 1000.0));
  add_chain_options(compensate, o.chain);
  compensate->add_option("--out", o.out,
                         "Output directory: compensated.csv, results.json (default "
                         "hapticcal-out/compensate)");
  compensate->footer(
      "Examples:\n"
      "  hapticcal compensate --model cal/device.yaml --nominal examples/meca500/meca500.yaml "
      "--targets program.csv --out program-compensated");
  return compensate;
}

int run_compensate(const CompensateOptions& o) {
  CompensateRequest request;
  request.model = o.model;
  request.nominal = o.nominal;
  request.targets = o.targets;
  request.columns = o.columns;
  request.tip = o.chain.tip;
  request.root = o.chain.root;
  request.options.load = o.load;
  request.out = o.out;
  const CompensateJob job = run_compensate_job(request);
  for (const std::string& line : job.lines) fmt::print("{}\n", line);
  fmt::print("{}", output_summary(*job.out, o.out));
  return 0;
}

}  // namespace hapticcal::cli
