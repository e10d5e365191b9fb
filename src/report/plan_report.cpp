// The report of `plan`: predicted uncertainty of the planned poses against
// random poses of the same count, per parameter and over the workspace.
#include <fmt/format.h>

#include "hapticcal/design/plan.hpp"
#include "hapticcal/report/report.hpp"
#include "report/report_parts.hpp"

namespace hapticcal {
namespace {

// The terminal's and the other reports' units: kinematic lengths in mm and
// angles in mrad, step-1 parameters as calibrate prints them.
DisplayUnit unit_of(const PlanProblem& problem, const std::string& name) {
  for (const ParameterInfo& info : problem.model().parameter_info()) {
    if (info.name == name) return display_unit(info.unit);
  }
  return display_unit(name);
}

}  // namespace

Report plan_report(const PlanProblem& problem, const Plan& plan) {
  Report report;
  report.title = fmt::format("hapticcal plan: {} poses, {}-optimal", plan.readings.rows(),
                             to_string(plan.criterion));
  const char* tip = traits(problem.type()).tip;
  report.outcome.status = "done";
  report.outcome.headline.push_back(fmt::format(
      "predicted RMS {} sd over the workspace: {:.3f} um with the {} planned poses, {:.3f} um "
      "with random poses of the same count (median of {} draws)",
      tip, plan.planned.rms_sd * 1e6, plan.readings.rows(), plan.random_median_rms_sd * 1e6,
      plan.random_rms_sd.size()));
  report.outcome.headline.push_back(
      fmt::format("condition number {:.4g} planned, {:.4g} random; {} parameters held at nominal",
                  plan.planned.conditioning.condition_number,
                  plan.random.conditioning.condition_number, problem.held().size()));
  report.sections.push_back(fmt::format(
      "<p>{} poses chosen from {} candidates (seed {}), measurement: {} (sd {:.3g} um), "
      "external encoders sd {:.3g} urad. Predicted RMS {} sd over the workspace (exact two-step "
      "Cramer-Rao covariance): <b>{:.3f} um planned</b>, {:.3f} um for random poses of the same "
      "count (median of {} draws; range {:.3f} - {:.3f} um).</p>\n"
      "<p>Exchange: {} sweeps, {} swaps; refinement moves: {}; criterion of the joint information "
      "{:.6g} (greedy); of the two-step information {:.6g} (greedy) -> {:.6g} (exchange) -> "
      "{:.6g} (refined). Path: {:.2f} rad of max joint travel (unordered "
      "{:.2f} rad).</p>\n",
      plan.readings.rows(), plan.pool, plan.seed, traits(problem.type()).name,
      problem.sigma_m() * 1e6, problem.sigma_e() * 1e6, tip, plan.planned.rms_sd * 1e6,
      plan.random_median_rms_sd * 1e6, plan.random_rms_sd.size(),
      plan.random_rms_sd.empty() ? 0.0 : plan.random_rms_sd.front() * 1e6,
      plan.random_rms_sd.empty() ? 0.0 : plan.random_rms_sd.back() * 1e6, plan.sweeps, plan.swaps,
      plan.refined_moves, plan.criterion_greedy, plan.two_step_greedy, plan.two_step_exchange,
      plan.two_step_refined, plan.path_length, plan.path_length_unordered));
  const Conditioning& a = plan.planned.conditioning;
  const Conditioning& b = plan.random.conditioning;
  report.sections.push_back(
      "<h2>Observability of the kinematic parameters</h2>\n" +
      html_table(
          {"design", "condition number", "O1", "O2", "O3", "O4"},
          {{"planned", fmt::format("{:.4g}", a.condition_number),
            fmt::format("{:.4g}", a.observability.O1), fmt::format("{:.4g}", a.observability.O2),
            fmt::format("{:.4g}", a.observability.O3), fmt::format("{:.4g}", a.observability.O4)},
           {"random (median draw)", fmt::format("{:.4g}", b.condition_number),
            fmt::format("{:.4g}", b.observability.O1), fmt::format("{:.4g}", b.observability.O2),
            fmt::format("{:.4g}", b.observability.O3),
            fmt::format("{:.4g}", b.observability.O4)}}));
  std::vector<std::vector<std::string>> rows;
  std::vector<double> planned, random;
  std::vector<std::string> plotted_names;
  for (int k = 0; k < problem.parameters(); ++k) {
    const std::string& name = problem.names()[k];
    if (name.ends_with(".encoder_zero")) continue;
    const DisplayUnit u = unit_of(problem, name);
    rows.push_back(
        {name, fmt::format("{:.4g}", plan.planned.sd[k] * u.scale),
         fmt::format("{:.4g}", plan.random.sd[k] * u.scale),
         fmt::format("{:.3f}",
                     plan.random.sd[k] > 0 ? plan.planned.sd[k] / plan.random.sd[k] : 0.0),
         u.unit.empty() ? "-" : u.unit});
    plotted_names.push_back(name);
    planned.push_back(plan.planned.sd[k] * u.scale);
    random.push_back(plan.random.sd[k] * u.scale);
  }
  report.sections.push_back(
      "<h2>Predicted standard deviation per parameter</h2>\n" +
      html_table({"parameter", "planned", "random (median draw)", "ratio", "unit"}, rows));
  if (!problem.held().empty()) {
    std::vector<std::vector<std::string>> held;
    for (const auto& [name, why] : problem.held()) held.push_back({name, why});
    report.sections.push_back("<h2>Held at nominal</h2>\n" +
                              html_table({"parameter", "why"}, held));
  }
  FigureSpec f;
  f.name = "plan_sd";
  f.title = "Predicted sd per parameter: planned vs random poses";
  f.xlabel = "parameter";
  f.ylabel = "predicted sd [the table's unit: mm, mrad, deg, rad or -]";
  f.columns = {planned, random};
  f.xtics = plotted_names;
  f.series = {{"planned", -1, 0, "points", -1, "#0072b2", 0, 1.5, 7},
              {"random (median draw)", -1, 1, "points", -1, "#d55e00", 0, 1.5, 5}};
  f.x_min = -0.5;
  f.x_max = static_cast<double>(plotted_names.size()) - 0.5;
  use_log_y(f, 8);
  report.figures.push_back(f);
  // Where the planned poses are, in the order of the path plan.csv lists.
  report.figures.push_back(detail::poses_figure(
      problem.model(), plan.readings,
      fmt::format("The {} planned poses in the workspace: the tool point{} through the nominal "
                  "model, joined in the order of plan.csv",
                  plan.readings.rows(), problem.model().tree() ? "s (every tip)" : ""),
      "tool point of a planned pose", true));
  return report;
}

}  // namespace hapticcal
