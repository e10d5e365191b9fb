#include "plan_command.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "hapticcal/design/plan.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/io/error.hpp"
#include "hapticcal/io/io.hpp"
#include "hapticcal/io/model_source.hpp"
#include "hapticcal/io/output_set.hpp"
#include "hapticcal/report/report.hpp"
#include "hapticcal/study/paper.hpp"

namespace hapticcal::cli {
namespace {

// "A,B,..." as `count` finite numbers, or InputError naming the option.
std::vector<double> numbers(const std::string& text, size_t count, const std::string& option) {
  std::vector<double> out;
  for (const std::string& part : split_columns(text)) {
    try {
      size_t used = 0;
      const double v = std::stod(part, &used);
      if (used != part.size() || !std::isfinite(v)) throw std::invalid_argument("");
      out.push_back(v);
    } catch (const std::exception&) {
      throw InputError(
          fmt::format("{} '{}': '{}' is not a number", option, printable(text), printable(part)));
    }
  }
  if (out.size() != count) {
    throw InputError(fmt::format("{} '{}': expected {} comma-separated numbers", option,
                                 printable(text), count));
  }
  return out;
}

std::vector<std::string> list(const std::string& text) {
  return text.empty() ? std::vector<std::string>{} : split_columns(text);
}

}  // namespace

CLI::App* add_plan_command(CLI::App& app, PlanCommandOptions& o) {
  auto* plan = app.add_subcommand(
      "plan", "Choose N poses that make the calibration predict best (experiment design)");
  plan->add_option("--model", o.model, "Device file (YAML) or URDF (.urdf, with --tip)")
      ->required();
  plan->add_option("--measurement", o.measurement, "distance, position or pose")->required();
  plan->add_option("--poses", o.poses, "Number of poses to plan")
      ->required()
      ->check(CLI::Range(1, 100000));
  auto* candidates =
      plan->add_option("--candidates", o.candidates,
                       "A log of recorded poses to choose from (repeated rows count as one pose)");
  auto* pool = plan->add_option("--pool", o.pool,
                                "Random candidate poses within the joint limits (default 10000)")
                   ->check(CLI::Range(1, 10000000));
  candidates->excludes(pool);
  pool->excludes(candidates);
  plan->add_option("--columns", o.columns, "Column names of a candidates log without header");
  plan->add_option("--criterion", o.criterion,
                   "d (log det), a (trace of the scaled covariance), i (mean prediction "
                   "variance over the workspace, default), e (smallest eigenvalue)");
  plan->add_option("--seed", o.seed, "Random seed (default 1)");
  plan->add_option("--sigma", o.sigma,
                   "Measurement sd [m] (default: the paper's sigma_m for distances, 10 um for "
                   "positions and poses)")
      ->check(CLI::Range(1e-12, 1.0));
  plan->add_option("--sigma-e", o.sigma_e,
                   "External encoder sd [rad] (default: the paper's 2 pi / 20000 / 3)")
      ->check(CLI::Range(1e-12, 1.0));
  plan->add_option("--distance-range", o.distance_range,
                   "MIN,MAX: the tool point's distance from the measurement origin [m] (a cable "
                   "encoder's range)");
  plan->add_option("--box", o.box,
                   "XMIN,XMAX,YMIN,YMAX,ZMIN,ZMAX: a box the tool point must be in "
                   "(measurement frame) [m]");
  plan->add_option("--refine-passes", o.refine_passes,
                   "Continuous refinement passes of random candidates (default 20; 0: none)")
      ->check(CLI::Range(0, 1000));
  plan->add_option("--fix", o.fix, "Kinematic parameters held at nominal, e.g. j1.a,j2.d");
  plan->add_option("--free", o.free, "Parameters added to the candidates, e.g. j2.beta");
  plan->add_option("--tip", o.tip, "Tip link of a URDF model's chain");
  plan->add_option("--root", o.root, "Root link of a URDF model's chain");
  plan->add_option("--out", o.out, "Output folder (default hapticcal-out/plan)");
  return plan;
}

int run_plan(const PlanCommandOptions& o) {
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
  const DeviceModel model = load_model(o.model, o.tip, o.root);
  PlanOptions options;
  options.poses = o.poses;
  options.criterion = *criterion;
  options.seed = o.seed;
  if (o.pool > 0) options.pool = o.pool;
  if (o.refine_passes >= 0) options.refine_passes = o.refine_passes;
  if (!o.distance_range.empty()) {
    const std::vector<double> v = numbers(o.distance_range, 2, "--distance-range");
    if (!(v[0] >= 0 && v[0] < v[1])) {
      throw InputError(fmt::format("--distance-range '{}': expected 0 <= MIN < MAX",
                                   printable(o.distance_range)));
    }
    options.constraints.min_distance = v[0];
    options.constraints.max_distance = v[1];
  }
  if (!o.box.empty()) {
    const std::vector<double> v = numbers(o.box, 6, "--box");
    for (int k = 0; k < 3; ++k) {
      if (!(v[2 * k] < v[2 * k + 1]))
        throw InputError(
            fmt::format("--box '{}': each MIN must be below its MAX", printable(o.box)));
    }
    options.constraints.box = std::array<double, 6>{v[0], v[1], v[2], v[3], v[4], v[5]};
  }
  if (!o.candidates.empty()) {
    if (options.constraints.any())
      throw InputError("--distance-range / --box: apply to random candidates, not to --candidates");
    const Log log = read_log(o.candidates, list(o.columns));
    if (log.q.cols() != model.dof()) {
      throw InputError(o.candidates, log.line.empty() ? 1 : log.line.front(), "q",
                       fmt::format("the log has {} joint readings a row, the model {} joints",
                                   log.q.cols(), model.dof()));
    }
    const std::vector<std::vector<int>> groups = repeated_poses(log);
    options.candidates.resize(static_cast<Eigen::Index>(groups.size()), model.dof());
    for (size_t g = 0; g < groups.size(); ++g)
      options.candidates.row(static_cast<Eigen::Index>(g)) = log.q.row(groups[g].front());
    if (o.poses > options.candidates.rows()) {
      throw InputError(o.candidates, 0, "",
                       fmt::format("--poses {}: the log has only {} distinct poses", o.poses,
                                   options.candidates.rows()));
    }
  }
  const double sigma = o.sigma > 0                           ? o.sigma
                       : *type == MeasurementType::kDistance ? kPaperSigmaMPaper
                                                             : kPlanSigmaPosition;
  const double sigma_e = o.sigma_e > 0 ? o.sigma_e : kPaperSigmaE;
  OutputSet out(o.out, "plan");
  const bool tty = isatty(2);
  options.progress = [tty](const std::string& s) {
    if (tty) fmt::print(stderr, "  {}\n", s);
  };
  const Eigen::MatrixXd analysis =
      options.candidates.size()
          ? options.candidates
          : random_readings(model, 300, options.seed ^ 0x5eed, options.constraints);
  const PlanProblem problem(model, *type, sigma, sigma_e, analysis, list(o.fix), list(o.free));
  fmt::print(
      "hapticcal plan: {} poses of {} ({} joints), {} measurements, {}-optimal, seed {}\n"
      "  parameters: {} ({} kinematic, the rest step-1 transmissions and encoder zeros); "
      "sigma_m {:.4g} um, sigma_e {:.4g} urad\n",
      o.poses, model.name, model.dof(), traits(*type).name, to_string(*criterion), o.seed,
      problem.parameters(), problem.kinematic_slots().size(), sigma * 1e6, sigma_e * 1e6);
  const Plan plan = plan_poses(problem, options);
  const bool user = options.candidates.size() > 0;
  fmt::print(
      "  candidates: {} {}; exchange: {} sweeps, {} swaps; refinement: {} moves ({:.1f} s)\n",
      plan.pool, user ? "recorded poses (" + o.candidates + ")" : "random poses", plan.sweeps,
      plan.swaps, plan.refined_moves, plan.seconds);
  const char* tip = *type == MeasurementType::kDistance ? "distance" : "position";
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

  write_file_atomically(out.dir() + "/plan.csv", plan_to_csv(plan.readings));
  nlohmann::ordered_json j;
  j["format"] = "hapticcal-plan/1";
  j["model"] = o.model;
  j["measurement"] = traits(*type).name;
  j["criterion"] = to_string(*criterion);
  j["seed"] = o.seed;
  j["poses"] = o.poses;
  j["candidates"] = user ? o.candidates : "random";
  j["pool"] = plan.pool;
  j["sigma_m"] = sigma;
  j["sigma_e"] = sigma_e;
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
  write_file_atomically(out.dir() + "/plan.json",
                        j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
  std::string note;
  const int drawn = write_report(plan_report(problem, plan), out.dir(), note);
  out.commit();
  fmt::print("report: {}/report.html ({} figures)\n", o.out, drawn);
  if (!note.empty()) fmt::print("note: {}\n", note);
  fmt::print("wrote {0}/plan.csv (q1..q{1} in radians, path order), {0}/plan.json\n", o.out,
             model.dof());
  return 0;
}

}  // namespace hapticcal::cli
