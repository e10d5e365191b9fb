// `hapticcal simulate`: the paper's simulation study (its Tables 2-3 and
// Figs 8 and 10), or a study of any device and measurement from a scenario.
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <thread>
#include <vector>

#include "commands.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/core/output_set.hpp"
#include "hapticcal/jobs/simulate_job.hpp"
#include "hapticcal/model_io/model_source.hpp"
#include "hapticcal/report/report.hpp"
#include "hapticcal/report/results_json.hpp"
#include "hapticcal/study/paper.hpp"
#include "hapticcal/study/study.hpp"
#include "number_options.hpp"
#include "output_summary.hpp"
#include "terminal.hpp"

namespace hapticcal::cli {
namespace {

// The validation (Fig. 8) and trajectory (Fig. 10) lines; the figures' numbers
// and the paper's percentages in the paper's study only.
void print_validation_and_trajectory(const hapticcal::Scenario& sc,
                                     const hapticcal::TrialResult& t) {
  const bool paper = sc.paper_comparison();
  fmt::print("Validation ({} poses{}): {}\n", sc.validation_poses, paper ? ", Fig. 8" : "",
             hapticcal::validation_figures(sc, t));
  if (!hapticcal::shows_trajectory(sc, t)) return;
  fmt::print(
      "Trajectory ({:.0f} s at {:.0f} Hz{}): distance RMS {:.4f} mm nominal, {:.4f} mm "
      "full ({:.1f} %), {:.4f} mm kinematic-only ({:.1f} %){}\n",
      sc.trajectory_seconds, sc.trajectory_rate_hz, paper ? ", Fig. 10" : "",
      t.trajectory_rms_before * 1e3, t.trajectory_rms_full * 1e3,
      hapticcal::rms_improvement_pct(t.trajectory_rms_full, t.trajectory_rms_before),
      t.trajectory_rms_kinematic * 1e3,
      hapticcal::rms_improvement_pct(t.trajectory_rms_kinematic, t.trajectory_rms_before),
      paper ? fmt::format("; paper: {:.1f} % and {:.1f} %", hapticcal::kPaperImprovementFullPct,
                          hapticcal::kPaperImprovementKinematicOnlyPct)
            : "");
}

// A percentage, or "-" where it is undefined (a parameter without deviation).
std::string pct(double v, int width) {
  return std::isfinite(v) ? fmt::format("{:{}.2f}", v, width) : fmt::format("{:>{}}", "-", width);
}

// Beyond the paper's study: the truth as chosen, identified against assigned
// deviations with their error in Cramer-Rao standard deviations; no paper columns.
void print_general_study(const hapticcal::Scenario& sc, const hapticcal::StudyResult& r) {
  const hapticcal::TrialResult& t = r.first;
  std::string kinematics =
      sc.random.enabled()
          ? fmt::format("random deviations (sd {} m lengths, {} rad angles, seed {})",
                        sc.random.lengths, sc.random.angles, sc.random.seed)
          : (sc.paper_device ? std::string("the paper's Table 3 deviations") : "nominal");
  for (const auto& [name, v] : sc.deviations) kinematics += fmt::format(", {} {:+g}", name, v);
  fmt::print("Truth: {} transmissions; kinematics {}. Measurement: {} (sigma_m {:.3g} m{})\n",
             sc.paper_transmissions ? "the paper's (Table 2)" : "the device's own", kinematics,
             hapticcal::traits(sc.measurement).plural, hapticcal::measurement_sigma(sc),
             hapticcal::rotation_noise(sc));
  const std::vector<hapticcal::StudyRow> rows = hapticcal::study_rows(sc, t.full);
  auto crlb = [&](const hapticcal::StudyRow& row) {
    const auto it = r.monte_carlo.find(row.name);
    if (it == r.monte_carlo.end() || !(it->second.crlb_sd > 0)) return std::string("       -");
    return fmt::format("{:8.2f}", (row.identified - row.assigned) / it->second.crlb_sd);
  };
  fmt::print(
      "Transmission parameters (assigned = truth; ratio error, radii in mm, angles in deg)\n");
  fmt::print("  {:<20} {:>12} {:>12} {:>8} {:>8}\n", "parameter", "assigned", "identified", "I %",
             "err/CRLB");
  for (const hapticcal::StudyRow& row : rows) {
    if (!row.capstan) continue;
    fmt::print("  {:<20} {:>12.6f} {:>12.6f} {} {} {}\n", row.name, row.assigned * row.paper_scale,
               row.identified * row.paper_scale, pct(row.improvement_pct, 8), crlb(row),
               row.paper_unit);
  }
  fmt::print(
      "Kinematic parameters: deviation from nominal, assigned and identified (mm, mrad; "
      "assigned = truth - nominal)\n");
  fmt::print("  {:<20} {:>10} {:>10} {:>8} {:>8}\n", "parameter", "assigned", "identified", "I %",
             "err/CRLB");
  for (const hapticcal::StudyRow& row : rows) {
    if (row.capstan) continue;
    const double assigned = (row.assigned - row.nominal) * row.paper_scale;
    if (!row.held.empty()) {
      fmt::print("  {:<20} {:>10.4f} {:>10} {:>8} {:>8}   ({})\n", row.name, assigned, "-", "-",
                 "-", row.held);
      continue;
    }
    fmt::print("  {:<20} {:>10.4f} {:>10.4f} {} {}\n", row.name, assigned,
               (row.identified - row.nominal) * row.paper_scale, pct(row.improvement_pct, 8),
               crlb(row));
  }
  print_validation_and_trajectory(sc, t);
}

void print_study(const hapticcal::Scenario& sc, const hapticcal::StudyResult& r) {
  if (!sc.paper_comparison()) return print_general_study(sc, r);
  const hapticcal::TrialResult& t = r.first;
  const auto& mc = r.monte_carlo;
  const bool many = r.trials > 1;
  auto paper = [](const std::string& name) {
    const auto p = hapticcal::paper_improvement_pct(name);
    return p ? fmt::format("{:7.2f}", *p) : std::string("      -");
  };
  const std::vector<hapticcal::StudyRow> rows = hapticcal::study_rows(sc, t.full);
  auto monte_carlo = [&](const hapticcal::StudyRow& row) {
    if (!many) return std::string();
    const auto& m = mc.at(row.name);
    return fmt::format("  {:9.2f}  {:9.3f}", m.mean_improvement_pct, m.efficiency);
  };
  fmt::print("Table 2 analogue: capstan drives (assigned = truth; I % by paper eq. 8)\n");
  fmt::print("  {:<16} {:>12} {:>12} {:>8} {:>8}{}\n", "parameter", "assigned", "identified", "I %",
             "paper", many ? "   mean I %   RMSE/CRLB" : "");
  for (const hapticcal::StudyRow& row : rows) {
    if (!row.capstan) continue;
    fmt::print("  {:<16} {:>12.6f} {:>12.6f} {:>8.2f} {}{}{}\n", row.name,
               row.assigned * row.paper_scale, row.identified * row.paper_scale,
               row.improvement_pct, paper(row.name), monte_carlo(row),
               row.paper_unit.empty() ? "" : " " + row.paper_unit);
  }
  for (const hapticcal::TransmissionFit& f : t.full.transmissions) {
    if (f.kind != hapticcal::TransmissionKind::kPolynomial) continue;
    fmt::print("  {}: {}th-order polynomial, RMS residual {:.3g} mrad (Fig. 7: fig7_{}.csv)\n",
               sc.nominal.links[f.joint].name, f.value.size(), f.rms_after * 1e3,
               sc.nominal.links[f.joint].name);
  }
  fmt::print(
      "Table 3 analogue: kinematic deviations from nominal (assigned = truth - nominal; mm, "
      "mrad)\n");
  fmt::print("  {:<12} {:>10} {:>10} {:>8} {:>8}{}\n", "parameter", "assigned", "identified", "I %",
             "paper", many ? "   mean I %   RMSE/CRLB" : "");
  for (const hapticcal::StudyRow& row : rows) {
    if (row.capstan) continue;
    const double assigned = (row.assigned - row.nominal) * row.paper_scale;
    if (!row.held.empty()) {
      fmt::print("  {:<12} {:>10.3f} {:>10} {:>8} {:>8}   ({})\n", row.name, assigned, "-", "-",
                 "-", row.held);
      continue;
    }
    fmt::print("  {:<12} {:>10.3f} {:>10.3f} {:>8.2f} {}{}\n", row.name, assigned,
               (row.identified - row.nominal) * row.paper_scale, row.improvement_pct,
               paper(row.name), monte_carlo(row));
  }
  print_validation_and_trajectory(sc, t);
}

// The ISO 9283 tests after the calibrations (a scenario's iso9283): each
// pose's AP over the trials, simulated against predicted.
void print_iso_study(const hapticcal::IsoSimulation& iso, const hapticcal::IsoStudy& study) {
  fmt::print(
      "ISO 9283 test after each calibration: cube {:.1f} mm, {} cycles, attained positions "
      "scattered {:.4f} mm per coordinate; AP as RMS over {} trial(s) (iso9283.csv)\n",
      iso.plan.size * 1e3, iso.plan.cycles, iso.scatter * 1e3, study.trials.size());
  fmt::print("  {:<5} {:>10} {:>12} {:>12} {:>10} {:>9}\n", "pose", "AP nominal", "calibrated",
             "predicted", "ratio", "RP");
  const auto mm = [](double v) {
    return std::isfinite(v) ? fmt::format("{:.4f}", v * 1e3) : std::string("-");
  };
  const auto line = [&](const std::string& label, double nominal, double calibrated,
                        double predicted, double rp) {
    fmt::print("  {:<5} {:>10} {:>12} {:>12} {:>10} {:>9}  mm\n", label, mm(nominal),
               mm(calibrated), mm(predicted),
               std::isfinite(calibrated) && predicted > 0
                   ? fmt::format("{:.2f}", calibrated / predicted)
                   : std::string("-"),
               mm(rp));
  };
  for (const hapticcal::IsoPoseSummary& p : study.poses)
    line(p.label, p.ap_nominal, p.ap_calibrated, p.ap_predicted, p.rp);
  line("all", study.ap_nominal, study.ap_calibrated, study.ap_predicted, NAN);
  fmt::print(
      "  predicted: from each calibration's covariance and the scatter's mean; ratio: calibrated "
      "/ predicted; RP: the robot's (the same for both models)\n");
  for (const std::string& note : study.notes) fmt::print("  {}\n", note);
}
}  // namespace

CLI::App* add_simulate_command(CLI::App& app, SimulateOptions& o) {
  auto* simulate = app.add_subcommand(
      "simulate",
      "Run the paper's simulation study (main job), or one on any device and measurement");
  o.bound.bind(simulate, hapticcal::simulate_options());
  simulate->footer(
      "Examples:\n"
      "  hapticcal simulate --trials 20 --seed 7\n"
      "  hapticcal simulate --scenario data/scenarios/touch-hand-guided.yaml --out touch-session");
  return simulate;
}

int run_simulate(const SimulateOptions& o) {
  hapticcal::SimulateRequest request;
  o.bound.apply(request);
  const std::string& out = request.out;
  bool bar = false;
  request.started = [&](const hapticcal::Scenario& sc, int threads) {
    if (sc.session) {
      fmt::print("hapticcal simulate: a hand-guided session, seed {}, device {}\n", sc.seed,
                 sc.device_path);
    } else {
      fmt::print("hapticcal simulate: {} trial(s), seed {}, {} thread(s), device {}\n", sc.trials,
                 sc.seed, threads, sc.device_path);
    }
    bar = (sc.trials > 1 || sc.session) && isatty(2);
  };
  request.progress = [&](int k, int n) {
    if (!bar) return;
    const int width = 40, filled = width * k / n;
    hapticcal::cli::say(stderr, "\r[{}{}] {}/{}", std::string(filled, '#'),
                        std::string(width - filled, ' '), k, n);
    if (k == n) hapticcal::cli::say(stderr, "\n");
  };
  const hapticcal::SimulateJob job = hapticcal::run_simulate_job(request);
  if (job.session) {
    for (const std::string& line : job.session->lines) fmt::print("{}\n", line);
    fmt::print("{}", report_said(job.figures, job.report_note, out));
    fmt::print("{}", hapticcal::cli::output_summary(*job.out, out));
    return 0;
  }
  print_study(job.scenario, job.result);
  if (job.result.iso) print_iso_study(*job.scenario.iso9283, *job.result.iso);
  fmt::print("{}", report_said(job.figures, job.report_note, out));
  fmt::print("{}", hapticcal::cli::output_summary(*job.out, out));
  return 0;
}

}  // namespace hapticcal::cli
