// The report of `calibrate --tip A,B` (a tree, identification/tree.hpp).
#include <fmt/format.h>

#include <cmath>

#include "hapticcal/identification/tree.hpp"
#include "hapticcal/report/report.hpp"
#include "report/figures.hpp"

namespace hapticcal {
namespace {

// Each tip's position error a pose, before and after, on a log axis.
FigureSpec tree_errors_figure(const TreeCalibration& fit) {
  FigureSpec f;
  f.name = "tree_errors";
  f.title =
      "Each tip's position error a pose, of the nominal tree (orange, open) and of the "
      "calibrated one (blue, filled)";
  f.xlabel = "pose";
  f.ylabel = "position error [mm]";
  const Eigen::Index n = fit.errors_before.empty() ? 0 : fit.errors_before[0].size();
  const size_t stride = detail::plot_stride(static_cast<size_t>(n));
  std::vector<double> pose;
  for (Eigen::Index i = 0; i < n; i += static_cast<Eigen::Index>(stride))
    pose.push_back(static_cast<double>(i + 1));
  f.columns.push_back(pose);
  for (size_t c = 0; c < fit.calibrated.tips.size(); ++c) {
    for (const auto* errors : {&fit.errors_before, &fit.errors_after}) {
      std::vector<double> e;
      for (Eigen::Index i = 0; i < n; i += static_cast<Eigen::Index>(stride))
        e.push_back(1e3 * (*errors)[c][i]);
      f.columns.push_back(e);
      const int y = static_cast<int>(f.columns.size()) - 1;
      const std::string label =
          fit.calibrated.tips[c] + (errors == &fit.errors_before ? ", nominal" : ", calibrated");
      Series s = errors == &fit.errors_before ? detail::before_series(label, 0, y)
                                              : detail::after_series(label, 0, y);
      // Orange before, blue after (every report's); a point type a tip, open
      // before and filled after: circles, squares, triangles, diamonds.
      constexpr int kOpen[] = {6, 4, 8, 12}, kFilled[] = {7, 5, 9, 13};
      s.point = errors == &fit.errors_before ? kOpen[c % 4] : kFilled[c % 4];
      f.series.push_back(s);
    }
  }
  f.extra = "set pointsize 0.5";
  f.x_min = 0;
  f.x_max = static_cast<double>(n + 1);
  use_log_y(f, 6);
  return f;
}

// The parameter table: every parameter, its tips, and its estimate or why it is held.
std::string tree_parameter_table(const TreeCalibration& fit) {
  std::vector<std::vector<std::string>> rows;
  for (const ParameterEstimate& p : fit.parameters) {
    std::vector<std::string> tips;
    for (int c : fit.calibrated.chains_of[static_cast<size_t>(p.slot)])
      tips.push_back(fit.calibrated.tips[static_cast<size_t>(c)]);
    const std::string unit = p.unit == ParameterUnit::kLength ? "mm" : "mrad";
    rows.push_back({p.name, fmt::format("{}", fmt::join(tips, ", ")), unit,
                    fmt::format("{:.4f}", 1e3 * p.nominal), fmt::format("{:.4f}", 1e3 * p.value),
                    p.identifiable ? fmt::format("{:.4f}", 1e3 * p.sd) : std::string(),
                    p.identifiable ? std::string("identified") : p.reason});
  }
  return html_table({"parameter", "tips", "unit", "nominal", "calibrated", "sd", "status"}, rows);
}

}  // namespace

Report tree_report(const TreeCalibration& fit, const std::string& model_path,
                   const std::string& log_path, const std::vector<std::string>& lines) {
  const DeviceTree& t = fit.calibrated;
  Report report;
  report.title = fmt::format("hapticcal calibrate: {} (a tree of {} tips) on {}", t.name,
                             t.tips.size(), detail::display_path(log_path));
  report.outcome.status = to_string(fit.status);
  report.outcome.usable = fit.status == CalibrationStatus::kConverged;
  for (size_t k = 0; k < lines.size() && k < 2 + t.tips.size(); ++k)
    report.outcome.headline.push_back(lines[k]);
  report.outcome.notes = fit.notes;
  if (!report.outcome.usable)
    report.outcome.notes.insert(report.outcome.notes.begin(), fit.status_reason);
  report.sections.push_back(fmt::format(
      "<p>Model {}: the chains from its root to the tips {}, fitted at once from {} poses (the "
      "log's x1, y1, z1 at the first tip, x2, y2, z2 at the second, ...). A joint the chains share "
      "is one set of parameters; a tool is each tip's. Lengths in mm, angles in mrad; "
      "results.json holds them in metres and radians. Plain least squares over the parameters the "
      "rank test identifies (no tolerance prior or model selection on a tree yet).</p>\n",
      html_escape(model_path), html_escape(fmt::format("{}", fmt::join(t.tips, ", "))), fit.poses));
  report.sections.push_back("<h2>Parameters</h2>\n" + tree_parameter_table(fit));
  report.figures.push_back(tree_errors_figure(fit));
  return report;
}

}  // namespace hapticcal
