#include "hapticcal/jobs/plan_job.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/identification/tree.hpp"
#include "hapticcal/jobs/calibrate_job.hpp"
#include "hapticcal/model_io/model_source.hpp"
#include "hapticcal/report/report.hpp"
#include "hapticcal/study/paper.hpp"

namespace hapticcal {
namespace {}  // namespace

PlanSetup prepare_plan(const PlanRequest& o) {
  PlanSetup setup;
  const std::optional<MeasurementType> type = measurement_kind(o.measurement);
  if (!type) {
    throw InputError(fmt::format("--measurement '{}': expected distance, position or pose",
                                 printable(o.measurement)));
  }
  const std::optional<PlanCriterion> criterion = plan_criterion(o.criterion);
  if (!criterion) {
    throw InputError(
        fmt::format("--criterion '{}': expected d, a, i or e", printable(o.criterion)));
  }
  if ((!o.tip.empty() || !o.root.empty()) && !is_urdf_path(o.model)) {
    throw InputError(fmt::format("{}: applies to URDF models (.urdf); none is given",
                                 o.tip.empty() ? "--root" : "--tip"));
  }
  setup.model = load_model(o.model, o.tip, o.root);
  if (setup.model.tree()) {
    // A tree: each pose measures every tip's point (tree_model).
    if (*type != MeasurementType::kPosition)
      throw InputError(o.model, 0, "--measurement",
                       "a tree's plan measures its tips' points: position");
    if (o.distance_range || o.box)
      throw InputError(o.model, 0, o.box ? "--box" : "--distance-range",
                       "no workspace constraints on a tree yet");
  }
  setup.type = *type;
  const DeviceModel& model = setup.model;
  PlanOptions& options = setup.options;
  options.poses = o.poses.value_or(0);  // none: refused by run_plan_job
  options.criterion = *criterion;
  options.seed = o.seed;
  if (o.pool) options.pool = *o.pool;
  if (o.refine_passes) options.refine_passes = *o.refine_passes;
  const auto finite = [](const auto& values, const char* option) {
    for (double v : values) {
      if (!std::isfinite(v))
        throw InputError(fmt::format("{}: {} is not a finite number", option, v));
    }
  };
  if (o.distance_range) {
    const std::array<double, 2>& v = *o.distance_range;
    finite(v, "--distance-range");
    if (!(v[0] >= 0 && v[0] < v[1])) {
      throw InputError(
          fmt::format("--distance-range '{},{}': expected 0 <= MIN < MAX", v[0], v[1]));
    }
    options.constraints.min_distance = v[0];
    options.constraints.max_distance = v[1];
  }
  if (o.box) {
    const std::array<double, 6>& v = *o.box;
    finite(v, "--box");
    for (int k = 0; k < 3; ++k) {
      if (!(v[2 * k] < v[2 * k + 1])) {
        throw InputError(fmt::format("--box '{}': each MIN must be below its MAX",
                                     fmt::join(v.begin(), v.end(), ",")));
      }
    }
    options.constraints.box = v;
  }
  if (!o.candidates.empty()) {
    if (options.constraints.any())
      throw InputError("--distance-range / --box: apply to random candidates, not to --candidates");
    const Log log = read_log(o.candidates, o.columns);
    if (log.q.cols() != model.dof()) {
      throw InputError(o.candidates, log.line.empty() ? 1 : log.line.front(), "q",
                       fmt::format("the log has {} joint readings a row, the model {} joints",
                                   log.q.cols(), model.dof()));
    }
    // Candidates are readings: a side of approach makes none new.
    const std::vector<std::vector<int>> groups = repeated_poses(log, /*by_direction=*/false);
    options.candidates.resize(static_cast<Eigen::Index>(groups.size()), model.dof());
    for (size_t g = 0; g < groups.size(); ++g)
      options.candidates.row(static_cast<Eigen::Index>(g)) = log.q.row(groups[g].front());
    if (options.poses > options.candidates.rows()) {
      throw InputError(o.candidates, 0, "",
                       fmt::format("--poses {}: the log has only {} distinct poses", options.poses,
                                   options.candidates.rows()));
    }
  }
  // The kind's own sd among a cable encoder's (the paper's) and a tracker's.
  setup.sigma = o.sigma.value_or(
      kind_of(*type).sigma({.distance = kPaperSigmaMPaper, .position = kPlanSigmaPosition}));
  setup.sigma_e = o.sigma_e.value_or(kPaperSigmaE);
  setup.analysis = options.candidates.size()
                       ? options.candidates
                       : random_readings(model, 300, options.seed ^ 0x5eed, options.constraints);
  setup.fix = o.fix;
  setup.free = o.free;
  setup.user_candidates = options.candidates.size() > 0;
  return setup;
}

std::string plan_json(const PlanRequest& o, const PlanSetup& setup, const PlanProblem& problem,
                      const Plan& plan) {
  nlohmann::ordered_json j;
  j["format"] = "hapticcal-plan/1";
  j["model"] = o.model;
  j["measurement"] = traits(setup.type).name;
  j["criterion"] = to_string(setup.options.criterion);
  j["seed"] = o.seed;
  j["poses"] = setup.options.poses;
  j["candidates"] = setup.user_candidates ? o.candidates : "random";
  j["pool"] = plan.pool;
  j["sigma_m"] = setup.sigma;
  j["sigma_e"] = setup.sigma_e;
  j["chosen_candidates"] = plan.candidate;
  j["predicted_rms_sd"] = {{"planned", plan.planned.rms_sd},
                           {"random_median", plan.random_median_rms_sd},
                           {"random_draws", plan.random_rms_sd}};
  nlohmann::ordered_json sd = nlohmann::ordered_json::object();
  for (int k = 0; k < problem.parameters(); ++k) {
    if (problem.names()[k].ends_with(".encoder_zero")) continue;
    sd[problem.names()[k]] = {{"planned", plan.planned.sd[k]}, {"random", plan.random.sd[k]}};
  }
  j["parameter_sd"] = sd;
  auto obs = [](const Conditioning& c) {
    return nlohmann::ordered_json{{"condition_number", c.condition_number},
                                  {"O1", c.observability.O1},
                                  {"O2", c.observability.O2},
                                  {"O3", c.observability.O3},
                                  {"O4", c.observability.O4}};
  };
  j["observability"] = {{"planned", obs(plan.planned.conditioning)},
                        {"random", obs(plan.random.conditioning)}};
  j["path_length"] = plan.path_length;
  return j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

int write_plan_files(const std::string& dir, const std::string& json, const PlanProblem& problem,
                     const Plan& plan, std::string& note) {
  write_file_atomically(dir + "/plan.csv", plan_to_csv(plan.readings));
  write_file_atomically(dir + "/plan.json", json);
  return write_report(plan_report(problem, plan), dir, note);
}

PlanJob run_plan_job(const PlanRequest& request, const std::string& out,
                     const std::function<void(const PlanSetup&, const PlanProblem&)>& started,
                     const std::function<void(const std::string&)>& progress) {
  if (!request.poses || *request.poses < 1 || *request.poses > 100000)
    throw InputError("--poses: expected 1 to 100000 poses");
  PlanJob job;
  job.setup = prepare_plan(request);
  PlanSetup& setup = job.setup;
  job.out = std::make_unique<OutputSet>(out, "plan");
  if (progress) setup.options.progress = progress;
  // The transmissions step 1 can fit from the planned poses.
  job.problem = std::make_unique<PlanProblem>(step_one_model(setup.model, *request.poses),
                                              setup.type, setup.sigma, setup.sigma_e,
                                              setup.analysis, setup.fix, setup.free);
  if (started) started(setup, *job.problem);
  job.plan = plan_poses(*job.problem, setup.options);
  job.json = plan_json(request, setup, *job.problem, job.plan);
  job.figures = write_plan_files(job.out->dir(), job.json, *job.problem, job.plan, job.report_note);
  job.out->commit();
  return job;
}

}  // namespace hapticcal
