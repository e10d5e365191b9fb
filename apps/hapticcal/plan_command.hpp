// `hapticcal plan`: experiment design (issue 12) on the command line. Parsing
// and printing only; the work is hapticcal::prepare_plan and plan_poses (design/).
#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "hapticcal/jobs/plan_job.hpp"

namespace hapticcal::cli {

struct PlanCommandOptions {
  PlanRequest request;
  // The options given as text, parsed into the request by run_plan.
  std::string columns, fix, free, distance_range, box;
  // An ISO 9283 test plan instead (--iso9283): the cube's centre X,Y,Z [m] and
  // edge [m] (none: found), the cycles.
  bool iso9283 = false;
  std::string cube_centre;
  double cube_size = 0;
  int cycles = 30;
  std::string out = "hapticcal-out/plan";
};

// Registers `plan` on the app; returns the subcommand (true when given).
CLI::App* add_plan_command(CLI::App& app, PlanCommandOptions& options);
// Runs it: 0 on success; bad input throws hapticcal::InputError (exit 2).
int run_plan(const PlanCommandOptions& options);

}  // namespace hapticcal::cli
