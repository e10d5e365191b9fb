// The tables and figures that the calibrate and simulate reports share.
#include "report/report_parts.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

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

std::string held_table(const KinematicFit& k) {
  std::vector<std::vector<std::string>> rows;
  for (const ParameterEstimate& e : k.parameters) {
    if (!e.identifiable) rows.push_back({e.name, e.reason});
  }
  return "<h2>Held at nominal (identifiability analysis and model selection)</h2>\n" +
         html_table({"parameter", "why"}, rows);
}

}  // namespace hapticcal::detail
