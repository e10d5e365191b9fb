// `hapticcal plan`: experiment design (issue 12) on the command line. Parsing
// and printing only; the work is hapticcal::plan_poses (design/plan.hpp).
#pragma once

#include <CLI/CLI.hpp>
#include <string>

namespace hapticcal::cli {

struct PlanCommandOptions {
  std::string model, measurement, candidates, columns, criterion = "i", out = "hapticcal-out/plan";
  std::string tip, root, distance_range, box, fix, free;
  int poses = 0, pool = 0;
  unsigned long long seed = 1;
  double sigma = 0, sigma_e = 0;
  int refine_passes = -1;
};

// Registers `plan` on the app; returns the subcommand (true when given).
CLI::App* add_plan_command(CLI::App& app, PlanCommandOptions& options);
// Runs it: 0 on success; bad input throws hapticcal::InputError (exit 2).
int run_plan(const PlanCommandOptions& options);

}  // namespace hapticcal::cli
