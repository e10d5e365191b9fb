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

namespace {

// How the cube was found (iso9283.json's "search").
nlohmann::ordered_json iso_search_json(const IsoCubeSearch& s) {
  return {{"centre", s.centre_given ? "given" : "searched over the workspace"},
          {"size", s.size_given ? "given" : "the largest that fits"},
          {"candidates", s.candidates},
          {"moves", s.moves},
          {"seed", s.seed},
          {"stopped", s.stopped},
          {"fits",
           "the five poses reached within the joint limits away from singularities "
           "(smallest singular value of the Jacobian by the readings at least " +
               fmt::format("{:g}", kIsoAwayFromSingular) +
               " m/rad, rotation at 0.1 m/rad), the eight corners within reach"},
          {"text", iso_search_text(s)}};
}

}  // namespace

// plan --iso9283: the test cube and its poses; plan.csv holds a row a pose
// visited (q1..qN and its label in `point`, cycle after cycle), iso9283.json
// the cube and the poses.
int run_iso_plan(const PlanCommandOptions& options) {
  const PlanRequest& o = options.request;
  if (!o.measurement.empty() || o.poses != 0 || !o.candidates.empty())
    throw InputError(
        "--iso9283: the test's poses are the standard's: no --measurement, --poses "
        "or --candidates");
  const DeviceModel model = load_model(o.model, o.tip, o.root);
  IsoCubeOptions cube;
  if (!options.cube_centre.empty()) {
    const std::array<double, 3> c = numbers<3>(options.cube_centre, "--cube-centre");
    cube.centre = Eigen::Vector3d(c[0], c[1], c[2]);
  }
  if (options.cube_size > 0) cube.size = options.cube_size;
  cube.cycles = options.cycles;
  OutputSet out(options.out, "plan");
  const IsoCubePlan plan = plan_iso_cube(model, cube);
  std::string csv;
  for (int i = 1; i <= model.dof(); ++i) csv += fmt::format("q{},", i);
  csv += "point\n";
  for (int cycle = 0; cycle < plan.cycles; ++cycle) {
    for (int k : plan.order) {
      const IsoTestPose& p = plan.poses[static_cast<size_t>(k)];
      for (int i = 0; i < model.dof(); ++i) csv += fmt::format("{:.17g},", p.readings[i]);
      csv += p.label + "\n";
    }
  }
  nlohmann::ordered_json poses = nlohmann::ordered_json::array();
  for (const IsoTestPose& p : plan.poses) {
    const Eigen::Vector3d rpy = matrix_rpy(p.pose.R);
    poses.push_back({{"pose", p.label},
                     {"xyz", {p.pose.p.x(), p.pose.p.y(), p.pose.p.z()}},
                     {"rpy", {rpy[0], rpy[1], rpy[2]}},
                     {"readings", std::vector<double>(p.readings.data(),
                                                      p.readings.data() + p.readings.size())}});
  }
  nlohmann::ordered_json corners = nlohmann::ordered_json::array();
  for (const Eigen::Vector3d& c : plan.corners) corners.push_back({c.x(), c.y(), c.z()});
  const nlohmann::ordered_json json = {
      {"format", "hapticcal-iso9283-plan/1"},
      {"model", o.model},
      {"centre", {plan.centre.x(), plan.centre.y(), plan.centre.z()}},
      {"size", plan.size},
      {"plane", "C1-C2-C7-C8"},
      {"corners", corners},
      {"orientation_held", plan.orientation_held},
      {"search", iso_search_json(plan.search)},
      {"cycles", plan.cycles},
      {"order", {"P1", "P5", "P4", "P3", "P2"}},
      {"poses", poses}};
  write_file_atomically(out.dir() + "/plan.csv", csv);
  write_file_atomically(out.dir() + "/iso9283.json", json.dump(2) + "\n");
  std::string note;
  const int figures = write_report(iso_plan_report(model, plan), out.dir(), note);
  out.commit();
  fmt::print("hapticcal plan --iso9283: {} ({} joints)\n", model.name, model.dof());
  fmt::print(
      "  test cube: edge {:.1f} mm about ({:.1f}, {:.1f}, {:.1f}) mm, its edges along the base "
      "frame's axes; measuring plane C1-C2-C7-C8\n  {}\n",
      plan.size * 1e3, plan.centre.x() * 1e3, plan.centre.y() * 1e3, plan.centre.z() * 1e3,
      iso_search_text(plan.search));
  for (const IsoTestPose& p : plan.poses) {
    fmt::print("  {}: ({:9.3f}, {:9.3f}, {:9.3f}) mm\n", p.label, p.pose.p.x() * 1e3,
               p.pose.p.y() * 1e3, p.pose.p.z() * 1e3);
  }
  fmt::print("  {}; {} cycles of P1, P5, P4, P3, P2 ({} rows)\n",
             plan.orientation_held ? "every pose at the centre's orientation"
                                   : "orientation not held (fewer than six joints)",
             plan.cycles, plan.cycles * 5);
  fmt::print("report: {}/report.html ({} figure{})\n", options.out, figures,
             figures == 1 ? "" : "s");
  if (!note.empty()) fmt::print("note: {}\n", note);
  fmt::print("{}", output_summary(out, options.out,
                                  fmt::format(" (plan.csv: q1..q{} in radians and the pose's "
                                              "label, a row a pose visited)",
                                              model.dof())));
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
