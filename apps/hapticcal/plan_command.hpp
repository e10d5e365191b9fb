// `hapticcal plan`: experiment design (issue 12) on the command line. Parsing
// and printing only; the work is hapticcal::prepare_plan and plan_poses (design/).
#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "bound_options.hpp"
#include "hapticcal/jobs/plan_job.hpp"

namespace hapticcal::cli {

// plan's options are the library's table (plan_options), as Python's keywords are.
struct PlanCommandOptions {
  BoundOptions<PlanCommandRequest> bound;
};

// Registers `plan` on the app; returns the subcommand (true when given).
CLI::App* add_plan_command(CLI::App& app, PlanCommandOptions& options);
// Runs it: 0 on success; bad input throws hapticcal::InputError (exit 2).
int run_plan(const PlanCommandOptions& options);

}  // namespace hapticcal::cli
