// The report of `evaluate`: a model's errors on a log, per sample, against a
// reference model if one is given.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cmath>

#include "hapticcal/core/error.hpp"
#include "hapticcal/report/report.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "report/figures.hpp"

namespace hapticcal {
namespace {

// One per-sample figure of |error| in `unit` (scaled by 1e3 from SI), the
// model's and the reference's, on a log axis.
FigureSpec per_sample(const std::string& name, const std::string& caption,
                      const std::string& ylabel, const Eigen::VectorXd& model,
                      const Eigen::VectorXd* reference, const std::string& model_label,
                      const std::string& reference_label) {
  FigureSpec f;
  f.name = name;
  f.title = caption;
  f.xlabel = "sample";
  f.ylabel = ylabel;
  std::vector<double> sample, m, r;
  const int stride = static_cast<int>(detail::plot_stride(model.size()));
  for (int i = 0; i < model.size(); i += stride) {
    sample.push_back(i + 1);
    m.push_back(std::abs(model[i]) * 1e3);
    if (reference) r.push_back(std::abs((*reference)[i]) * 1e3);
  }
  f.columns = {sample, m};
  f.series = {detail::after_series(model_label, 0, 1)};
  if (reference) {
    f.columns.push_back(r);
    f.series.push_back(detail::before_series(reference_label, 0, 2));
  }
  f.extra = "set pointsize 0.5";
  f.x_min = 0;
  f.x_max = model.size() + 1;
  use_log_y(f, 6);  // errors orders of magnitude apart both visible
  return f;
}

// evaluate --register: the fitted base (and tool), so that a reader can carry
// the frame over to the next log from the same tracker set-up.
std::string registration_section(const FrameFit& fit) {
  const auto pose = [](const std::array<double, 6>& p) {
    return fmt::format("x {:.3f}, y {:.3f}, z {:.3f} mm, roll {:.4f}, pitch {:.4f}, yaw {:.4f} deg",
                       p[0] * 1e3, p[1] * 1e3, p[2] * 1e3, p[3] * 180 / M_PI, p[4] * 180 / M_PI,
                       p[5] * 180 / M_PI);
  };
  std::string html = fmt::format(
      "<p>Registered (<code>--register {}</code>): the measurement frame was fitted on this log "
      "before the errors were computed (closed form, then Levenberg-Marquardt). Fitted base "
      "pose: {}.",
      to_string(fit.what), pose(fit.base));
  if (fit.tool) html += fmt::format(" Fitted tool: {}.", pose(*fit.tool));
  return html + "</p>\n";
}

}  // namespace

Report evaluation_report(const DeviceModel& model, const std::string& model_path, const Log& log,
                         const Evaluation& ev, const Evaluation* reference,
                         const std::string& reference_path, const std::vector<std::string>& lines) {
  Report report;
  report.title =
      fmt::format("hapticcal evaluate: {} on {}", model.name, detail::display_path(log.origin));
  report.outcome.status = "evaluated";
  report.outcome.headline = lines;
  report.sections.push_back(fmt::format(
      "<p>Model {} ({}, {} joints); log {} ({} rows){}. Errors are the model's prediction minus "
      "the measurement, in mm and mrad; results.json holds them in metres and radians.</p>\n",
      markup_escaped(model_path), markup_escaped(model.name), model.dof(),
      markup_escaped(log.origin), ev.n,
      reference ? fmt::format("; reference model {}", markup_escaped(reference_path))
                : std::string()));
  if (ev.registered) report.sections.push_back(registration_section(*ev.registered));
  if (!ev.labels.empty()) {
    std::vector<std::vector<std::string>> rows;
    const bool points = ev.mean_point_deviation.has_value();
    for (const auto& l : ev.labels) {
      rows.push_back({l.name, std::to_string(l.samples),
                      fmt::format("{:.4f}", l.mean_deviation * 1e3),
                      fmt::format("{:.4f}", l.rms_deviation * 1e3),
                      l.rms_known_error ? fmt::format("{:.4f}", *l.rms_known_error * 1e3) : "-"});
    }
    report.sections.push_back(fmt::format("<h2>Fixture {} </h2>\n", points ? "points" : "planes") +
                              html_table({"label", "samples",
                                          points ? "mean spread about its centre [mm]"
                                                 : "mean distance from its plane [mm]",
                                          points ? "RMS spread [mm]" : "RMS distance [mm]",
                                          "RMS error against its known position [mm]"},
                                         rows));
  }
  const std::string mine = "this model", theirs_name = "reference model";
  const Evaluation* ref = reference;
  if (ev.fixture_error.size() > 0) {
    const bool points = ev.mean_point_deviation.has_value();
    report.figures.push_back(per_sample(
        "fixture_errors_per_sample",
        points ? "Distance of each sample's tool point from its fixture point's centre"
               : "Distance of each sample's tool point from its plane",
        points ? "|p_model - centre| [mm]" : "|n . (p_model - centre)| [mm]", ev.fixture_error,
        ref && ref->fixture_error.size() ? &ref->fixture_error : nullptr, mine, theirs_name));
  }
  for (const Evaluation::FigureErrors& f : ev.figures) {
    const Evaluation::FigureErrors* theirs = ref ? ref->figure(f.figure.name) : nullptr;
    report.figures.push_back(per_sample(fmt::format("{}_errors_per_sample", f.figure.name),
                                        f.figure.title, f.figure.axis, f.error,
                                        theirs ? &theirs->error : nullptr, mine, theirs_name));
  }
  return report;
}

Report tree_evaluation_report(const DeviceModel& tree, const std::string& model_path,
                              const std::vector<std::string>& tips, const std::vector<Log>& parts,
                              const std::vector<Evaluation>& evaluations,
                              const std::vector<const Evaluation*>& references,
                              const std::string& reference_path, const std::string& log_origin,
                              const std::vector<std::string>& lines) {
  Report report;
  for (size_t c = 0; c < tips.size(); ++c) {
    Report tip = evaluation_report(tree, model_path, parts[c], evaluations[c], references[c],
                                   reference_path, {});
    if (c == 0) {
      report.title = fmt::format("hapticcal evaluate: {}, a tree of {} tips ({}), on {}", tree.name,
                                 tips.size(), fmt::join(tips, ", "), log_origin);
      report.outcome = tip.outcome;
      report.outcome.headline = lines;
    }
    report.sections.push_back(
        fmt::format("<h2>Tip {} ({} of {})</h2>\n", markup_escaped(tips[c]), c + 1, tips.size()));
    report.sections.insert(report.sections.end(), tip.sections.begin(), tip.sections.end());
    for (FigureSpec& f : tip.figures) {
      f.name += "_" + std::to_string(c + 1);
      f.title = tips[c] + ": " + f.title;
      report.figures.push_back(std::move(f));
    }
  }
  return report;
}

}  // namespace hapticcal
