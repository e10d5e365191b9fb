// calibrate's report: the outcome the terminal prints, the transmission,
// parameter, held and model-selection tables, and the figures of the fit.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/tree.hpp"
#include "hapticcal/report/calibration_lines.hpp"
#include "hapticcal/report/report.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "report/figures.hpp"
#include "report/report_parts.hpp"

namespace hapticcal {
namespace {

using detail::figure;
using detail::held_table;
using detail::transmission_figures;

std::string f4(double v) { return fmt::format("{:.4f}", v); }

// The terminal's table (calibration_lines): nominal and identified in mm or
// deg, deviation and sd in mm or mrad (detail::parameter_units).
std::string parameter_table(const KinematicFit& k, const DeviceModel& nominal) {
  std::vector<std::vector<std::string>> rows[2];  // determined, not
  for (const ParameterEstimate& e : k.parameters) {
    if (!e.identifiable) continue;
    const detail::ParameterUnits u = detail::parameter_units(e, nominal);
    std::vector<std::string> row{e.name,
                                 f4(e.nominal * u.value.scale),
                                 f4(e.value * u.value.scale),
                                 u.value.unit,
                                 f4((e.value - e.nominal) * u.change.scale),
                                 f4(e.sd * u.change.scale),
                                 u.change.unit,
                                 fmt::format("{:.3f}", e.max_correlation),
                                 e.max_correlation_with};
    if (!e.determined) row.push_back(detail::undetermined_text(e, nominal));
    rows[e.determined ? 0 : 1].push_back(std::move(row));
  }
  std::vector<std::string> header{"parameter", "nominal", "identified", "unit",
                                  "deviation", "sd",      "unit",       "largest correlation",
                                  "with"};
  std::string html = "<h2>Identified kinematic parameters</h2>\n" + html_table(header, rows[0]);
  if (rows[1].empty()) return html;
  header.push_back("why not determined");
  return html +
         fmt::format(
             "<h2>Fitted, not determined by these data</h2>\n<p>Their sd is above their "
             "tolerance, or they are correlated beyond {} with another: the data do not "
             "tell their values apart.</p>\n",
             kUndeterminedCorrelation) +
         html_table(header, rows[1]);
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
                  traits(k.type).rotation ? "position rows" : "the measurement's error",
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

// A candidate of the model search in words: "geometry + compliance, zero fitted".
std::string candidate_words(const SearchCandidate& c) {
  std::string out = "geometry";
  for (const std::string& f : c.families) out += " + " + f;
  if (c.zero) out += " + instrument zero";
  return out;
}

// The model search: every candidate's held-out RMS with its standard error,
// the one kept, the nominal's yardstick, and what each family bought (its best
// candidate against the geometry's best).
void search_section(const ModelSearch& s, Report& report) {
  if (s.candidates.empty()) return;
  std::vector<int> order;
  for (int i = 0; i < static_cast<int>(s.candidates.size()); ++i) order.push_back(i);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    const double x = s.candidates[a].cv_rms, y = s.candidates[b].cv_rms;
    return std::isfinite(x) && (!std::isfinite(y) || x < y);
  });
  double geometry = std::numeric_limits<double>::infinity();
  for (const SearchCandidate& c : s.candidates) {
    if (c.families.empty() && std::isfinite(c.cv_rms)) geometry = std::min(geometry, c.cv_rms);
  }
  std::vector<std::vector<std::string>> rows;
  std::vector<double> x, rms, se, kept;
  std::vector<std::string> tics;
  for (int i : order) {
    const SearchCandidate& c = s.candidates[i];
    const bool finite = std::isfinite(c.cv_rms);
    rows.push_back({candidate_words(c), to_string(c.estimator), finite ? f4(c.cv_rms * 1e3) : "-",
                    finite ? f4(c.se * 1e3) : "-", fmt::format("{:.1f}", c.parameters),
                    finite && std::isfinite(geometry) && !c.families.empty()
                        ? fmt::format("{:+.1f} %", (c.cv_rms / geometry - 1) * 100)
                        : "",
                    i == s.kept       ? "kept"
                    : !c.allowed      ? "reference"
                    : !c.usable       ? "worse than nominal"
                    : !c.note.empty() ? c.note
                                      : ""});
    if (!finite) continue;
    x.push_back(static_cast<double>(x.size()));
    rms.push_back(c.cv_rms * 1e3);
    se.push_back(c.se * 1e3);
    kept.push_back(i == s.kept ? c.cv_rms * 1e3 : std::numeric_limits<double>::quiet_NaN());
    tics.push_back(fmt::format("{}{}", i == s.kept ? "* " : "", candidate_words(c)) + " / " +
                   to_string(c.estimator));
  }
  report.sections.push_back(
      fmt::format("<h2>Model search</h2>\n<p>{} candidate models, each scored by its held-out "
                  "RMS [mm]: the whole estimator re-run on each fold's training {}s and its error "
                  "on the fold's own ({} folds, {} shuffles, seed {}, over {} {}s). Kept: the "
                  "model with the fewest joint-error families (then the instrument's zero "
                  "held, then the fewest parameters) within one standard error of the lowest. "
                  "The nominal model with its {} fitted: {} mm held out. \"vs geometry\": what "
                  "a family bought against the geometry's best.</p>\n",
                  s.candidates.size(), s.unit, s.folds, s.repeats, s.seed, s.units, s.unit,
                  s.nominal_fitted.empty() ? "nothing" : s.nominal_fitted,
                  std::isfinite(s.nominal_rms) ? f4(s.nominal_rms * 1e3) : "-") +
      html_table(
          {"model", "estimator", "held-out RMS [mm]", "+- [mm]", "parameters", "vs geometry", ""},
          rows));
  if (x.empty()) return;
  FigureSpec f = figure("model_search", "Held-out RMS of each candidate model (* kept)",
                        "candidate model", "held-out RMS [mm]", {x, rms, se, kept});
  f.xtics = tics;
  f.series = {{"held-out RMS +- 1 se", 0, 1, "yerrorbars", 2, "#0072b2", 0, 1.5, 7},
              {"kept", 0, 3, "points", -1, "#d55e00", 0, 2.5, 6}};
  f.y_min = 0;
  f.x_min = -0.5;
  f.x_max = static_cast<double>(x.size()) - 0.5;
  if (std::isfinite(s.nominal_rms) && s.nominal_rms * 1e3 < 3 * rms.back()) {
    f.extra = fmt::format(
        "set arrow from graph 0, first {0} to graph 1, first {0} nohead dt 2 "
        "lc rgb 'black'\nset label 'nominal' at graph 0.01, first {0} offset 0,0.6",
        s.nominal_rms * 1e3);
  }
  report.figures.push_back(f);
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

// The kinematic fit's lines of the outcome box.
void kinematic_headlines(const KinematicFit& k, const std::string& measured, Outcome& o) {
  o.headline.push_back(fmt::format("RMS {} error: {:.4f} mm before, {:.4f} mm after (training)",
                                   measured, k.rms_before * 1e3, k.rms_after * 1e3));
  o.headline.push_back(
      std::isfinite(k.cv_rms)
          ? fmt::format("held-out RMS ({}-fold cross-validation by pose): {:.4f} mm", k.cv_folds,
                        k.cv_rms * 1e3)
          : fmt::format("held-out RMS (cross-validation): {}",
                        k.cv_note.empty() ? std::string("not computed") : k.cv_note));
  const auto undetermined = std::count_if(k.parameters.begin(), k.parameters.end(),
                                          [](const auto& e) { return !e.determined; });
  o.headline.push_back(fmt::format(
      "{} parameters identified{}{}; condition number {:.4g}; sd from sigma = {:.4g} mm ({}); "
      "solver: {} after {} iterations",
      k.identified - undetermined,
      undetermined > 0 ? fmt::format(" ({} more fitted, not determined)", undetermined) : "",
      k.model_selection
          ? fmt::format(" ({} identifiable; model selection)", k.structurally_identified)
          : "",
      k.condition_number, k.sigma * 1e3, k.sigma_given ? "given" : "residual estimate",
      k.converged ? "converged" : "NOT converged", k.iterations));
}

// The outcome first, with what the terminal prints: status, RMS before and
// after, held-out error, solver, step 1, notes and warnings.
Outcome calibration_outcome(const CalibrationResult& result, const DeviceModel& nominal) {
  const KinematicFit& k = result.kinematics;
  const bool usable = result.status == CalibrationStatus::kConverged;
  Outcome o;
  o.usable = usable;
  o.status = fmt::format(
      "{} ({}){}", to_string(result.status), result.status_reason,
      usable ? "" : ": this calibration is not usable; no new calibrated.yaml was written");
  const std::string measured = traits(k.type).name;
  if (result.step_one_only) {
    o.headline.push_back("step 1 alone: the log has external encoders and no measurements");
  } else {
    kinematic_headlines(k, measured, o);
    for (const std::string& line : tip_rms_lines(k, nominal)) o.headline.push_back("  " + line);
    if (const std::string line = geometry_model_line(result); !line.empty())
      o.headline.push_back(line);
  }
  for (const TransmissionFit& t : result.transmissions) {
    o.headline.push_back(fmt::format(
        "step 1, {} {} ({} samples, {}): RMS of ext - q - c {:.4f} mrad before, {:.4f} mrad "
        "after, {:.4f} mrad on left-out samples{}{}; encoder zero c {:.6f} +- {:.6f} mrad",
        nominal.links[t.joint].name, t.type, t.n, t.model_choice, t.rms_before * 1e3,
        t.rms_after * 1e3, t.held_out_rms * 1e3, t.flagged ? " (FLAGGED)" : "",
        t.converged ? "" : " (did not converge)", t.offset * 1e3, t.offset_sd * 1e3));
  }
  for (const ParameterEstimate& e : k.parameters)
    if (e.large_change) o.notes.push_back("warning: " + detail::large_change_text(e, k));
  for (const std::string& line : suspect_lines(k)) o.notes.push_back(line);
  for (const std::string& note : result.notes)
    o.notes.push_back(note.rfind("warning: ", 0) == 0 ? note : "note: " + note);
  return o;
}

// Step 1 in the terminal's units (the paper's Table 2), the encoder zero c last.
void transmission_section(const CalibrationResult& result, const DeviceModel& nominal,
                          Report& report) {
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
}

// The measurement's error per sample, before and after calibration.
FigureSpec errors_per_sample(const KinematicFit& k, const Log& log, const Evaluation& before,
                             const Evaluation& after) {
  const MeasurementTraits& kind = traits(k.type);
  const Eigen::VectorXd& error_before = sample_errors(before, k.type);
  const Eigen::VectorXd& error_after = sample_errors(after, k.type);
  std::vector<double> sample, eb, ea;
  const int row_stride = static_cast<int>(detail::plot_stride(log.rows));
  for (int r = 0; r < log.rows; r += row_stride) {
    sample.push_back(r + 1);
    eb.push_back(std::abs(error_before[r]) * 1e3);
    ea.push_back(std::abs(error_after[r]) * 1e3);
  }
  // Magnitudes on a log axis: the calibrated model's errors are orders of
  // magnitude below the nominal one's.
  const char* title = kind.error_title;
  const char* axis = kind.error_axis;
  FigureSpec residuals = figure("errors_per_sample", title, "sample", axis, {sample, eb, ea});
  residuals.series = {detail::before_series("nominal model", 0, 1),
                      detail::after_series("calibrated model", 0, 2)};
  residuals.extra = "set pointsize 0.5";
  residuals.x_min = 0;
  residuals.x_max = log.rows + 1;
  use_log_y(residuals, 6);
  return residuals;
}

// The summary as the terminal printed it (calibration_lines), folded.
std::string terminal_section(const CalibrationResult& result, const DeviceModel& nominal) {
  std::string terminal;
  for (const std::string& line : calibration_lines(result, nominal)) terminal += line + "\n";
  return "<details><summary>The summary as the terminal printed it</summary>\n<pre>" +
         markup_escaped(terminal) + "</pre></details>\n";
}

// A log of external encoders only: step 1's tables and figures.
void step_one_report(const CalibrationResult& result, const DeviceModel& nominal, const Log& log,
                     Report& report) {
  transmission_section(result, nominal, report);
  std::vector<int> plotted_rows;
  const size_t stride = detail::plot_stride(result.rows.size());
  for (size_t i = 0; i < result.rows.size(); i += stride) plotted_rows.push_back(result.rows[i]);
  for (const TransmissionFit& t : result.transmissions) {
    transmission_figures(t, nominal.links[t.joint].name, log, plotted_rows,
                         without_trailing_harmonic(result.calibrated.links[t.joint].transmission),
                         nullptr, report.figures);
  }
  report.sections.push_back(terminal_section(result, nominal));
}

}  // namespace

// Two streams' clocks: the estimate and the residual against the offset.
void clock_section(const ClockEstimate& c, const std::string& model, Report& report) {
  report.sections.push_back(fmt::format(
      "<h2>Clocks</h2>\n<p>Device time = tracker time + offset{}. Offset {:.4f} ms &plusmn; "
      "{:.4f} ms{}; the coarse search (the tool point's speed in both streams, correlated over "
      "&plusmn;{:g} s) found {:.1f} ms (correlation {:.3f}); {} clock step(s){}. {} of {} tracker "
      "samples fall within the device's stream; {} in its gaps and {} of the fastest were left "
      "out; {} used {}.</p>\n",
      c.drift_fitted ? " + drift &times; (tracker time &minus; its first stamp)" : "",
      1e3 * c.clock.offset, 1e3 * c.offset_sd,
      c.drift_fitted ? fmt::format(", drift {:.3f} ppm &plusmn; {:.3f} ppm", 1e6 * c.clock.drift,
                                   1e6 * c.drift_sd)
                     : std::string(),
      c.search_range, 1e3 * c.coarse_offset, c.coarse_correlation, c.iterations,
      c.converged ? "" : " (<b>not settled</b>)", c.overlapping, c.tracker_rows, c.dropped_gap,
      c.dropped_speed, model == "calibrated model" ? "the fit" : "the score", c.fit_samples));
  if (c.curve.size() < 2) return;
  std::vector<double> offset, rms;
  for (const auto& [o, r] : c.curve) {
    offset.push_back(1e3 * o);
    rms.push_back(1e3 * r);
  }
  FigureSpec f = figure("clock_offset", "Residual of the " + model + " against the offset",
                        "clock offset [ms]", "RMS position residual [mm]", {offset, rms});
  f.series = {{model + ", tracker samples", 0, 1, "linespoints", -1, "#0072b2", 0, 1.5, 7}};
  f.y_min = 0;
  f.extra =
      fmt::format("set arrow from {0},graph 0 to {0},graph 1 nohead dt 2", 1e3 * c.clock.offset);
  report.figures.push_back(f);
}

Report calibration_report(const CalibrationResult& result, const DeviceModel& nominal,
                          const Log& log, const std::vector<PointDistance>& point_distances,
                          const std::vector<KnownPoint>& known_points) {
  const KinematicFit& k = result.kinematics;
  Report report;
  report.title =
      fmt::format("hapticcal calibrate: {} on {}", nominal.name, detail::display_path(log.origin));
  report.outcome = calibration_outcome(result, nominal);
  if (result.step_one_only) {
    step_one_report(result, nominal, log, report);
    return report;
  }
  const std::string repeats = k.rows > k.poses
                                  ? fmt::format(" ({}, repeats averaged; {})",
                                                samples_text(k.poses, nominal.tips(), "pose"),
                                                detail::repeatability_text(k.repeatability))
                                  : "";
  report.sections.push_back(
      fmt::format("<p>{}{}, {} measurements; observability O1 {:.4g}, O4 {:.4g} (angles scaled by "
                  "{:.3f} m).{}</p>\n",
                  samples_text(k.rows, nominal.tips(), "row"), repeats, traits(k.type).name,
                  k.observability.O1, k.observability.O4, k.length_scale,
                  k.rank_deficient ? " <b>Rank-deficient: see the held parameters.</b>" : ""));
  transmission_section(result, nominal, report);
  if (!k.robust.outliers.empty()) report.sections.push_back(outlier_table(k.robust));
  report.sections.push_back(parameter_table(k, nominal));
  report.sections.push_back(held_table(k));
  selection_section(k, report);
  search_section(k.search, report);
  if (result.clock) clock_section(*result.clock, "calibrated model", report);

  const size_t pose_stride = detail::plot_stride(result.rows.size());
  std::vector<int> plotted_rows;
  for (size_t i = 0; i < result.rows.size(); i += pose_stride)
    plotted_rows.push_back(result.rows[i]);
  for (const TransmissionFit& t : result.transmissions) {
    transmission_figures(t, nominal.links[t.joint].name, log, plotted_rows,
                         without_trailing_harmonic(result.calibrated.links[t.joint].transmission),
                         nullptr, report.figures);
  }
  // The calibrated model leaves the instrument's zero out: its errors are of
  // the readings less the zero (what rms_after measures).
  Log corrected = log;
  if (const double zero = identified_instrument_zero(k); zero != 0) {
    corrected.distance.array() -= zero;
  }
  const Evaluation before = evaluate(nominal, log, point_distances, known_points),
                   after = evaluate(result.calibrated, corrected, point_distances, known_points);
  report.figures.push_back(errors_per_sample(k, log, before, after));
  if (k.correlation.size() > 0) report.figures.push_back(detail::correlation_figure(k));
  // Where the calibration's poses were: their tool points through the calibrated model
  // (a quarter of the other figures' points: each is drawn twice, in 3-D).
  std::vector<int> pose_rows;
  const size_t stride = detail::plot_stride(4 * result.rows.size());
  for (size_t i = 0; i < result.rows.size(); i += stride) pose_rows.push_back(result.rows[i]);
  Eigen::MatrixXd readings(static_cast<Eigen::Index>(pose_rows.size()), log.q.cols());
  for (size_t i = 0; i < pose_rows.size(); ++i)
    readings.row(static_cast<Eigen::Index>(i)) = log.q.row(pose_rows[i]);
  if (readings.rows() > 0 && readings.cols() == result.calibrated.dof()) {
    report.figures.push_back(detail::poses_figure(
        result.calibrated, readings,
        fmt::format("The {} in the workspace: the tool point{} through the "
                    "calibrated model, in the {} frame{}",
                    samples_text(k.poses, nominal.tips(), "calibration pose"),
                    nominal.tree() ? "s (every tip)" : "",
                    traits(k.type).fixture ? "model's base" : "measurement",
                    readings.rows() < static_cast<Eigen::Index>(result.rows.size())
                        ? fmt::format(" ({} of {} rows shown)", readings.rows(), result.rows.size())
                        : ""),
        "tool point of a pose", false));
  }
  // The summary the terminal printed, from the same function (calibration_lines).
  report.sections.push_back(terminal_section(result, nominal));
  return report;
}

}  // namespace hapticcal
