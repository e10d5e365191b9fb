// `plan --tip A,B` on a URDF: the poses to measure every tip of a tree at
// (jobs/plan_job.hpp, design/tree_plan.hpp).
#include <fmt/format.h>

#include <nlohmann/json.hpp>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/jobs/calibrate_job.hpp"
#include "hapticcal/jobs/plan_job.hpp"
#include "hapticcal/model_io/model_source.hpp"
#include "hapticcal/report/report.hpp"

namespace hapticcal {
namespace {

// What a tree's plan does not take (yet): InputError naming the option.
void check_tree_request(const PlanRequest& r) {
  const auto refuse = [&](const std::string& option, const std::string& why) {
    throw InputError(r.model, 0, option, why);
  };
  if (!is_urdf_path(r.model)) refuse("--tip", "several tips (a tree) need a URDF model");
  if (r.measurement != "position")
    refuse("--measurement", "a tree's plan measures its tips' points: position");
  if (!r.candidates.empty()) refuse("--candidates", "a tree's plan draws random candidates");
  if (r.distance_range || r.box)
    refuse(r.box ? "--box" : "--distance-range", "no workspace constraints on a tree yet");
  if (!r.fix.empty() || !r.free.empty())
    refuse(r.fix.empty() ? "--free" : "--fix", "not on a tree's plan yet");
  if (r.refine_passes >= 0) refuse("--refine-passes", "a tree's plan has no refinement");
  if (r.sigma_e > 0) refuse("--sigma-e", "a tree's plan has no external encoders");
}

std::string tree_plan_json(const PlanRequest& request, const DeviceTree& tree,
                           const TreePlanOptions& options, const TreePlan& plan) {
  nlohmann::ordered_json j;
  j["format"] = "hapticcal-tree-plan/1";
  j["model"] = request.model;
  j["tree"] = {{"name", tree.name}, {"tips", tree.tips}, {"joints", tree.joints}};
  j["poses"] = options.poses;
  j["criterion"] = to_string(options.criterion);
  j["seed"] = options.seed;
  j["sigma"] = options.sigma;
  j["pool"] = plan.pool;
  j["predicted_rms_sd"] = plan.rms_sd;
  j["greedy_rms_sd"] = plan.rms_sd_greedy;
  j["exchange"] = {{"sweeps", plan.sweeps},
                   {"swaps", plan.swaps},
                   {"criterion_greedy", plan.criterion_greedy},
                   {"criterion_exchange", plan.criterion_exchange}};
  j["random_median_rms_sd"] = plan.random_median_rms_sd;
  j["random_rms_sd"] = plan.random_rms_sd;
  j["path_length"] = plan.path_length;
  for (size_t i = 0; i < plan.parameters.size(); ++i)
    j["parameters"][plan.parameters[i]] = {{"sd", plan.sd[static_cast<Eigen::Index>(i)]}};
  for (const auto& [name, why] : plan.held) j["held"][name] = why;
  return j.dump(2) + "\n";
}

Report tree_plan_report(const DeviceTree& tree, const TreePlan& plan,
                        const std::vector<std::string>& lines) {
  Report report;
  report.title = fmt::format("hapticcal plan: {} poses of {} (a tree of {} tips)",
                             plan.readings.rows(), tree.name, tree.tips.size());
  report.outcome.status = "planned";
  report.outcome.headline = lines;
  std::vector<std::vector<std::string>> rows;
  for (size_t i = 0; i < plan.parameters.size(); ++i) {
    const std::string& name = plan.parameters[i];
    const bool angle = std::any_of(
        tree.parameters.begin(), tree.parameters.end(),
        [&](const ParameterInfo& p) { return p.name == name && p.unit == ParameterUnit::kAngle; });
    rows.push_back({name, angle ? "mrad" : "mm",
                    fmt::format("{:.4g}", 1e3 * plan.sd[static_cast<Eigen::Index>(i)])});
  }
  report.sections.push_back(
      "<p>The greedy start and Fedorov exchange of the plan on the tree's rows (no continuous "
      "refinement on a tree yet); the sd are the linearised covariance's at the nominal "
      "tree.</p>\n<h2>Predicted "
      "standard deviations</h2>\n" +
      html_table({"parameter", "unit", "predicted sd"}, rows));
  std::vector<std::vector<std::string>> held;
  for (const auto& [name, why] : plan.held) held.push_back({name, why});
  report.sections.push_back("<h2>Held</h2>\n" + html_table({"parameter", "why"}, held));
  return report;
}

}  // namespace

TreePlanJob run_tree_plan_job(const PlanRequest& request, const std::vector<std::string>& tips,
                              const std::string& out) {
  check_tree_request(request);
  TreePlanJob job;
  job.tree = load_tree(request.model, tips, request.root);
  const std::optional<PlanCriterion> criterion = plan_criterion(request.criterion);
  if (!criterion)
    throw InputError(fmt::format("--criterion {}: expected d, a, i or e", request.criterion));
  job.options.criterion = *criterion;
  job.options.poses = request.poses;
  job.options.seed = request.seed;
  if (request.pool > 0) job.options.pool = request.pool;
  if (request.sigma > 0) job.options.sigma = request.sigma;
  job.out = std::make_unique<OutputSet>(out, "plan");
  job.plan = plan_tree(job.tree, job.options);
  const TreePlan& p = job.plan;
  job.lines = {
      fmt::format("hapticcal plan: {} poses of {} (a tree of {} tips: {}; {} joints), position, "
                  "{}-optimal, seed {}",
                  job.options.poses, job.tree.name, tips.size(), fmt::join(tips, ", "),
                  job.tree.dof(), to_string(job.options.criterion), job.options.seed),
      fmt::format("  parameters: {} identifiable ({} held); sigma {:.4g} um; candidates: {} "
                  "random poses; greedy start {}, exchange: {} swaps in {} sweeps",
                  p.parameters.size(), p.held.size(), 1e6 * job.options.sigma, p.pool,
                  p.rms_sd_greedy > 0 ? fmt::format("{:.3f} um", 1e6 * p.rms_sd_greedy)
                                      : std::string("undetermined"),
                  p.swaps, p.sweeps),
      fmt::format("  predicted RMS sd of a tip's point over the workspace: planned {:.3f} um, "
                  "random {} poses {:.3f} um (median of {} draws): ratio {:.3f}",
                  1e6 * p.rms_sd, job.options.poses, 1e6 * p.random_median_rms_sd,
                  p.random_rms_sd.size(),
                  p.random_median_rms_sd > 0 ? p.rms_sd / p.random_median_rms_sd : 0.0),
      fmt::format("  path: {:.2f} rad of largest joint travel (unordered {:.2f} rad)",
                  p.path_length, p.path_length_unordered)};
  job.json = tree_plan_json(request, job.tree, job.options, p);
  write_file_atomically(job.out->dir() + "/plan.csv", plan_to_csv(p.readings));
  write_file_atomically(job.out->dir() + "/plan.json", job.json);
  job.figures =
      write_report(tree_plan_report(job.tree, p, job.lines), job.out->dir(), job.report_note);
  job.out->commit();
  return job;
}

}  // namespace hapticcal
