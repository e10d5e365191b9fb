// ISO 9283's test in the reports: the plan's cube and poses (plan --iso9283),
// and a scored test laid out as the standard's report (evaluate --iso9283).
#include "hapticcal/report/iso9283_report.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>

#include "hapticcal/core/error.hpp"

namespace hapticcal {
namespace {

constexpr double kNoValue = std::numeric_limits<double>::quiet_NaN();  // gnuplot draws nothing

// A number in a table, "-" where it does not apply (fewer than two cycles).
std::string cell(double v, double scale) {
  return std::isfinite(v) ? fmt::format("{:.4f}", v * scale) : "-";
}

// The cube's twelve edges as one path (some retraced), the measuring plane's
// outline, and the five poses: columns 0-2, 3-5 and 6-8, padded with NaN
// (gnuplot draws nothing there).
FigureSpec cube_figure(const IsoCubePlan& plan) {
  static const int path[] = {0, 1, 2, 3, 0, 4, 5, 1, 5, 6, 2, 6, 7, 3, 7, 4};
  static const int plane[] = {0, 1, 6, 7, 0};
  constexpr size_t kRows = std::size(path);
  std::vector<std::vector<double>> columns(9, std::vector<double>(kRows, kNoValue));
  for (size_t r = 0; r < kRows; ++r) {
    for (int a = 0; a < 3; ++a) columns[a][r] = plan.corners[path[r]][a] * 1e3;
  }
  for (size_t r = 0; r < std::size(plane); ++r) {
    for (int a = 0; a < 3; ++a) columns[3 + a][r] = plan.corners[plane[r]][a] * 1e3;
  }
  for (size_t r = 0; r < plan.poses.size(); ++r) {
    for (int a = 0; a < 3; ++a) columns[6 + a][r] = plan.poses[r].pose.p[a] * 1e3;
  }
  FigureSpec f;
  f.name = "iso9283_cube";
  f.title = fmt::format(
      "The test cube (edge {:.1f} mm, its edges along the base frame's axes), its measuring plane "
      "C1-C2-C7-C8 and the poses P1 (centre) to P5, in the measurement frame",
      plan.size * 1e3);
  f.xlabel = "x [mm]";
  f.ylabel = "y [mm]";
  f.zlabel = "z [mm]";
  f.columns = std::move(columns);
  f.series.push_back({"cube", 0, 1, "lines", -1, "gray60", 0, 1, 0});
  f.series.back().z = 2;
  f.series.push_back({"measuring plane", 3, 4, "lines", -1, "#e69f00", 0, 1.5, 0});
  f.series.back().z = 5;
  f.series.push_back({"P1 .. P5", 6, 7, "points", -1, "#0072b2", 0, 2, 7});
  f.series.back().z = 8;
  f.extra = "set view 60, 30\nset view equal xyz";
  return f;
}

}  // namespace

Report iso_plan_report(const DeviceModel& model, const IsoCubePlan& plan) {
  Report report;
  report.title = fmt::format("hapticcal plan --iso9283: {}", model.name);
  report.outcome.status = "planned";
  report.outcome.headline.push_back(fmt::format(
      "test cube: edge {:.1f} mm about ({:.1f}, {:.1f}, {:.1f}) mm; {} cycles of P1, P5, P4, P3, "
      "P2; {}",
      plan.size * 1e3, plan.centre.x() * 1e3, plan.centre.y() * 1e3, plan.centre.z() * 1e3,
      plan.cycles,
      plan.orientation_held ? "every pose at the centre's orientation"
                            : "orientation not held (fewer than six joints)"));
  report.outcome.headline.push_back(iso_search_text(plan.search));
  std::vector<std::vector<std::string>> rows;
  for (const IsoTestPose& p : plan.poses) {
    std::string readings;
    for (int i = 0; i < p.readings.size(); ++i)
      readings += fmt::format("{}{:.4f}", i ? ", " : "", p.readings[i]);
    rows.push_back({p.label, fmt::format("{:.3f}", p.pose.p.x() * 1e3),
                    fmt::format("{:.3f}", p.pose.p.y() * 1e3),
                    fmt::format("{:.3f}", p.pose.p.z() * 1e3), readings});
  }
  report.sections.push_back(
      "<h2>Test poses</h2>\n" +
      html_table({"pose", "x [mm]", "y [mm]", "z [mm]", "joint targets [rad]"}, rows));
  report.figures.push_back(cube_figure(plan));
  return report;
}

void add_iso_section(const IsoCriteria& model, const IsoCriteria* reference,
                     const std::string& conditions, Report& report) {
  std::string html = "<h2>ISO 9283: pose and distance characteristics</h2>\n";
  html += fmt::format(
      "<p>Test conditions: {}. Commanded: the model's pose at each pose's mean readings; "
      "AP and AD are the model's accuracy, RP and RD the robot's repeatability.</p>\n",
      markup_escaped(conditions.empty() ? "not stated (evaluate --conditions)" : conditions));
  const bool orientation = !model.poses.empty() && model.poses.front().orientation;
  std::vector<std::string> header = {"pose", "n", "AP [mm]"};
  if (reference) header.push_back("AP reference [mm]");
  for (const char* h : {"AP_x [mm]", "AP_y [mm]", "AP_z [mm]", "RP [mm]"}) header.push_back(h);
  if (orientation) {
    for (const char* h :
         {"AP_a [mrad]", "AP_b [mrad]", "AP_c [mrad]", "RP_a [mrad]", "RP_b [mrad]", "RP_c [mrad]"})
      header.push_back(h);
  }
  std::vector<std::vector<std::string>> rows;
  for (size_t k = 0; k < model.poses.size(); ++k) {
    const IsoPoseCriteria& p = model.poses[k];
    std::vector<std::string> row = {p.label, std::to_string(p.cycles), cell(p.ap, 1e3)};
    if (reference) row.push_back(cell(reference->poses[k].ap, 1e3));
    for (double v : {p.ap_xyz.x(), p.ap_xyz.y(), p.ap_xyz.z(), p.rp}) row.push_back(cell(v, 1e3));
    if (orientation) {
      for (int a = 0; a < 3; ++a) row.push_back(cell(p.ap_abc[a], 1e3));
      for (int a = 0; a < 3; ++a) row.push_back(cell(p.rp_abc[a], 1e3));
    }
    rows.push_back(row);
  }
  html += html_table(header, rows);
  std::vector<std::string> distance_header = {"distance", "n", "D_c [mm]", "AD [mm]"};
  if (reference) distance_header.push_back("AD reference [mm]");
  distance_header.push_back("RD [mm]");
  rows.clear();
  for (size_t k = 0; k < model.distances.size(); ++k) {
    const IsoDistanceCriteria& d = model.distances[k];
    std::vector<std::string> row = {d.from + " - " + d.to, std::to_string(d.cycles),
                                    cell(d.commanded, 1e3), cell(d.ad, 1e3)};
    if (reference) row.push_back(cell(reference->distances[k].ad, 1e3));
    row.push_back(cell(d.rd, 1e3));
    rows.push_back(row);
  }
  html += html_table(distance_header, rows);
  report.sections.push_back(html);
}

namespace {

// Each trial's simulated AP of the calibrated model against its prediction, a
// point a pose and trial, and the line where they are equal.
FigureSpec predicted_ap_figure(const IsoStudy& study) {
  std::vector<double> predicted, simulated;
  double top = 0;
  for (const IsoTrial& t : study.trials) {
    for (size_t k = 0; k < t.predicted_ap.size(); ++k) {
      predicted.push_back(t.predicted_ap[k] * 1e3);
      simulated.push_back(t.calibrated.poses[k].ap * 1e3);
      if (std::isfinite(predicted.back())) top = std::max(top, predicted.back());
      if (std::isfinite(simulated.back())) top = std::max(top, simulated.back());
    }
  }
  FigureSpec f;
  f.name = "iso9283_ap";
  f.title =
      "ISO 9283 pose accuracy AP of the calibrated model, simulated (a point a pose and trial) "
      "against the calibration's prediction; the line: equal";
  f.xlabel = "predicted AP [mm]";
  f.ylabel = "simulated AP [mm]";
  std::vector<double> line_x = {0, top * 1.05}, line_y = line_x;
  line_x.resize(predicted.size(), kNoValue);
  line_y.resize(predicted.size(), kNoValue);
  f.columns = {predicted, simulated, line_x, line_y};
  f.series.push_back({"a pose of a trial", 0, 1, "points", -1, "#0072b2", 0, 1, 7});
  f.series.push_back({"simulated = predicted", 2, 3, "lines", -1, "gray40", 2, 1, 0});
  f.x_min = 0;
  f.y_min = 0;
  return f;
}

}  // namespace

void add_iso_study_section(const IsoSimulation& iso, const IsoStudy& study, Report& report) {
  const size_t trials = study.trials.size();
  report.outcome.headline.push_back(fmt::format(
      "ISO 9283 AP (RMS over {} trial(s) and {} poses): nominal {} mm, calibrated {} mm, "
      "predicted from the calibration's covariance {} mm",
      trials, study.poses.size(), cell(study.ap_nominal, 1e3), cell(study.ap_calibrated, 1e3),
      cell(study.ap_predicted, 1e3)));
  std::string html = "<h2>ISO 9283 test after calibration (simulated)</h2>\n";
  html += fmt::format(
      "<p>After each trial's calibration the robot (the truth) runs {} cycles of the test at the "
      "nominal model's cube (edge {:.1f} mm about ({:.1f}, {:.1f}, {:.1f}) mm): at each pose's "
      "joint targets it attains the truth's tool point, scattered by {:.4f} mm per coordinate. "
      "The nominal and the calibrated model command it (their tool points at the same targets). "
      "AP: RMS over the {} trial(s); predicted: sqrt(trace(G C G<sup>T</sup>) + 3 s<sup>2</sup> / "
      "n) from each calibration's covariance C (G the tool point's derivatives by the "
      "parameters). RP: the mean over the trials, the robot's, the same for both models.</p>\n",
      iso.plan.cycles, iso.plan.size * 1e3, iso.plan.centre.x() * 1e3, iso.plan.centre.y() * 1e3,
      iso.plan.centre.z() * 1e3, iso.scatter * 1e3, trials);
  std::vector<std::vector<std::string>> rows;
  const auto row = [&](const std::string& label, const std::string& at, double nominal,
                       double calibrated, double predicted, double rp) {
    rows.push_back({label, at, cell(nominal, 1e3), cell(calibrated, 1e3), cell(predicted, 1e3),
                    std::isfinite(calibrated) && predicted > 0
                        ? fmt::format("{:.2f}", calibrated / predicted)
                        : "-",
                    cell(rp, 1e3)});
  };
  for (const IsoPoseSummary& p : study.poses) {
    row(p.label,
        fmt::format("{:.1f}, {:.1f}, {:.1f}", p.point.x() * 1e3, p.point.y() * 1e3,
                    p.point.z() * 1e3),
        p.ap_nominal, p.ap_calibrated, p.ap_predicted, p.rp);
  }
  row("all", "", study.ap_nominal, study.ap_calibrated, study.ap_predicted, kNoValue);
  html += html_table({"pose", "position [mm]", "AP nominal [mm]", "AP calibrated [mm]",
                      "AP predicted [mm]", "calibrated / predicted", "RP [mm]"},
                     rows);
  for (const std::string& note : study.notes) {
    html += "<p>" + markup_escaped(note) + "</p>\n";
    report.outcome.notes.push_back(note);
  }
  report.sections.push_back(html);
  report.figures.push_back(cube_figure(iso.plan));
  report.figures.push_back(predicted_ap_figure(study));
}

}  // namespace hapticcal
