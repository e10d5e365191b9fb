// simulate's report: the set-up, the Table 2 and 3 analogues, the outcome,
// the paper's Figs 7, 8, 9-like and 10, and the Monte Carlo figures.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "hapticcal/core/error.hpp"
#include "hapticcal/report/iso9283_report.hpp"
#include "hapticcal/report/report.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "report/figures.hpp"
#include "report/report_parts.hpp"

namespace hapticcal {
namespace {

using detail::figure;
using detail::held_table;
using detail::identified_line;
using detail::measured_points;
using detail::order_by;
using detail::transmission_figures;
using detail::truth_line;

// What a study's report shows beyond what every study has. The first trial's
// step 1 ran (its log has external encoders): sigma_e applies.
bool step_one_ran(const TrialResult& t) { return !t.full.transmissions.empty(); }
// Why a parameter has no RMSE / CRLB ("n/a" in the tables).
constexpr const char* kNoBound =
    "n/a: no Cramer-Rao bound (the trials' information about the parameter is singular)";

// simulate's outcome: the validation and trajectory errors before and after,
// the Monte Carlo summary, and why a distance measurement leaves the position
// error where it is.
Outcome study_outcome(const Scenario& sc, const StudyResult& r) {
  const TrialResult& t = r.first;
  Outcome o;
  o.usable = t.full.status == CalibrationStatus::kConverged;
  o.status = fmt::format("{} trial(s), seed {}; the first trial's calibration: {}", r.trials,
                         sc.seed, to_string(t.full.status));
  o.headline.push_back(
      fmt::format("validation ({} poses): {}", sc.validation_poses, validation_figures(sc, t)));
  if (shows_trajectory(sc, t)) {
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
  }
  if (r.trials > 1 && !r.monte_carlo.empty()) {
    std::vector<double> e;
    for (const auto& [name, m] : r.monte_carlo) {
      if (std::isfinite(m.efficiency)) e.push_back(m.efficiency);
    }
    std::sort(e.begin(), e.end());
    const size_t missing = r.monte_carlo.size() - e.size();
    const std::string without =
        missing > 0 ? fmt::format("; {} parameter(s) {}", missing, kNoBound) : std::string();
    if (!e.empty()) {
      o.headline.push_back(fmt::format(
          "Monte Carlo over {} trials: RMSE / CRLB median {:.3f} over {} parameters (range "
          "{:.3f} - {:.3f}); 1 is an efficient estimator{}",
          r.trials, e[e.size() / 2], e.size(), e.front(), e.back(), without));
    } else {
      o.headline.push_back(
          fmt::format("Monte Carlo over {} trials: RMSE / CRLB {}", r.trials, kNoBound));
    }
  }
  std::string unseen;  // held because the measurement cannot see them at all
  for (const ParameterEstimate& e : t.full.kinematics.parameters) {
    if (!e.identifiable && e.reason.starts_with("no effect"))
      unseen += (unseen.empty() ? "" : ", ") + e.name;
  }
  if (measures_distance(sc.measurement) && !unseen.empty()) {
    o.notes.push_back(fmt::format(
        "A distance from a fixed anchor does not change when the device turns about the anchor, "
        "nor with the tool's orientation: {} have no effect on it and stay at nominal, so the "
        "validation position and orientation errors keep their deviations. The distance error "
        "is what the calibration reached.",
        unseen));
  }
  return o;
}

// Tables 2 and 3 analogues (identified parameters; capstans in SI units).
void parameter_tables(const Scenario& sc, const StudyResult& r, Report& report) {
  const TrialResult& t = r.first;
  const bool paper_study = sc.paper_comparison();
  std::vector<std::vector<std::string>> t2, t3;
  auto paper = [](const std::string& name) {
    const auto p = paper_improvement_pct(name);
    return p ? fmt::format("{:.2f}", *p) : std::string("-");
  };
  // The Monte Carlo columns: of a study of several trials only.
  const bool monte_carlo = r.trials > 1;
  bool unbounded = false;  // a parameter without RMSE / CRLB: "n/a", and why under the table
  auto mc = [&](const std::string& name, bool efficiency) {
    const auto it = r.monte_carlo.find(name);
    if (it == r.monte_carlo.end()) return std::string("-");  // identified in no trial
    const double v = efficiency ? it->second.efficiency : it->second.mean_improvement_pct;
    if (std::isfinite(v)) return fmt::format("{:.3f}", v);
    if (!efficiency) return std::string("-");  // I % of a parameter without deviation
    unbounded = true;
    return std::string("n/a");
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
    if (monte_carlo) {
      cells.push_back(mc(row.name, false));
      cells.push_back(mc(row.name, true));
    }
    cells.push_back(row.paper_unit.empty() ? "-" : row.paper_unit);
    (row.capstan ? t2 : t3).push_back(cells);
  }
  auto header = [&](bool deviations) {
    std::vector<std::string> h = {"parameter", deviations ? "assigned deviation" : "assigned",
                                  deviations ? "identified deviation" : "identified", "I %"};
    if (paper_study) h.push_back("paper I %");
    if (monte_carlo) h.insert(h.end(), {"mean I %", "RMSE / CRLB"});
    h.push_back("unit");
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
  std::string notes;
  if (unbounded) notes += fmt::format("RMSE / CRLB {}. ", kNoBound);
  if (monte_carlo && !sc.keep_all) {
    notes +=
        "The trials calibrate as an owner would, with the model search (calibration: keep_all: "
        "false): a parameter it holds at nominal in some trials is estimated with a bias, so its "
        "RMSE / CRLB (the bound of the unbiased full model) may fall below 1.";
  }
  if (!notes.empty()) report.sections.push_back("<p>" + markup_escaped(notes) + "</p>\n");
}

// Fig. 7: the parallelogram joint's error.
void fig7_figures(const Scenario& sc, const TrialResult& t, Report& report) {
  for (const TransmissionFit& f : t.full.transmissions) {
    if (f.kind != TransmissionKind::kPolynomial) continue;
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
}

// Metres or radians to mm or mrad.
std::vector<double> scaled(std::vector<double> x) {
  for (double& e : x) e *= 1e3;
  return x;
}

// Fig. 8: validation errors per pose; orientation errors where the
// measurement has them (shows_orientation).
void fig8_figures(const Scenario& sc, const TrialResult& t, Report& report) {
  const auto& v = t.figures.fig8;
  // The paper's figure number in the paper's study only.
  const bool paper = sc.paper_comparison();
  FigureSpec fig8p = figure("fig8_position",
                            fmt::format("{}osition error per validation pose (against the truth)",
                                        paper ? "Fig. 8: p" : "P"),
                            "pose", "position error [mm]", {v[0], scaled(v[1]), scaled(v[2])});
  // Errors are norms, before and after orders of magnitude apart: a log axis.
  fig8p.series = {detail::before_series("before calibration", 0, 1, "linespoints"),
                  detail::after_series("after calibration", 0, 2, "linespoints")};
  use_log_y(fig8p);
  FigureSpec fig8o =
      figure("fig8_orientation",
             fmt::format("{}rientation error per validation pose (against the truth)",
                         paper ? "Fig. 8: o" : "O"),
             "pose", "orientation error [mrad]", {v[0], scaled(v[3]), scaled(v[4])});
  fig8o.series = fig8p.series;
  use_log_y(fig8o);
  report.figures.push_back(fig8p);
  if (shows_orientation(sc)) report.figures.push_back(fig8o);
}

// Fig. 9-like: every joint's transmission fit but the polynomial one's, which
// is Fig. 7.
void transmission_fit_figures(const Scenario& sc, const TrialResult& t, Report& report) {
  const Log& ident = t.figures.identification;
  for (const TransmissionFit& f : t.full.transmissions) {
    if (f.kind == TransmissionKind::kPolynomial &&
        t.figures.fig7.count(sc.nominal.links[f.joint].name))
      continue;
    std::vector<int> rows(ident.rows);
    std::iota(rows.begin(), rows.end(), 0);
    transmission_figures(f, sc.nominal.links[f.joint].name, ident, rows,
                         t.full.calibrated.links[f.joint].transmission,
                         &sc.actual.links[f.joint].transmission, report.figures);
    report.figures.pop_back();  // the residual panels belong to calibrate's report
  }
}

// Fig. 10: the trajectory.
void fig10_figures(const TrialResult& t, Report& report) {
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
}

// Monte Carlo: the I % spread and RMSE / CRLB per parameter.
void monte_carlo_figures(const Scenario& sc, const StudyResult& r, Report& report) {
  std::vector<std::string> names, bounded;
  std::vector<double> mean, half, efficiency;
  for (const auto& [name, m] : r.monte_carlo) {
    names.push_back(name);
    mean.push_back((m.improvement_p05 + m.improvement_p95) / 2);
    half.push_back((m.improvement_p95 - m.improvement_p05) / 2);
    // RMSE / CRLB of the parameters with a bound only: no point at a fake 0.
    if (!std::isfinite(m.efficiency)) continue;
    bounded.push_back(name);
    efficiency.push_back(m.efficiency);
  }
  const double n = static_cast<double>(names.size());
  FigureSpec spread =
      figure("monte_carlo_improvement",
             fmt::format("I % over {} trials: 5th to 95th percentile per parameter", r.trials),
             "parameter",
             sc.paper_comparison() ? "I [%] (paper eq. 8)"
                                   : "I [%] = 100 (1 - |identified - truth| / |nominal - truth|)",
             {mean, half});
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
  report.figures.push_back(spread);
  if (bounded.empty()) return;
  const double m_bounded = static_cast<double>(bounded.size());
  FigureSpec eff =
      figure("monte_carlo_efficiency", fmt::format("RMSE / CRLB over {} trials", r.trials),
             "parameter", "RMSE / CRLB [-]",
             {efficiency, std::vector<double>(bounded.size(), band_lo),
              std::vector<double>(bounded.size(), band_hi)});
  eff.xtics = bounded;
  eff.series = {{"RMSE / CRLB", -1, 0, "points", -1, "#0072b2", 0, 1.5, 7},
                {fmt::format("5-95 % for {} trials if efficient", r.trials), -1, 1, "lines", -1,
                 "gray40", 2, 1.5, 0},
                {"", -1, 2, "lines", -1, "gray40", 2, 1.5, 0}};
  eff.x_min = -0.5;
  eff.x_max = m_bounded - 0.5;
  eff.y_min = 0;
  report.figures.push_back(eff);
}

}  // namespace

std::string validation_figures(const Scenario& sc, const TrialResult& t) {
  std::string out = fmt::format("position RMS {:.4f} -> {:.4f} mm", t.position_rms_before * 1e3,
                                t.position_rms_after * 1e3);
  if (shows_orientation(sc)) {
    out += fmt::format(", orientation RMS {:.4f} -> {:.4f} mrad", t.orientation_rms_before * 1e3,
                       t.orientation_rms_after * 1e3);
  }
  if (measures_distance(sc.measurement)) {
    out += fmt::format(", distance RMS {:.4f} -> {:.4f} mm", t.distance_rms_before * 1e3,
                       t.distance_rms_after * 1e3);
  }
  return out;
}

std::string rotation_noise(const Scenario& sc) {
  return measures_orientation(sc.measurement)
             ? fmt::format(", sigma_r {:.4g} rad", sc.noise.sigma_orientation)
             : std::string();
}

bool shows_orientation(const Scenario& sc) {
  return measures_orientation(sc.measurement) || sc.paper_comparison();
}

bool shows_trajectory(const Scenario& sc, const TrialResult& t) {
  return sc.paper_comparison() || (measures_distance(sc.measurement) && step_one_ran(t));
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
  // sigma_e: the external encoders' noise, where the log has them (step 1 ran).
  report.sections.push_back(fmt::format(
      "<p>{} trial(s), seed {}; {} identification and {} validation poses; {}sigma_m {:.4g} m "
      "({}){}.{}</p>\n",
      r.trials, sc.seed, sc.identification_poses, sc.validation_poses,
      paper_study || step_one_ran(t) ? fmt::format("sigma_e {:.4g} rad, ", sc.noise.sigma_ext)
                                     : std::string(),
      measurement_sigma(sc), sc.sigma_m_formula, rotation_noise(sc),
      paper_study ? std::string()
                  : fmt::format(" Truth: {} transmissions, {} kinematics.",
                                sc.paper_transmissions ? "the paper's" : "the device's own",
                                sc.random.enabled() ? "randomly deviated" : "assigned")));
  parameter_tables(sc, r, report);
  report.sections.push_back(held_table(t.full.kinematics));
  report.outcome = study_outcome(sc, r);
  if (r.iso) add_iso_study_section(*sc.iso9283, *r.iso, report);

  fig7_figures(sc, t, report);
  fig8_figures(sc, t, report);
  transmission_fit_figures(sc, t, report);
  if (shows_trajectory(sc, t)) fig10_figures(t, report);
  if (r.trials > 1) monte_carlo_figures(sc, r, report);
  return report;
}

}  // namespace hapticcal
