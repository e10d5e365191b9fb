// plan's options (jobs/command_options.hpp): an experiment design's and the
// ISO 9283 test cube's, in one table as the command takes them.
#include "hapticcal/core/option_ranges.hpp"
#include "hapticcal/jobs/plan_job.hpp"

namespace hapticcal {

namespace {

using R = PlanCommandRequest;

void add_design_options(CommandOptions<R>& t) {
  auto candidates = field_option<R>(
      "candidates", "A log of recorded poses to choose from (repeated rows count as one pose)",
      [](R & r) -> auto& { return r.plan.candidates; });
  t.push_back(candidates);
  t.push_back(field_option<R>(
      "pool", "Random candidate poses within the joint limits (default 10000)",
      [](R & r) -> auto& { return r.plan.pool; }, option_range::kPool));
  t.push_back(field_option<R>(
      "columns", "Column names of a candidates log without header",
      [](R & r) -> auto& { return r.plan.columns; }));
  auto criterion = field_option<R>(
      "criterion",
      "d (log det), a (trace of the scaled covariance), i (mean prediction variance over the "
      "workspace), e (smallest eigenvalue)",
      [](R & r) -> auto& { return r.plan.criterion; });
  criterion.words = {"d", "a", "i", "e"};
  t.push_back(criterion);
  t.push_back(field_option<R>(
      "seed", "Random seed", [](R & r) -> auto& { return r.plan.seed; }, kAtLeastZero));
  t.push_back(field_option<R>(
      "sigma",
      "Measurement sd [m] (default: the paper's sigma_m for distances, 10 um for positions and "
      "poses)",
      [](R & r) -> auto& { return r.plan.sigma; }, option_range::kSigma));
  t.push_back(field_option<R>(
      "sigma_e", "External encoder sd [rad] (default: the paper's 2 pi / 20000 / 3)",
      [](R & r) -> auto& { return r.plan.sigma_e; }, option_range::kAngle));
  t.push_back(of_numbers(parsed_option<R>(
      "distance_range", OptionKind::kText,
      "MIN,MAX: the tool point's distance from the measurement origin [m] (a cable encoder's "
      "range)",
      [](R& r, const OptionValue& v, const std::string& as) {
        r.plan.distance_range = comma_numbers<2>(std::get<std::string>(v), as);
      })));
  t.push_back(of_numbers(parsed_option<R>(
      "box", OptionKind::kText,
      "XMIN,XMAX,YMIN,YMAX,ZMIN,ZMAX: a box the tool point must be in (measurement frame) [m]",
      [](R& r, const OptionValue& v, const std::string& as) {
        r.plan.box = comma_numbers<6>(std::get<std::string>(v), as);
      })));
  t.push_back(field_option<R>(
      "refine_passes", "Continuous refinement passes of random candidates (default 20; 0: none)",
      [](R & r) -> auto& { return r.plan.refine_passes; }, option_range::kRefinePasses));
  t.push_back(field_option<R>(
      "fix", "Kinematic parameters held at nominal, e.g. j1.a,j2.d",
      [](R & r) -> auto& { return r.plan.fix; }));
  t.push_back(field_option<R>(
      "free", "Parameters added to the candidates, e.g. j2.beta",
      [](R & r) -> auto& { return r.plan.free; }));
}

void add_iso_options(CommandOptions<R>& t) {
  t.push_back(field_option<R>(
      "iso9283",
      "An ISO 9283 test instead: the test cube, its five poses P1..P5 as joint targets and the "
      "cycles (plan.csv, a row a pose visited; iso9283.json)",
      [](R & r) -> auto& { return r.iso9283; }));
  t.push_back(of_numbers(parsed_option<R>(
      "cube_centre", OptionKind::kText,
      "X,Y,Z: the test cube's centre in the measurement frame [m] (default: searched over the "
      "workspace for the largest cube)",
      [](R& r, const OptionValue& v, const std::string& as) {
        r.iso.cube_centre = comma_numbers<3>(std::get<std::string>(v), as);
      })));
  auto size =
      parsed_option<R>("cube_size", OptionKind::kNumber,
                       "The test cube's edge [m] (default: the largest the workspace holds)",
                       [](R& r, const OptionValue& v, const std::string&) {
                         r.iso.cube_size = std::get<double>(v);
                       });
  size.range = OptionRange{1e-3, 10, "m"};
  t.push_back(size);
  t.push_back(field_option<R>(
      "cycles", "ISO 9283 cycles (the standard's 30)", [](R & r) -> auto& { return r.iso.cycles; },
      OptionRange{1, 1000}));
}

CommandOptions<R> plan_table() {
  CommandOptions<R> t;
  auto model =
      parsed_option<R>("model", OptionKind::kText, "Device file (YAML) or URDF (.urdf, with --tip)",
                       [](R& r, const OptionValue& v, const std::string&) {
                         r.plan.model = r.iso.model = std::get<std::string>(v);
                       });
  model.required = true;
  t.push_back(model);
  auto measurement = field_option<R>(
      "measurement", "distance, position or pose (required unless --iso9283)",
      [](R & r) -> auto& { return r.plan.measurement; });
  measurement.positional = true;
  t.push_back(measurement);
  auto poses = field_option<R>(
      "poses", "Number of poses to plan (required unless --iso9283)",
      [](R & r) -> auto& { return r.plan.poses; }, option_range::kPlanPoses);
  poses.positional = true;
  t.push_back(poses);
  add_iso_options(t);
  add_design_options(t);
  t.push_back(parsed_option<R>("tip", OptionKind::kText, "Tip link of a URDF model's chain",
                               [](R& r, const OptionValue& v, const std::string&) {
                                 r.plan.tip = r.iso.tip = std::get<std::string>(v);
                               }));
  t.push_back(parsed_option<R>("root", OptionKind::kText, "Root link of a URDF model's chain",
                               [](R& r, const OptionValue& v, const std::string&) {
                                 r.plan.root = r.iso.root = std::get<std::string>(v);
                               }));
  t.push_back(field_option<R>(
      "out", "Output folder", [](R & r) -> auto& { return r.out; }));
  return t;
}

}  // namespace

const CommandOptions<PlanCommandRequest>& plan_options() {
  static const CommandOptions<PlanCommandRequest> table = plan_table();
  return table;
}

void check_plan_command(const PlanCommandRequest& r) {
  const PlanCommandRequest defaults;
  if (r.iso9283) {
    if (!r.plan.measurement.empty() || r.plan.poses || !r.plan.candidates.empty())
      throw InputError(
          "--iso9283: the test's poses are the standard's: no --measurement, --poses or "
          "--candidates");
    return;
  }
  if (r.iso.cube_centre || r.iso.cube_size != defaults.iso.cube_size ||
      r.iso.cycles != defaults.iso.cycles)
    throw InputError(
        "--cube-centre, --cube-size and --cycles: apply to an ISO 9283 plan (--iso9283)");
  if (r.plan.measurement.empty() || !r.plan.poses)
    throw InputError("plan: --measurement and --poses are required (or --iso9283)");
  if (!r.plan.candidates.empty() && r.plan.pool)
    throw InputError("--candidates excludes --pool: the candidates are the log's poses");
}

}  // namespace hapticcal
