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
  PlanRequest& o = options.request;
  auto* plan = app.add_subcommand(
      "plan", "Choose N poses that make the calibration predict best (experiment design)");
  plan->add_option("--model", o.model, "Device file (YAML) or URDF (.urdf, with --tip)")
      ->required();
  plan->add_option("--measurement", o.measurement,
                   "distance, position or pose (required unless --iso9283)");
  plan->add_option("--poses", o.poses, "Number of poses to plan (required unless --iso9283)")
      ->check(whole_number(option_range::kPlanPoses));
  plan->add_flag("--iso9283", options.iso9283,
                 "An ISO 9283 test instead: the test cube, its five poses P1..P5 as joint "
                 "targets and the cycles (plan.csv, a row a pose visited; iso9283.json)");
  plan->add_option("--cube-centre", options.cube_centre,
                   "X,Y,Z: the test cube's centre in the measurement frame [m] (default: searched "
                   "over the workspace for the largest cube)");
  plan->add_option("--cube-size", options.cube_size,
                   "The test cube's edge [m] (default: the largest the workspace holds)")
      ->check(within(1e-3, 10.0, "m"));
  plan->add_option("--cycles", options.cycles, "ISO 9283 cycles (default 30, the standard's)")
      ->check(whole_number(1, 1000));
  auto* candidates =
      plan->add_option("--candidates", o.candidates,
                       "A log of recorded poses to choose from (repeated rows count as one pose)");
  auto* pool = plan->add_option("--pool", o.pool,
                                "Random candidate poses within the joint limits (default 10000)")
                   ->check(whole_number(option_range::kPool));
  candidates->excludes(pool);
  pool->excludes(candidates);
  plan->add_option("--columns", options.columns, "Column names of a candidates log without header");
  plan->add_option("--criterion", o.criterion,
                   "d (log det), a (trace of the scaled covariance), i (mean prediction "
                   "variance over the workspace, default), e (smallest eigenvalue)");
  plan->add_option("--seed", o.seed, "Random seed (default 1)")->check(whole_number(0));
  plan->add_option("--sigma", o.sigma,
                   "Measurement sd [m] (default: the paper's sigma_m for distances, 10 um for "
                   "positions and poses)")
      ->check(within(option_range::kSigma));
  plan->add_option("--sigma-e", o.sigma_e,
                   "External encoder sd [rad] (default: the paper's 2 pi / 20000 / 3)")
      ->check(within(option_range::kAngle));
  plan->add_option("--distance-range", options.distance_range,
                   "MIN,MAX: the tool point's distance from the measurement origin [m] (a cable "
                   "encoder's range)");
  plan->add_option("--box", options.box,
                   "XMIN,XMAX,YMIN,YMAX,ZMIN,ZMAX: a box the tool point must be in "
                   "(measurement frame) [m]");
  plan->add_option("--refine-passes", o.refine_passes,
                   "Continuous refinement passes of random candidates (default 20; 0: none)")
      ->check(whole_number(option_range::kRefinePasses));
  plan->add_option("--fix", options.fix, "Kinematic parameters held at nominal, e.g. j1.a,j2.d");
  plan->add_option("--free", options.free, "Parameters added to the candidates, e.g. j2.beta");
  plan->add_option("--tip", o.tip, "Tip link of a URDF model's chain");
  plan->add_option("--root", o.root, "Root link of a URDF model's chain");
  plan->add_option("--out", options.out, "Output folder (default hapticcal-out/plan)");
  plan->footer(
      "Examples:\n"
      "  hapticcal plan --model examples/meca500/meca500.yaml --measurement position --poses 30\n"
      "  hapticcal plan --model geomagic-touch --measurement pose --poses 40 --out touch-plan");
  return plan;
}

// plan --iso9283: the test cube and its poses (jobs/iso_plan_job.hpp).
int run_iso_plan(const PlanCommandOptions& options) {
  const PlanRequest& o = options.request;
  if (!o.measurement.empty() || o.poses != 0 || !o.candidates.empty())
    throw InputError(
        "--iso9283: the test's poses are the standard's: no --measurement, --poses "
        "or --candidates");
  IsoPlanRequest request;
  request.model = o.model;
  request.tip = o.tip;
  request.root = o.root;
  if (!options.cube_centre.empty())
    request.cube_centre = numbers<3>(options.cube_centre, "--cube-centre");
  request.cube_size = options.cube_size;
  request.cycles = options.cycles;
  const IsoPlanJob job = run_iso_plan_job(request, options.out);
  for (const std::string& line : job.lines) fmt::print("{}\n", line);
  fmt::print("report: {}/report.html ({} figure{})\n", options.out, job.figures,
             job.figures == 1 ? "" : "s");
  if (!job.report_note.empty()) fmt::print("note: {}\n", job.report_note);
  fmt::print("{}", output_summary(*job.out, options.out,
                                  fmt::format(" (plan.csv: q1..q{} in radians and the pose's "
                                              "label, a row a pose visited)",
                                              job.model.dof())));
  return 0;
}

int run_plan(const PlanCommandOptions& options) {
  if (options.iso9283) return run_iso_plan(options);
  if (!options.cube_centre.empty() || options.cube_size > 0 || options.cycles != 30)
    throw InputError(
        "--cube-centre, --cube-size and --cycles: apply to an ISO 9283 plan (--iso9283)");
  if (options.request.measurement.empty() || options.request.poses == 0)
    throw InputError("plan: --measurement and --poses are required (or --iso9283)");
  PlanRequest o = options.request;
  o.columns = names(options.columns);
  o.fix = names(options.fix);
  o.free = names(options.free);
  if (!options.distance_range.empty())
    o.distance_range = numbers<2>(options.distance_range, "--distance-range");
  if (!options.box.empty()) o.box = numbers<6>(options.box, "--box");
  const bool tty = isatty(2);
  const auto started = [&](const PlanSetup& setup, const PlanProblem& problem) {
    const DeviceModel& model = setup.model;
    fmt::print(
        "hapticcal plan: {} poses of {} ({} joints), {} measurements, {}-optimal, seed {}\n"
        "  parameters: {} ({} kinematic, the rest step-1 transmissions and encoder zeros); "
        "sigma_m {:.4g} um, sigma_e {:.4g} urad\n",
        o.poses, model.name, model.dof(), traits(setup.type).name,
        to_string(setup.options.criterion), o.seed, problem.parameters(),
        problem.kinematic_slots().size(), setup.sigma * 1e6, setup.sigma_e * 1e6);
  };
  const PlanJob job = run_plan_job(o, options.out, started, [tty](const std::string& s) {
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
      tip, plan.planned.rms_sd * 1e6, o.poses, plan.random_median_rms_sd * 1e6,
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
  fmt::print("report: {}/report.html ({} figure{})\n", options.out, job.figures,
             job.figures == 1 ? "" : "s");
  if (!job.report_note.empty()) fmt::print("note: {}\n", job.report_note);
  fmt::print("{}", output_summary(*job.out, options.out,
                                  fmt::format(" (plan.csv: q1..q{} in radians, path order)",
                                              job.setup.model.dof())));
  return 0;
}

}  // namespace hapticcal::cli
