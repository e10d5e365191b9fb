#include "plan_command.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "command_support.hpp"
#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/core/output_set.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/design/plan.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/jobs/calibrate_job.hpp"
#include "hapticcal/jobs/iso_plan_job.hpp"
#include "hapticcal/jobs/plan_job.hpp"
#include "hapticcal/model_io/model_source.hpp"
#include "hapticcal/report/iso9283_report.hpp"
#include "hapticcal/report/report.hpp"
#include "hapticcal/study/iso9283_cube.hpp"
#include "hapticcal/study/paper.hpp"
#include "number_options.hpp"
#include "output_summary.hpp"
#include "terminal.hpp"

namespace hapticcal::cli {

CLI::App* add_plan_command(CLI::App& app, PlanCommandOptions& options) {
  auto* plan = app.add_subcommand(
      "plan", "Choose N poses that make the calibration predict best (experiment design)");
  options.bound.bind(plan, plan_options());
  plan->footer(
      "Examples:\n"
      "  hapticcal plan --model examples/meca500/meca500.yaml --measurement position --poses 30\n"
      "  hapticcal plan --model geomagic-touch --measurement pose --poses 40 --out touch-plan");
  return plan;
}

namespace {

// plan --iso9283: the test cube and its poses (jobs/iso_plan_job.hpp).
int run_iso_plan(const PlanCommandRequest& command) {
  const IsoPlanRequest& request = command.iso;
  const std::string& out = command.out;
  const IsoPlanJob job = run_iso_plan_job(request, out);
  for (const std::string& line : job.lines) fmt::print("{}\n", line);
  fmt::print("report: {}/report.html ({} figure{})\n", out, job.figures,
             job.figures == 1 ? "" : "s");
  if (!job.report_note.empty()) fmt::print("note: {}\n", job.report_note);
  fmt::print("{}", output_summary(*job.out, out,
                                  fmt::format(" (plan.csv: q1..q{} in radians and the pose's "
                                              "label, a row a pose visited)",
                                              job.model.dof())));
  return 0;
}

}  // namespace

int run_plan(const PlanCommandOptions& options) {
  PlanCommandRequest command;
  options.bound.apply(command);
  check_plan_command(command);
  if (command.iso9283) return run_iso_plan(command);
  const PlanRequest& o = command.plan;
  const std::string& out = command.out;
  const bool tty = isatty(2);
  const auto started = [&](const PlanSetup& setup, const PlanProblem& problem) {
    const DeviceModel& model = setup.model;
    fmt::print(
        "hapticcal plan: {} poses of {} ({} joints), {} measurements, {}-optimal, seed {}\n"
        "  parameters: {} ({} kinematic, the rest step-1 transmissions and encoder zeros); "
        "sigma_m {:.4g} um, sigma_e {:.4g} urad\n",
        setup.options.poses, model.name, model.dof(), traits(setup.type).name,
        to_string(setup.options.criterion), o.seed, problem.parameters(),
        problem.kinematic_slots().size(), setup.sigma * 1e6, setup.sigma_e * 1e6);
  };
  const PlanJob job = run_plan_job(o, out, started, [tty](const std::string& s) {
    if (tty) hapticcal::cli::say(stderr, "  {}\n", s);
  });
  const Plan& plan = job.plan;
  const bool user = job.setup.user_candidates;
  fmt::print(
      "  candidates: {} {}; exchange: {} sweeps, {} swaps; refinement: {} moves ({:.1f} s)\n",
      plan.pool, user ? "recorded poses (" + o.candidates + ")" : "random poses", plan.sweeps,
      plan.swaps, plan.refined_moves, plan.seconds);
  const char* tip = hapticcal::traits(job.setup.type).tip;
  fmt::print(
      "  predicted RMS {} sd over the workspace: planned {:.3f} um, random {} poses {:.3f} um "
      "(median of {} draws): ratio {:.3f}\n",
      tip, plan.planned.rms_sd * 1e6, job.setup.options.poses, plan.random_median_rms_sd * 1e6,
      plan.random_rms_sd.size(),
      plan.random_median_rms_sd > 0 ? plan.planned.rms_sd / plan.random_median_rms_sd : 0.0);
  fmt::print("  observability O1 {:.4g} (random {:.4g}), condition number {:.4g} (random {:.4g})\n",
             plan.planned.conditioning.observability.O1, plan.random.conditioning.observability.O1,
             plan.planned.conditioning.condition_number, plan.random.conditioning.condition_number);
  fmt::print("  path: {:.2f} rad of largest joint travel (unordered {:.2f} rad)\n",
             plan.path_length, plan.path_length_unordered);
  if (user) {
    std::string rows;
    for (int c : plan.candidate) rows += fmt::format("{}{}", rows.empty() ? "" : " ", c + 1);
    fmt::print("  chosen poses (distinct poses of the log, 1-based, in path order): {}\n", rows);
  }
  fmt::print("report: {}/report.html ({} figure{})\n", out, job.figures,
             job.figures == 1 ? "" : "s");
  if (!job.report_note.empty()) fmt::print("note: {}\n", job.report_note);
  fmt::print("{}", output_summary(*job.out, out,
                                  fmt::format(" (plan.csv: q1..q{} in radians, path order)",
                                              job.setup.model.dof())));
  return 0;
}

}  // namespace hapticcal::cli
