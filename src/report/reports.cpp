// The reports of calibrate, simulate and force.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "hapticcal/report/report.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "report/figures.hpp"

namespace hapticcal {
namespace {

std::string f4(double v) { return fmt::format("{:.4f}", v); }

FigureSpec figure(std::string name, std::string title, std::string xlabel, std::string ylabel,
                  std::vector<std::vector<double>> columns = {}) {
  FigureSpec f;
  f.name = std::move(name);
  f.title = std::move(title);
  f.xlabel = std::move(xlabel);
  f.ylabel = std::move(ylabel);
  f.columns = std::move(columns);
  return f;
}

// One look per role in every figure (Okabe-Ito colours, told apart in grey
// print too): measurements grey points, identified a solid colour, truth black
// dashed; before / nominal vermillion, after / calibrated blue.
Series measured_points(std::string label, int x, int y) {
  return {std::move(label), x, y, "points", -1, "gray50", 0, 0, 7};
}
Series identified_line(std::string label, int x, int y) {
  return {std::move(label), x, y, "lines", -1, "#0072b2", 1, 2.5, 0};
}
Series truth_line(std::string label, int x, int y) {
  return {std::move(label), x, y, "lines", -1, "black", 2, 1.5, 0};
}
// Rows sorted by x, so that model curves draw as lines.
std::vector<int> order_by(const std::vector<double>& x) {
  std::vector<int> idx(x.size());
  std::iota(idx.begin(), idx.end(), 0);
  std::sort(idx.begin(), idx.end(), [&](int a, int b) { return x[a] < x[b]; });
  return idx;
}

// Transmission fit (Fig. 9-like) and its residuals for one joint, in mrad against deg.
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

std::string parameter_table(const KinematicFit& k) {
  std::vector<std::vector<std::string>> rows;
  for (const ParameterEstimate& e : k.parameters) {
    if (!e.identifiable) continue;
    const DisplayUnit u = display_unit(e.unit);
    rows.push_back({e.name, f4(e.nominal * u.scale), f4(e.value * u.scale),
                    f4((e.value - e.nominal) * u.scale), f4(e.sd * u.scale), u.unit,
                    fmt::format("{:.3f}", e.max_correlation), e.max_correlation_with});
  }
  return "<h2>Identified kinematic parameters</h2>\n" +
         html_table({"parameter", "nominal", "identified", "deviation", "sd", "unit",
                     "largest correlation", "with"},
                    rows);
}

std::string held_table(const KinematicFit& k) {
  std::vector<std::vector<std::string>> rows;
  for (const ParameterEstimate& e : k.parameters) {
    if (!e.identifiable) rows.push_back({e.name, e.reason});
  }
  return "<h2>Held at nominal (identifiability analysis and model selection)</h2>\n" +
         html_table({"parameter", "why"}, rows);
}

// The model selection's path as a table and a figure: training and
// cross-validated RMS by the number of parameters fitted.
void selection_section(const KinematicFit& k, Report& report) {
  if (!k.model_selection || k.selection_path.empty()) return;
  std::vector<std::vector<std::string>> rows;
  std::vector<double> n, train, cv;
  for (const SelectionStep& step : k.selection_path) {
    rows.push_back(
        {std::to_string(step.parameters), fmt::format("{:.4f}", step.rms * 1e3),
         std::isfinite(step.cv_rms) ? fmt::format("{:.4f}", step.cv_rms * 1e3) : std::string("-"),
         step.removed, step.removed.empty() ? "" : fmt::format("{:.2f}", step.removed_t),
         step.removed.empty() ? "" : fmt::format("{:.2f}", step.threshold),
         step.parameters == k.identified ? "kept" : ""});
    if (!std::isfinite(step.cv_rms)) continue;
    n.push_back(step.parameters);
    train.push_back(step.rms * 1e3);
    cv.push_back(step.cv_rms * 1e3);
  }
  report.sections.push_back(
      fmt::format("<h2>Model selection</h2>\n<p>Backward elimination from the {} identifiable "
                  "parameters: the one whose change from nominal is the fewest standard deviations "
                  "(t) is held next, while t is below the family-wise (Bonferroni) 5 % threshold "
                  "of Student's t for the parameters then fitted. {} kept. RMS [mm] of the "
                  "linearised fits ({}); cross-validated over {} folds of poses (for the record: "
                  "the rule does not use it). <code>--keep-all</code> fits all of them.</p>\n",
                  k.structurally_identified, k.identified,
                  k.type == MeasurementType::kPose ? "position rows" : "the measurement's error",
                  k.selection_folds) +
      html_table({"parameters", "training RMS [mm]", "cross-validated RMS [mm]", "held next",
                  "its t [sd]", "threshold [sd]", ""},
                 rows));
  if (n.size() < 2) return;
  FigureSpec f = figure("model_selection", "Training and cross-validated RMS along the selection",
                        "parameters fitted", "RMS error [mm]", {n, train, cv});
  f.series = {{"training (all poses)", 0, 1, "linespoints", -1, "#d55e00", 0, 1.5, 7},
              {"cross-validated (held-out poses)", 0, 2, "linespoints", -1, "#0072b2", 0, 1.5, 5}};
  use_log_y(f);
  f.extra = fmt::format("set arrow from {0},graph 0 to {0},graph 1 nohead dt 2", k.identified);
  report.figures.push_back(f);
}

// simulate's outcome: the validation and trajectory errors before and after,
// the Monte Carlo summary, and why a distance measurement leaves the position
// error where it is.
Outcome study_outcome(const Scenario& sc, const StudyResult& r) {
  const TrialResult& t = r.first;
  Outcome o;
  o.usable = t.full.status == CalibrationStatus::kConverged;
  o.status = fmt::format("{} trial(s), seed {}; the first trial's calibration: {}", r.trials,
                         sc.seed, to_string(t.full.status));
  std::string validation = fmt::format(
      "validation ({} poses): position RMS {:.4f} -> {:.4f} mm, orientation RMS {:.4f} -> "
      "{:.4f} mrad",
      sc.validation_poses, t.position_rms_before * 1e3, t.position_rms_after * 1e3,
      t.orientation_rms_before * 1e3, t.orientation_rms_after * 1e3);
  if (sc.measurement == MeasurementType::kDistance) {
    validation += fmt::format(", distance RMS {:.4f} -> {:.4f} mm", t.distance_rms_before * 1e3,
                              t.distance_rms_after * 1e3);
  }
  o.headline.push_back(validation);
  o.headline.push_back(fmt::format(
      "trajectory ({:.0f} s at {:.0f} Hz): distance RMS {:.4f} mm nominal, {:.4f} mm full "
      "calibration ({:.1f} %), {:.4f} mm kinematic-only ({:.1f} %){}",
      sc.trajectory_seconds, sc.trajectory_rate_hz, t.trajectory_rms_before * 1e3,
      t.trajectory_rms_full * 1e3,
      rms_improvement_pct(t.trajectory_rms_full, t.trajectory_rms_before),
      t.trajectory_rms_kinematic * 1e3,
      rms_improvement_pct(t.trajectory_rms_kinematic, t.trajectory_rms_before),
      sc.paper_comparison()
          ? fmt::format("; the paper measured {:.1f} % and {:.1f} %", kPaperImprovementFullPct,
                        kPaperImprovementKinematicOnlyPct)
          : ""));
  if (r.trials > 1 && !r.monte_carlo.empty()) {
    std::vector<double> e;
    for (const auto& [name, m] : r.monte_carlo) {
      if (std::isfinite(m.efficiency)) e.push_back(m.efficiency);
    }
    std::sort(e.begin(), e.end());
    if (!e.empty()) {
      o.headline.push_back(fmt::format(
          "Monte Carlo over {} trials: RMSE / CRLB median {:.3f} over {} parameters (range "
          "{:.3f} - {:.3f}); 1 is an efficient estimator",
          r.trials, e[e.size() / 2], e.size(), e.front(), e.back()));
    }
  }
  std::string unseen;  // held because the measurement cannot see them at all
  for (const ParameterEstimate& e : t.full.kinematics.parameters) {
    if (!e.identifiable && e.reason.starts_with("no effect"))
      unseen += (unseen.empty() ? "" : ", ") + e.name;
  }
  if (sc.measurement == MeasurementType::kDistance && !unseen.empty()) {
    o.notes.push_back(fmt::format(
        "A distance from a fixed anchor does not change when the device turns about the anchor, "
        "nor with the tool's orientation: {} have no effect on it and stay at nominal, so the "
        "validation position and orientation errors keep their deviations. The distance error "
        "is what the calibration reached.",
        unseen));
  }
  return o;
}

}  // namespace

namespace detail {

FigureSpec correlation_figure(const KinematicFit& k) {
  FigureSpec heat =
      figure("correlation", "Correlation of the identified parameters", "parameter", "parameter");
  // In the order of the parameter table (identifiable parameters in model order).
  std::vector<int> order;
  for (const ParameterEstimate& e : k.parameters) {
    const auto at = std::find(k.identified_names.begin(), k.identified_names.end(), e.name);
    if (e.identifiable && at != k.identified_names.end())
      order.push_back(static_cast<int>(at - k.identified_names.begin()));
  }
  for (int i = 0; i < static_cast<int>(k.identified_names.size()); ++i) {
    if (std::find(order.begin(), order.end(), i) == order.end()) order.push_back(i);
  }
  const auto n = static_cast<Eigen::Index>(order.size());
  if (k.correlation.rows() != n || k.correlation.cols() != n) {  // no names to order by
    order.resize(k.correlation.rows());
    std::iota(order.begin(), order.end(), 0);
  }
  heat.matrix.resize(static_cast<Eigen::Index>(order.size()),
                     static_cast<Eigen::Index>(order.size()));
  for (Eigen::Index r = 0; r < heat.matrix.rows(); ++r) {
    if (order[r] < static_cast<int>(k.identified_names.size()))
      heat.xtics.push_back(k.identified_names[order[r]]);
    for (Eigen::Index c = 0; c < heat.matrix.cols(); ++c)
      heat.matrix(r, c) = k.correlation(order[r], order[c]);
  }
  if (static_cast<Eigen::Index>(heat.xtics.size()) != heat.matrix.rows()) heat.xtics.clear();
  heat.cblabel = "correlation coefficient [-]";
  return heat;
}

}  // namespace detail

namespace {

// The outcome block's lines for a suspect fit, one a reason.
std::vector<std::string> suspect_lines(const KinematicFit& k) {
  std::vector<std::string> out;
  for (const std::string& reason : k.suspect.reasons)
    out.push_back("warning: suspect fit: " + reason);
  return out;
}

// The poses the outlier test flagged: their lines, residual and weight.
std::string outlier_table(const RobustFit& robust) {
  std::vector<std::vector<std::string>> rows;
  for (const OutlierPose& o : robust.outliers) {
    std::string lines = o.lines.size() == 1 ? "line " : "lines ";
    for (size_t i = 0; i < o.lines.size(); ++i)
      lines += (i ? ", " : "") + std::to_string(o.lines[i]);
    rows.push_back({lines, fmt::format("{:.4f}", o.residual * 1e3),
                    fmt::format("{:.1f}", o.statistic), fmt::format("{:.3g}", o.weight)});
  }
  return fmt::format(
             "<h2>Outliers</h2>\n<p>Poses whose residual exceeds {:.2f} robust sds (robust sd "
             "{:.4g} mm of one component: 1.4826 MAD; Bonferroni over the poses); {}.</p>\n",
             robust.threshold, robust.robust_sd * 1e3,
             robust.reweighted ? fmt::format("down-weighted by the {} loss", to_string(robust.loss))
                               : std::string("not down-weighted")) +
         html_table({"log lines", "residual [mm]", "residual [robust sd]", "weight [1]"}, rows);
}

}  // namespace

Report calibration_report(const CalibrationResult& result, const DeviceModel& nominal,
                          const Log& log, const std::vector<PointDistance>& point_distances,
                          const std::vector<KnownPoint>& known_points) {
  const KinematicFit& k = result.kinematics;
  Report report;
  report.title =
      fmt::format("hapticcal calibrate: {} on {}", nominal.name, detail::display_path(log.origin));
  // The outcome first, with what the terminal prints: status, RMS before and
  // after, held-out error, solver, step 1, notes and warnings.
  const bool usable = result.status == CalibrationStatus::kConverged;
  Outcome& o = report.outcome;
  o.usable = usable;
  o.status = fmt::format("{} ({}){}", to_string(result.status), result.status_reason,
                         usable ? ""
                                : ": this calibration is not usable; no new calibrated.yaml was "
                                  "written");
  const std::string measured = traits(k.type).name;
  o.headline.push_back(fmt::format("RMS {} error: {:.4f} mm before, {:.4f} mm after (training)",
                                   measured, k.rms_before * 1e3, k.rms_after * 1e3));
  o.headline.push_back(
      std::isfinite(k.cv_rms)
          ? fmt::format("held-out RMS ({}-fold cross-validation by pose): {:.4f} mm", k.cv_folds,
                        k.cv_rms * 1e3)
          : fmt::format("held-out RMS (cross-validation): {}",
                        k.cv_note.empty() ? std::string("not computed") : k.cv_note));
  o.headline.push_back(fmt::format(
      "{} parameters identified{}; condition number {:.4g}; sd from sigma = {:.4g} mm ({}); "
      "solver: {} after {} iterations",
      k.identified,
      k.model_selection
          ? fmt::format(" ({} identifiable; model selection)", k.structurally_identified)
          : "",
      k.condition_number, k.sigma * 1e3, k.sigma_given ? "given" : "residual estimate",
      k.converged ? "converged" : "NOT converged", k.iterations));
  for (const TransmissionFit& t : result.transmissions) {
    o.headline.push_back(fmt::format(
        "step 1, {} {} ({} samples): RMS of ext - q - c {:.4f} mrad before, {:.4f} mrad after{}; "
        "encoder zero c {:.6f} +- {:.6f} mrad",
        nominal.links[t.joint].name, t.type, t.n, t.rms_before * 1e3, t.rms_after * 1e3,
        t.converged ? "" : " (did not converge)", t.offset * 1e3, t.offset_sd * 1e3));
  }
  for (const ParameterEstimate& e : k.parameters) {
    if (!e.large_change) continue;
    const DisplayUnit u = display_unit(e.unit);
    o.notes.push_back(fmt::format(
        "warning: {} moved {:.4g} {} from nominal (flagged beyond {} mm / {} mrad): plausible for "
        "a base pose measured in an unknown frame; for a link, check the model and the log",
        e.name, (e.value - e.nominal) * u.scale, u.unit, kLargeChangeLength * 1e3,
        kLargeChangeAngle * 1e3));
  }
  for (const std::string& line : suspect_lines(k)) o.notes.push_back(line);
  for (const std::string& note : result.notes)
    o.notes.push_back(note.rfind("warning: ", 0) == 0 ? note : "note: " + note);
  const std::string repeats =
      k.rows > k.poses ? fmt::format(" ({} poses, repeats averaged; repeatability {:.4f} mm RMS)",
                                     k.poses, k.repeatability * 1e3)
                       : "";
  report.sections.push_back(fmt::format(
      "<p>{} rows{}, {} measurements; observability O1 {:.4g}, O4 {:.4g} (angles scaled by "
      "{:.3f} m).{}</p>\n",
      k.rows, repeats, traits(k.type).name, k.observability.O1, k.observability.O4, k.length_scale,
      k.rank_deficient ? " <b>Rank-deficient: see the held parameters.</b>" : ""));
  // Step 1 in the terminal's units (the paper's Table 2), the encoder zero c last.
  std::vector<std::vector<std::string>> tx;
  for (const TransmissionFit& t : result.transmissions) {
    for (size_t i = 0; i < t.names.size(); ++i) {
      const DisplayUnit u = display_unit(t, static_cast<int>(i));
      tx.push_back({t.names[i], fmt::format("{:.6f}", t.nominal[i] * u.scale),
                    fmt::format("{:.6f}", t.value[i] * u.scale),
                    fmt::format("{:.6f}", t.sd[i] * u.scale), u.unit.empty() ? "-" : u.unit});
    }
    tx.push_back({nominal.links[t.joint].name + ".c (encoder zero, nuisance)", "-",
                  fmt::format("{:.6f}", t.offset * 1e3), fmt::format("{:.6f}", t.offset_sd * 1e3),
                  "mrad"});
  }
  if (!tx.empty()) {
    report.sections.push_back("<h2>Transmissions (step 1)</h2>\n" +
                              html_table({"parameter", "nominal", "identified", "sd", "unit"}, tx));
  }
  if (!k.robust.outliers.empty()) report.sections.push_back(outlier_table(k.robust));
  report.sections.push_back(parameter_table(k));
  report.sections.push_back(held_table(k));
  selection_section(k, report);

  const size_t pose_stride = detail::plot_stride(result.rows.size());
  std::vector<int> plotted_rows;
  for (size_t i = 0; i < result.rows.size(); i += pose_stride)
    plotted_rows.push_back(result.rows[i]);
  for (const TransmissionFit& t : result.transmissions) {
    transmission_figures(t, nominal.links[t.joint].name, log, plotted_rows,
                         result.calibrated.links[t.joint].transmission, nullptr, report.figures);
  }
  // The calibrated model leaves the instrument's zero out: its errors are of
  // the readings less the zero (what rms_after measures).
  Log corrected = log;
  if (const double zero = identified_instrument_zero(k); zero != 0) {
    corrected.distance.array() -= zero;
  }
  const Evaluation before = evaluate(nominal, log, point_distances, known_points),
                   after = evaluate(result.calibrated, corrected, point_distances, known_points);
  const bool fixture = is_fixture(k.type);
  const bool position = k.type != MeasurementType::kDistance && !fixture;
  const Eigen::VectorXd& error_before = fixture    ? before.fixture_error
                                        : position ? before.position_error
                                                   : before.distance_error;
  const Eigen::VectorXd& error_after = fixture    ? after.fixture_error
                                       : position ? after.position_error
                                                  : after.distance_error;
  std::vector<double> sample, eb, ea;
  const int row_stride = static_cast<int>(detail::plot_stride(log.rows));
  for (int r = 0; r < log.rows; r += row_stride) {
    sample.push_back(r + 1);
    eb.push_back(std::abs(error_before[r]) * 1e3);
    ea.push_back(std::abs(error_after[r]) * 1e3);
  }
  const char* title = k.type == MeasurementType::kPoint
                          ? "Distance of each sample's tool point from its fixture point's centre"
                      : k.type == MeasurementType::kPlane
                          ? "Distance of each sample's tool point from its plane"
                      : position ? "Position error per sample, before and after calibration"
                                 : "Distance error per sample, before and after calibration";
  // Magnitudes on a log axis: the calibrated model's errors are orders of
  // magnitude below the nominal one's.
  const char* axis = k.type == MeasurementType::kPoint   ? "|p_model - centre| [mm]"
                     : k.type == MeasurementType::kPlane ? "|n . (p_model - centre)| [mm]"
                     : position                          ? "|p_model - p_measured| [mm]"
                                                         : "|delta_model - delta_measured| [mm]";
  FigureSpec residuals = figure("errors_per_sample", title, "sample", axis, {sample, eb, ea});
  residuals.series = {detail::before_series("nominal model", 0, 1),
                      detail::after_series("calibrated model", 0, 2)};
  residuals.extra = "set pointsize 0.5";
  residuals.x_min = 0;
  residuals.x_max = log.rows + 1;
  use_log_y(residuals, 6);
  report.figures.push_back(residuals);
  if (k.correlation.size() > 0) report.figures.push_back(detail::correlation_figure(k));
  return report;
}

Report study_report(const Scenario& sc, const StudyResult& r) {
  const TrialResult& t = r.first;
  Report report;
  const bool paper_study = sc.paper_comparison();
  report.title = paper_study
                     ? fmt::format("hapticcal simulate: the paper's study on {}", sc.nominal.name)
                     : fmt::format("hapticcal simulate: {} measured by {}", sc.nominal.name,
                                   traits(sc.measurement).plural);
  // The set-up; the validation and trajectory errors are in the outcome block.
  report.sections.push_back(fmt::format(
      "<p>{} trial(s), seed {}; {} identification and {} validation poses; sigma_e {:.4g} rad, "
      "sigma_m {:.4g} m ({}).{}</p>\n",
      r.trials, sc.seed, sc.identification_poses, sc.validation_poses, sc.noise.sigma_ext,
      measurement_sigma(sc), sc.sigma_m_formula,
      paper_study ? std::string()
                  : fmt::format(" Truth: {} transmissions, {} kinematics.",
                                sc.paper_transmissions ? "the paper's" : "the device's own",
                                sc.random.enabled() ? "randomly deviated" : "assigned")));
  // Tables 2 and 3 analogues (identified parameters; capstans in SI units).
  std::vector<std::vector<std::string>> t2, t3;
  auto paper = [](const std::string& name) {
    const auto p = paper_improvement_pct(name);
    return p ? fmt::format("{:.2f}", *p) : std::string("-");
  };
  auto mc = [&](const std::string& name, bool efficiency) {
    const auto it = r.monte_carlo.find(name);
    if (r.trials < 2 || it == r.monte_carlo.end()) return std::string("-");
    return fmt::format("{:.3f}",
                       efficiency ? it->second.efficiency : it->second.mean_improvement_pct);
  };
  for (const StudyRow& row : study_rows(sc, t.full)) {
    if (!row.held.empty()) continue;
    const std::string ip =
        std::isfinite(row.improvement_pct) ? fmt::format("{:.2f}", row.improvement_pct) : "-";
    // The terminal's units: Table 2 values as the paper prints them, Table 3
    // deviations from nominal in mm and mrad.
    const double shift = row.capstan ? 0 : row.nominal;
    auto value = [&](double v) {
      return fmt::format("{:.{}f}", (v - shift) * row.paper_scale, row.capstan ? 6 : 4);
    };
    std::vector<std::string> cells = {row.name, value(row.assigned), value(row.identified), ip};
    if (paper_study) cells.push_back(paper(row.name));  // the paper's columns: its study only
    cells.push_back(mc(row.name, false));
    cells.push_back(mc(row.name, true));
    cells.push_back(row.paper_unit.empty() ? "-" : row.paper_unit);
    (row.capstan ? t2 : t3).push_back(cells);
  }
  auto header = [&](bool deviations) {
    std::vector<std::string> h = {"parameter", deviations ? "assigned deviation" : "assigned",
                                  deviations ? "identified deviation" : "identified", "I %"};
    if (paper_study) h.push_back("paper I %");
    h.insert(h.end(), {"mean I %", "RMSE / CRLB", "unit"});
    return h;
  };
  if (!t2.empty()) {
    report.sections.push_back(
        (paper_study ? "<h2>Table 2 analogue: capstan drives (assigned = truth)</h2>\n"
                     : "<h2>Transmission parameters: assigned (truth) and identified</h2>\n") +
        html_table(header(false), t2));
  }
  report.sections.push_back(
      (paper_study
           ? "<h2>Table 3 analogue: kinematic deviations from nominal</h2>\n"
           : "<h2>Kinematic deviations from nominal (assigned = truth - nominal): assigned and "
             "identified</h2>\n") +
      html_table(header(true), t3));
  report.sections.push_back(held_table(t.full.kinematics));
  report.outcome = study_outcome(sc, r);

  // Fig. 7: the parallelogram joint's error.
  const Log& ident = t.figures.identification;
  for (const TransmissionFit& f : t.full.transmissions) {
    if (f.type != "polynomial") continue;
    const std::string link = sc.nominal.links[f.joint].name;
    const auto& c = t.figures.fig7.at(link);
    std::vector<int> idx = order_by(c[0]);
    std::vector<double> q, m, id, tr;
    for (int i : idx) {
      q.push_back(c[0][i] * 180 / M_PI);
      m.push_back(c[1][i] * 1e3);
      id.push_back(c[2][i] * 1e3);
      tr.push_back(c[3][i] * 1e3);
    }
    FigureSpec fig7 =
        figure("fig7_" + link,
               fmt::format("Fig. 7: {} (capstan + parallelogram) transmission error", link),
               "reading q [deg]", "dtheta [mrad]", {q, m, id, tr});
    fig7.series = {measured_points("measurements", 0, 1),
                   identified_line("identified polynomial", 0, 2), truth_line("truth", 0, 3)};
    report.figures.push_back(fig7);
  }
  // Fig. 8: validation errors per pose.
  const auto& v = t.figures.fig8;
  auto scaled = [](std::vector<double> x) {
    for (double& e : x) e *= 1e3;
    return x;
  };
  FigureSpec fig8p = figure("fig8_position", "Fig. 8: position error per validation pose", "pose",
                            "position error [mm]", {v[0], scaled(v[1]), scaled(v[2])});
  // Errors are norms, before and after orders of magnitude apart: a log axis.
  fig8p.series = {detail::before_series("before calibration", 0, 1, "linespoints"),
                  detail::after_series("after calibration", 0, 2, "linespoints")};
  use_log_y(fig8p);
  FigureSpec fig8o = figure("fig8_orientation", "Fig. 8: orientation error per validation pose",
                            "pose", "orientation error [mrad]", {v[0], scaled(v[3]), scaled(v[4])});
  fig8o.series = fig8p.series;
  use_log_y(fig8o);
  report.figures.push_back(fig8p);
  report.figures.push_back(fig8o);
  // Fig. 9-like: every joint's transmission fit but the polynomial one's, which
  // is Fig. 7.
  for (const TransmissionFit& f : t.full.transmissions) {
    if (f.type == "polynomial" && t.figures.fig7.count(sc.nominal.links[f.joint].name)) continue;
    std::vector<int> rows(ident.rows);
    std::iota(rows.begin(), rows.end(), 0);
    transmission_figures(f, sc.nominal.links[f.joint].name, ident, rows,
                         t.full.calibrated.links[f.joint].transmission,
                         &sc.actual.links[f.joint].transmission, report.figures);
    report.figures.pop_back();  // the residual panels belong to calibrate's report
  }
  // Fig. 10: the trajectory.
  const auto& tr = t.figures.fig10;
  FigureSpec fig10 =
      figure("fig10_trajectory", "Fig. 10: distance error over the trajectory", "time [s]",
             "distance error [mm]", {tr[0], scaled(tr[2]), scaled(tr[3]), scaled(tr[4])});
  fig10.series = {{"nominal", 0, 1, "lines", -1, "#d55e00", 0, 1.5, 0},
                  {"full calibration", 0, 2, "lines", -1, "#0072b2", 0, 1.5, 0},
                  {"kinematic-only calibration", 0, 3, "lines", -1, "#009e73", 2, 1.5, 0}};
  report.figures.push_back(fig10);
  // Its full calibration on an axis of its own: microns beside millimetres.
  FigureSpec fig10_full = figure("fig10_trajectory_full",
                                 "Fig. 10 (detail): the full calibration's distance error alone",
                                 "time [s]", "distance error [mm]", {tr[0], scaled(tr[3])});
  fig10_full.series = {{"full calibration", 0, 1, "lines", -1, "#0072b2", 0, 1.5, 0}};
  report.figures.push_back(fig10_full);
  // Monte Carlo.
  if (r.trials > 1) {
    std::vector<std::string> names;
    std::vector<double> mean, half, efficiency;
    for (const auto& [name, m] : r.monte_carlo) {
      names.push_back(name);
      mean.push_back((m.improvement_p05 + m.improvement_p95) / 2);
      half.push_back((m.improvement_p95 - m.improvement_p05) / 2);
      efficiency.push_back(m.efficiency);
    }
    const double n = static_cast<double>(names.size());
    FigureSpec spread =
        figure("monte_carlo_improvement",
               fmt::format("I % over {} trials: 5th to 95th percentile per parameter", r.trials),
               "parameter", "I [%] (paper eq. 8)", {mean, half});
    spread.xtics = names;
    spread.series = {{"5-95 % of trials", -1, 0, "yerrorbars", 1, "#0072b2", 0, 1.5, 7}};
    // Every bar inside the frame, with a margin.
    double low = 0, high = 100;
    for (size_t i = 0; i < mean.size(); ++i) {
      low = std::min(low, mean[i] - half[i]);
      high = std::max(high, mean[i] + half[i]);
    }
    const double margin = 0.05 * (high - low);
    spread.x_min = -0.5;
    spread.x_max = n - 0.5;
    spread.y_min = low - margin;
    spread.y_max = high + margin;
    // What RMSE / CRLB of an efficient estimator spreads over from sampling
    // alone: n RMSE^2 / CRLB^2 ~ chi^2_n, 5th to 95th percentile.
    const double trials = r.trials;
    const double band_lo = std::sqrt(chi_square_quantile(0.05, trials) / trials);
    const double band_hi = std::sqrt(chi_square_quantile(0.95, trials) / trials);
    FigureSpec eff =
        figure("monte_carlo_efficiency", fmt::format("RMSE / CRLB over {} trials", r.trials),
               "parameter", "RMSE / CRLB [-]",
               {efficiency, std::vector<double>(names.size(), band_lo),
                std::vector<double>(names.size(), band_hi)});
    eff.xtics = names;
    eff.series = {{"RMSE / CRLB", -1, 0, "points", -1, "#0072b2", 0, 1.5, 7},
                  {fmt::format("5-95 % for {} trials if efficient", r.trials), -1, 1, "lines", -1,
                   "gray40", 2, 1.5, 0},
                  {"", -1, 2, "lines", -1, "gray40", 2, 1.5, 0}};
    eff.x_min = -0.5;
    eff.x_max = n - 0.5;
    eff.y_min = 0;
    report.figures.push_back(spread);
    report.figures.push_back(eff);
  }
  return report;
}

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
