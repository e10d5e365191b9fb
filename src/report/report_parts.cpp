// The tables and figures that the calibrate and simulate reports share.
#include "report/report_parts.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "hapticcal/kinematics/kinematics.hpp"

namespace hapticcal::detail {

void transmission_figures(const TransmissionFit& t, const std::string& link, const Log& log,
                          const std::vector<int>& rows, const Transmission& fitted,
                          const Transmission* truth, std::vector<FigureSpec>& figures) {
  std::vector<double> q, measured, model, real, residual;
  for (int r : rows) q.push_back(log.q(r, t.joint));
  for (int i : order_by(q)) {
    const int r = rows[i];
    const double qi = log.q(r, t.joint);
    const double m = log.ext(r, t.joint) - qi - t.offset;
    measured.push_back(m * 1e3);
    model.push_back(fitted.error(qi) * 1e3);
    residual.push_back((m - fitted.error(qi)) * 1e3);
    if (truth) real.push_back(truth->error(qi) * 1e3);
  }
  std::sort(q.begin(), q.end());
  for (double& v : q) v *= 180 / M_PI;
  FigureSpec fit =
      figure("transmission_" + link,
             fmt::format("{} transmission error: measured and identified {} model", link, t.type),
             "reading q [deg]", "dtheta [mrad]", {q, measured, model});
  fit.series = {measured_points("measured (ext - q - c)", 0, 1),
                identified_line("identified", 0, 2)};
  if (truth) {
    fit.columns.push_back(real);
    fit.series.push_back(truth_line("truth", 0, 3));
  }
  figures.push_back(fit);
  FigureSpec res = figure("transmission_" + link + "_residual",
                          fmt::format("{} transmission fit residual", link), "reading q [deg]",
                          "residual [mrad]", {q, residual});
  res.series = {measured_points("measured - identified", 0, 1)};
  figures.push_back(res);
}

FigureSpec poses_figure(const DeviceModel& model, const Eigen::MatrixXd& readings,
                        const std::string& title, const std::string& label, bool path) {
  const PreparedModel prepared(model);
  std::vector<double> x, y, z;
  for (Eigen::Index r = 0; r < readings.rows(); ++r) {
    const Eigen::VectorXd q = readings.row(r).transpose();
    for (int tip = 0; tip < prepared.tips(); ++tip) {
      const Frame<double> T = prepared.forward(q.data(), tip);
      if (!T.p.allFinite()) continue;
      x.push_back(T.p.x() * 1e3);
      y.push_back(T.p.y() * 1e3);
      z.push_back(T.p.z() * 1e3);
    }
  }
  // The floor below the lowest point, a whole mm: the shadows' z is exactly the
  // axis' lower limit (a rounded limit above them would drop every shadow).
  const auto [low, high] = std::minmax_element(z.begin(), z.end());
  const double floor = z.empty() ? 0 : std::floor(*low - 0.05 * std::max(*high - *low, 1.0));
  FigureSpec f =
      figure("poses", title, "x [mm]", "y [mm]", {x, y, z, std::vector<double>(z.size(), floor)});
  f.zlabel = "z [mm]";
  f.series.push_back({"projection on the floor", 0, 1, "points", -1, "gray75", 0, 0, 7});
  f.series.back().z = 3;
  if (path) {
    f.series.push_back({"path order", 0, 1, "lines", -1, "gray60", 0, 0.75, 0});
    f.series.back().z = 2;
  }
  f.series.push_back({label, 0, 1, "points", -1, "#0072b2", 0, 1.5, 7});
  f.series.back().z = 2;
  // gnuplot fits any box in the canvas at scale 1, which leaves a flat
  // workspace small on a wide figure: enlarged as far as the box's projected
  // height allows (view 60, 30; axes to one scale, the longest spanning 2).
  double scale = 1;
  if (!x.empty()) {
    const auto [x0, x1] = std::minmax_element(x.begin(), x.end());
    const auto [y0, y1] = std::minmax_element(y.begin(), y.end());
    const double hx = (*x1 - *x0) / 2, hy = (*y1 - *y0) / 2, hz = (*high - floor) / 2;
    const double longest = std::max({hx, hy, hz, 1e-9});
    const double height =
        0.5 * (hx * 0.5 + hy * std::sqrt(0.75)) / longest + std::sqrt(0.75) * hz / longest;
    scale = std::clamp(1.3 / height, 1.0, 1.5);
  }
  f.extra = fmt::format("set view 60, 30, {:.2f}\nset zrange [{:.0f}:*]\nset pointsize 0.6", scale,
                        floor);
  return f;
}

std::string held_table(const KinematicFit& k) {
  std::vector<std::vector<std::string>> rows;
  for (const ParameterEstimate& e : k.parameters) {
    if (!e.identifiable) rows.push_back({e.name, e.reason});
  }
  return "<h2>Held at nominal (identifiability analysis and model selection)</h2>\n" +
         html_table({"parameter", "why"}, rows);
}

ParameterUnits parameter_units(const ParameterEstimate& e, const DeviceModel& nominal) {
  const DisplayUnit small = display_unit(e.unit);
  if (e.unit != ParameterUnit::kAngle) return {small, small};
  const std::vector<ParameterInfo> info = nominal.parameter_info();
  const bool pose =
      e.slot >= 0 && e.slot < static_cast<int>(info.size()) && info[e.slot].name == e.name &&
      (info[e.slot].block == ParameterBlock::kBase || info[e.slot].block == ParameterBlock::kLink ||
       info[e.slot].block == ParameterBlock::kTool);
  if (!pose) return {small, small};
  return {{180 / M_PI, "deg"}, small};
}

std::string undetermined_text(const ParameterEstimate& e, const DeviceModel& nominal) {
  const DisplayUnit u = parameter_units(e, nominal).change;
  if (std::isfinite(e.tolerance) && e.sd > e.tolerance) {
    return fmt::format("sd {:.4g} {} above its tolerance {:.4g} {}", e.sd * u.scale, u.unit,
                       e.tolerance * u.scale, u.unit);
  }
  return fmt::format("correlated {:+.3f} with {}: their combination is determined, not each",
                     e.max_correlation, e.max_correlation_with);
}

std::string evidence_text(const KinematicFit& k) {
  if (k.search.ran) return "the held-out error judged the model";
  if (k.prior.used) {
    return std::string("the tolerance prior's evidence judged the model (no held-out error ") +
           (k.search.note.empty() ? "without the model search)" : "could compare candidates)");
  }
  if (k.model_selection) return "the significance cut chose the parameters (no held-out error)";
  return "every identifiable parameter was fitted by least squares (no held-out error judged it)";
}

std::string large_change_text(const ParameterEstimate& e, const KinematicFit& k) {
  return fmt::format(
      "{} moved {} from nominal (beyond {} mm / {} mrad){}{}: {}; check the move if the device "
      "should not have it",
      e.name, change_text(e.value - e.nominal, e.unit), kLargeChangeLength * 1e3,
      kLargeChangeAngle * 1e3, e.determined ? "" : ", not determined by these data",
      e.max_correlation_with.empty()
          ? std::string()
          : fmt::format(", correlated {:+.2f} with {}", e.max_correlation, e.max_correlation_with),
      evidence_text(k));
}

std::string change_text(double change, ParameterUnit unit) {
  if (unit == ParameterUnit::kAngle && std::abs(change) >= 0.1)
    return fmt::format("{:.4g} deg", change * 180 / M_PI);
  const DisplayUnit u = display_unit(unit);
  return fmt::format("{:.4g} {}", change * u.scale, u.unit);
}

std::string repeatability_text(double repeatability) {
  if (std::isnan(repeatability)) return "no repeatability: no pose was left and reached again";
  return fmt::format("repeatability {:.4f} mm RMS", repeatability * 1e3);
}

}  // namespace hapticcal::detail
