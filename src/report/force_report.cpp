// force's report: the Fig. 12 analogue of the virtual wall, and its outcome.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "hapticcal/report/report.hpp"
#include "report/figures.hpp"
#include "report/report_parts.hpp"

namespace hapticcal {
namespace {

using detail::figure;
using detail::truth_line;

}  // namespace

Report force_report(const ForceRun& nominal, const ForceRun& calibrated) {
  Report report;
  report.title = "hapticcal force: virtual wall with closed-loop impedance control";
  // Fig. 12 as two figures: the wall force Fz, and the transverse force |Fx, Fy|
  // of either model on a log axis (the result: orders of magnitude below Fz).
  std::vector<double> t, fdz, fz_nominal, fz_calibrated, ft_nominal, ft_calibrated;
  const size_t samples = std::min(nominal.t.size(), calibrated.t.size());
  const size_t stride = detail::plot_stride(samples, 5);
  for (size_t k = 0; k < samples; k += stride) {
    t.push_back(nominal.t[k]);
    fdz.push_back(nominal.desired[k][2]);
    fz_nominal.push_back(nominal.measured[k][2]);
    fz_calibrated.push_back(calibrated.measured[k][2]);
    ft_nominal.push_back(std::hypot(nominal.measured[k][0], nominal.measured[k][1]));
    ft_calibrated.push_back(std::hypot(calibrated.measured[k][0], calibrated.measured[k][1]));
  }
  FigureSpec normal =
      figure("fig12_normal", "Fig. 12: virtual wall, the force normal to the wall (handle frame)",
             "time [s]", "Fz [N]", {t, fdz, fz_nominal, fz_calibrated});
  // The desired force dashed on top of the calibrated model's, which follows it.
  normal.series = {detail::before_series("nominal model", 0, 2, "lines"),
                   detail::after_series("calibrated model", 0, 3, "lines"),
                   truth_line("desired", 0, 1)};
  normal.series[1].width = 3;
  // A wall pushes: Fz >= 0 but for an overshoot, which the axis would show.
  normal.y_min = 0;
  for (const auto* column : {&fdz, &fz_nominal, &fz_calibrated}) {
    for (double v : *column) normal.y_min = std::min(normal.y_min, v);
  }
  report.figures.push_back(normal);
  FigureSpec transverse = figure(
      "fig12_transverse",
      "Fig. 12: virtual wall, the transverse force |Fx, Fy| (handle frame), nominal vs calibrated",
      "time [s]", "|Fx, Fy| [N]", {t, ft_nominal, ft_calibrated});
  transverse.series = {detail::before_series("nominal model", 0, 1, "lines"),
                       detail::after_series("calibrated model", 0, 2, "lines")};
  use_log_y(transverse, 4);
  report.figures.push_back(transverse);
  return report;
}

Outcome force_outcome(const ForceStudy& study) {
  const ForceScenario& sc = study.scenario;
  const ForceRun &before = study.nominal, &after = study.calibrated;
  Outcome o;
  o.status = "done";
  o.headline.push_back(fmt::format(
      "transverse force (|Fx, Fy|) RMS: {:.4f} N with the nominal model, {:.4f} N with the "
      "calibrated one ({:.1f} % less)",
      before.transverse_rms, after.transverse_rms, study.reduction_pct));
  o.headline.push_back(
      fmt::format("at the end: Fz {:.4f} N desired, {:.4f} N nominal, {:.4f} N "
                  "calibrated",
                  before.desired.back()[2], before.measured.back()[2], after.measured.back()[2]));
  std::string posture;
  for (int i = 0; i < sc.posture.size(); ++i)
    posture += fmt::format("{}{:.4g}", i ? ", " : "", sc.posture[i]);
  o.headline.push_back(fmt::format(
      "virtual wall K = {} N/m moved {} mm along the handle's z in {} s, held {} s, at {} Hz; "
      "gain G = {} (stable for |G| < {:.4f}); {}; posture q = [{}] rad{}",
      sc.stiffness, sc.travel * 1e3, sc.move_seconds, sc.hold_seconds, sc.rate_hz, sc.gain,
      study.stable_gain_limit,
      sc.locked_joint >= 0 ? fmt::format("joint {} locked", sc.locked_joint + 1)
                           : "no joint locked",
      posture, study.default_posture ? " (the default posture)" : ""));
  return o;
}

}  // namespace hapticcal
