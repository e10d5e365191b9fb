// hapticcal command-line tool: argument parsing and printing over the library.
// Exit codes: 0 success; 2 bad input (file, log or argument); 3 the calibration
// ran but did not converge or is unusable (no calibrated model replaced); 1
// anything else, I/O errors included, with the system's reason.
#include <fmt/format.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>

#include "hapticcal/identification/identification.hpp"
#include "hapticcal/io/error.hpp"
#include "hapticcal/io/fixture_io.hpp"
#include "hapticcal/io/io.hpp"
#include "hapticcal/io/model_source.hpp"
#include "hapticcal/io/output_set.hpp"
#include "hapticcal/io/urdf.hpp"
#include "hapticcal/report/calibration_outputs.hpp"
#include "hapticcal/report/report.hpp"
#include "hapticcal/study/control.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "hapticcal/study/study.hpp"
#include "number_options.hpp"
#include "output_summary.hpp"
#include "plan_command.hpp"
#include "terminal.hpp"

namespace {

using hapticcal::cli::whole_number;
using hapticcal::cli::within;

constexpr int kExitBadInput = 2;
constexpr int kExitUnusable = 3;

// --tip and --root of a command that takes several model files: they apply to
// each URDF among them; given without any URDF they are a usage error.
struct ChainOptions {
  std::string tip, root;

  void check_used(const std::vector<std::string>& paths) const {
    if (tip.empty() && root.empty()) return;
    for (const std::string& p : paths) {
      if (hapticcal::is_urdf_path(p)) return;
    }
    throw hapticcal::InputError(fmt::format("{}: applies to URDF models (.urdf); none is given",
                                            tip.empty() ? "--root" : "--tip"));
  }
  hapticcal::DeviceModel load(const std::string& path) const {
    return hapticcal::is_urdf_path(path) ? hapticcal::load_model(path, tip, root)
                                         : hapticcal::load_model(path);
  }
};

void add_chain_options(CLI::App* command, ChainOptions& chain) {
  command->add_option("--tip", chain.tip,
                      "Tip link of a URDF model's chain (needed unless the URDF has one leaf)");
  command->add_option("--root", chain.root,
                      "Root link of a URDF model's chain (default: the URDF's root link)");
}

// What to print once a set with a report of `drawn` figures is in `shown`.
std::string report_said(int drawn, const std::string& note, const std::string& shown) {
  std::string said = fmt::format("report: {}/report.html ({} figures, SVG and PNG in {}/figures)\n",
                                 shown, drawn, shown);
  if (!note.empty()) said += fmt::format("note: {}\n", note);
  return said;
}

// Writes report.html with its figures into `dir` (a staging folder that
// becomes `shown`); returns what to print once the set is in place.
std::string report(const hapticcal::Report& r, const std::string& dir, const std::string& shown) {
  std::string note;
  const int drawn = hapticcal::write_report(r, dir, note);
  return report_said(drawn, note, shown);
}

struct EvaluateOptions {
  std::string fixture;
  std::vector<std::string> point_distance;
  std::string model, log, columns, reference, out = "hapticcal-out/evaluate";
  std::string register_what;    // --register: frame or frame,tool
  bool register_given = false;  // --register "" is refused, not taken as absent
  ChainOptions chain;
  bool json = false;
  bool out_given = false;  // --json writes no files unless --out is given
};

int run_evaluate(const EvaluateOptions& o) {
  o.chain.check_used({o.model, o.reference});
  std::optional<hapticcal::RegisterWhat> registration;
  if (o.register_given) registration = hapticcal::parse_register(o.register_what);
  const hapticcal::DeviceModel model = o.chain.load(o.model);
  const hapticcal::Log log = hapticcal::read_log(
      o.log, o.columns.empty() ? std::vector<std::string>{} : hapticcal::split_columns(o.columns));
  const hapticcal::Fixture known = hapticcal::fixture_facts(o.fixture, o.point_distance);
  std::optional<hapticcal::EvaluationComparison> cmp;
  if (!o.reference.empty()) {
    cmp = hapticcal::compare_to_reference(model, o.chain.load(o.reference), log, known.distances,
                                          known.points, registration);
  }
  const hapticcal::Evaluation ev =
      cmp ? cmp->model
          : (registration ? hapticcal::evaluate_registered(model, log, *registration,
                                                           known.distances, known.points)
                          : hapticcal::evaluate(model, log, known.distances, known.points));
  const std::optional<hapticcal::Evaluation> ref =
      cmp ? std::optional<hapticcal::Evaluation>(cmp->reference) : std::nullopt;
  const std::string json = hapticcal::evaluation_json(cmp ? &*cmp : nullptr, ev);
  const std::vector<std::string> lines =
      hapticcal::evaluation_lines(cmp ? &*cmp : nullptr, ev, o.reference);
  if (o.json) {
    fmt::print("{}\n", json);
    if (!o.out_given) return 0;
  } else {
    fmt::print("model: {} ({}, {} joints)\n", o.model, model.name, model.dof());
    fmt::print("log:   {} ({} rows)\n", o.log, ev.n);
    for (const std::string& line : lines) fmt::print("{}\n", line);
  }
  hapticcal::OutputSet out(o.out, "evaluate");
  hapticcal::write_file_atomically(out.dir() + "/results.json", json + "\n");
  const std::string reported =
      report(hapticcal::evaluation_report(model, o.model, log, ev, ref ? &*ref : nullptr,
                                          o.reference, lines),
             out.dir(), o.out);
  out.commit();
  // With --json, stdout is the JSON object alone.
  std::FILE* said = o.json ? stderr : stdout;
  hapticcal::cli::say(said, "{}", reported);
  hapticcal::cli::say(said, "{}", hapticcal::cli::output_summary(out, o.out));
  return 0;
}

struct CalibrateOptions {
  std::string fixture;
  std::vector<std::string> point_distance;
  std::string model, log, columns, out = "hapticcal-out/calibrate", fix, free;
  ChainOptions chain;
  bool no_transmission = false, force = false, keep_all = false, strict = false;
  std::string loss = "cauchy";
  int samples = 0, folds = 5;
  unsigned long long seed = 1;
  double sigma = 0;
  int polynomial_order = 0;
  double tolerance = 1e-6;
};

std::vector<std::string> names(const std::string& list) {
  return list.empty() ? std::vector<std::string>{} : hapticcal::split_columns(list);
}

// Values as the paper's Tables 2-5 print them: mm, mrad, deg.
std::string kinematic_row(const hapticcal::ParameterEstimate& e) {
  const hapticcal::DisplayUnit u = hapticcal::display_unit(e.unit);
  const double f = u.scale;
  return fmt::format("  {:<12} {:>12.4f} {:>12.4f} {:>10.4f} +- {:<9.4f} {:<4}  {:>6.3f} {}",
                     e.name, e.nominal * f, e.value * f, (e.value - e.nominal) * f, e.sd * f,
                     u.unit, e.max_correlation, e.max_correlation_with);
}

// A warning line a flagged pose, at most kShownOutliers, then how many more.
void print_outliers(const hapticcal::RobustFit& robust) {
  constexpr size_t kShownOutliers = 10;
  const std::vector<hapticcal::OutlierPose>& outliers = robust.outliers;
  for (size_t i = 0; i < outliers.size() && i < kShownOutliers; ++i) {
    const hapticcal::OutlierPose& o = outliers[i];
    std::string lines;
    for (size_t l = 0; l < o.lines.size(); ++l)
      lines += (l ? ", " : "") + std::to_string(o.lines[l]);
    fmt::print(
        "warning: outlier: log line{} {}: residual {:.4f} mm, {:.1f} robust sds (beyond {:.2f}); "
        "{}\n",
        o.lines.size() == 1 ? "" : "s", lines, o.residual * 1e3, o.statistic, robust.threshold,
        o.weight < 1 ? fmt::format("weight {:.3g} ({} loss)", o.weight, to_string(robust.loss))
                     : std::string("not down-weighted"));
  }
  if (outliers.size() > kShownOutliers) {
    fmt::print("warning: outlier: and {} more (results.json lists them all)\n",
               outliers.size() - kShownOutliers);
  }
}

void print_summary(const hapticcal::CalibrationResult& r, const hapticcal::DeviceModel& nominal) {
  if (!r.transmissions.empty()) {
    fmt::print("Step 1: transmissions from the external encoders (paper Table 4)\n");
    for (const hapticcal::TransmissionFit& t : r.transmissions) {
      const std::string& link = nominal.links[t.joint].name;
      fmt::print(
          "  {} {} ({} samples): RMS of ext - q - c {:.4f} mrad before, {:.4f} mrad after{}\n",
          link, t.type, t.n, t.rms_before * 1e3, t.rms_after * 1e3,
          t.converged ? "" : " (did not converge)");
      if (t.type == "capstan") {
        const char* labels[] = {"Re", "ro", "bo", "ri", "bi"};
        for (int k = 0; k < 5; ++k) {
          const hapticcal::DisplayUnit u = hapticcal::display_unit(t, k);
          fmt::print("    {:<3} {:>12.6f} +- {:<10.6f} {}\n", labels[k], t.value[k] * u.scale,
                     t.sd[k] * u.scale, u.unit);
        }
      } else {
        fmt::print("    monomial view (rad):");
        for (int k = static_cast<int>(t.monomial.size()) - 1; k >= 0; --k) {
          fmt::print(" k{}={:.6f}", k, t.monomial[k]);
        }
        fmt::print("\n");
      }
      fmt::print("    c (encoder zero, nuisance) {:.6f} +- {:.6f} mrad\n", t.offset * 1e3,
                 t.offset_sd * 1e3);
    }
  }
  const hapticcal::KinematicFit& k = r.kinematics;
  fmt::print("Step 2: kinematic parameters from {} ({} rows) (paper Table 5)\n",
             hapticcal::traits(k.type).plural, k.rows);
  fmt::print("  {:<12} {:>12} {:>12} {:>10}    {:<9} {:<4}  {}\n", "parameter", "nominal",
             "identified", "deviation", "sd", "unit", "largest correlation");
  for (const hapticcal::ParameterEstimate& e : k.parameters) {
    if (e.identifiable) fmt::print("{}\n", kinematic_row(e));
  }
  fmt::print("  held at nominal:\n");
  for (const hapticcal::ParameterEstimate& e : k.parameters) {
    if (!e.identifiable) fmt::print("  {:<12} {}\n", e.name, e.reason);
  }
  if (k.rows > k.poses) {
    fmt::print("  {} rows are {} poses (repeats averaged); repeatability {:.4f} mm RMS\n", k.rows,
               k.poses, k.repeatability * 1e3);
  }
  fmt::print(
      "  {} parameters identified; condition number {:.4g}; observability O1 {:.4g}, O4 "
      "{:.4g} (angles scaled by {:.3f} m)\n",
      k.identified, k.condition_number, k.observability.O1, k.observability.O4, k.length_scale);
  fmt::print("  sd from sigma = {:.4g} mm ({}); solver: {} after {} iterations\n", k.sigma * 1e3,
             k.sigma_given ? "given" : "residual estimate",
             k.converged ? "converged" : "NOT converged", k.iterations);
  fmt::print("  RMS residual: {:.4f} mm before, {:.4f} mm after (training)\n", k.rms_before * 1e3,
             k.rms_after * 1e3);
  if (k.cv_folds > 0 && std::isfinite(k.cv_rms)) {
    fmt::print("  held-out RMS ({}-fold cross-validation by pose): {:.4f} mm\n", k.cv_folds,
               k.cv_rms * 1e3);
  } else if (!k.cv_note.empty()) {
    fmt::print("  held-out RMS (cross-validation): {}\n", k.cv_note);
  }
  if (k.model_selection) {
    fmt::print(
        "  model selection: {} of {} identifiable parameters kept (5 % family-wise significance; "
        "--keep-all keeps them all)\n",
        k.identified, k.structurally_identified);
  } else if (!k.selection_note.empty()) {
    fmt::print("  model selection: {}\n", k.selection_note);
  }
  print_outliers(k.robust);
  for (const std::string& reason : k.suspect.reasons) {
    fmt::print("warning: suspect fit: {}{}\n", reason,
               r.status == hapticcal::CalibrationStatus::kSuspect ? "" : " (--strict refuses it)");
  }
  for (const hapticcal::ParameterEstimate& e : k.parameters) {
    if (!e.large_change) continue;
    const hapticcal::DisplayUnit u = hapticcal::display_unit(e.unit);
    fmt::print("warning: {} moved {:.4g} {} from nominal (flagged beyond {} mm / {} mrad)\n",
               e.name, (e.value - e.nominal) * u.scale, u.unit, hapticcal::kLargeChangeLength * 1e3,
               hapticcal::kLargeChangeAngle * 1e3);
  }
  for (const std::string& note : r.notes) {
    fmt::print("{}{}\n", note.rfind("warning: ", 0) == 0 ? "" : "note: ", note);
  }
}

int run_calibrate(const CalibrateOptions& o) {
  // A URDF is read once: its text is also the base of calibrated.urdf.
  const bool urdf = hapticcal::is_urdf_path(o.model);
  const std::string urdf_text =
      urdf ? hapticcal::read_file(o.model, hapticcal::FileKind::kUrdf) : std::string();
  const hapticcal::DeviceModel model =
      urdf ? hapticcal::parse_urdf(urdf_text, o.model, o.chain.tip, o.chain.root)
           : hapticcal::load_model(o.model, o.chain.tip, o.chain.root);
  const hapticcal::Log log = hapticcal::read_log(o.log, names(o.columns));
  hapticcal::OutputSet out(o.out, "calibrate");
  hapticcal::CalibrationOptions options;
  options.force = o.force;
  options.transmissions = !o.no_transmission;
  options.samples = o.samples;
  options.seed = o.seed;
  if (o.sigma > 0) options.sigma = o.sigma;
  if (o.polynomial_order > 0) options.polynomial_order = o.polynomial_order;
  options.dependency_tolerance = o.tolerance;
  options.keep_all = o.keep_all;
  options.folds = o.folds;
  options.loss = hapticcal::robust_loss(o.loss);
  options.strict = o.strict;
  hapticcal::Fixture fixture = hapticcal::fixture_facts(o.fixture, o.point_distance);
  options.point_distances = std::move(fixture.distances);
  options.known_points = std::move(fixture.points);
  options.fix = names(o.fix);
  options.free = names(o.free);
  hapticcal::CalibrationResult result = hapticcal::calibrate(model, log, options);
  const hapticcal::CalibrationOutputs written = hapticcal::write_calibration_outputs(
      out, result, model, log, options, {o.model, o.log, urdf_text, o.chain.tip, o.chain.root});
  print_summary(result, model);
  fmt::print("{}", report_said(written.figures, written.report_note, o.out));
  fmt::print("{}", hapticcal::cli::output_summary(out, o.out, fmt::format(" (seed {})", o.seed)));
  if (!written.model_written) {
    fmt::print("status: {}: {}; {}\n", to_string(result.status), result.status_reason,
               written.previous_kept ? "the previous calibrated.yaml is kept"
                                     : "no calibrated.yaml written");
    return kExitUnusable;
  }
  fmt::print("status: {}\n", to_string(result.status));
  return 0;
}

struct SimulateOptions {
  std::string scenario, out = "hapticcal-out/simulate", device;
  ChainOptions chain;
  int trials = 0, threads = 0;
  long long seed = -1;
};

// The validation (Fig. 8) and trajectory (Fig. 10) lines; the figures' numbers
// and the paper's percentages in the paper's study only.
void print_validation_and_trajectory(const hapticcal::Scenario& sc,
                                     const hapticcal::TrialResult& t) {
  const bool paper = sc.paper_comparison();
  fmt::print(
      "Validation ({} poses{}): position RMS {:.4f} -> {:.4f} mm, orientation RMS "
      "{:.4f} -> {:.4f} mrad{}\n",
      sc.validation_poses, paper ? ", Fig. 8" : "", t.position_rms_before * 1e3,
      t.position_rms_after * 1e3, t.orientation_rms_before * 1e3, t.orientation_rms_after * 1e3,
      sc.measurement == hapticcal::MeasurementType::kDistance
          ? fmt::format(", distance RMS {:.4f} -> {:.4f} mm", t.distance_rms_before * 1e3,
                        t.distance_rms_after * 1e3)
          : "");
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
             sc.measurement == hapticcal::MeasurementType::kPose
                 ? fmt::format(", sigma_r {:.3g} rad", sc.noise.sigma_orientation)
                 : "");
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
    if (f.type != "polynomial") continue;
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

int run_simulate(const SimulateOptions& o) {
  if (o.scenario.empty()) o.chain.check_used({o.device});
  hapticcal::Scenario sc =
      o.scenario.empty()
          ? hapticcal::default_scenario(o.device, o.chain.tip, o.chain.root)
          : hapticcal::load_scenario(o.scenario, o.device, o.chain.tip, o.chain.root);
  if (o.trials > 0) sc.trials = o.trials;
  if (o.seed >= 0) sc.seed = static_cast<std::uint64_t>(o.seed);
  const int threads = o.threads > 0 ? o.threads : std::max(1u, std::thread::hardware_concurrency());
  fmt::print("hapticcal simulate: {} trial(s), seed {}, {} thread(s), device {}\n", sc.trials,
             sc.seed, std::min(threads, sc.trials), sc.device_path);
  const bool bar = sc.trials > 1 && isatty(2);
  hapticcal::OutputSet out(o.out, "simulate");
  const hapticcal::StudyResult r = hapticcal::run_study(sc, out.dir(), threads, [&](int k, int n) {
    if (!bar) return;
    const int width = 40, filled = width * k / n;
    hapticcal::cli::say(stderr, "\r[{}{}] {}/{}", std::string(filled, '#'),
                        std::string(width - filled, ' '), k, n);
    if (k == n) hapticcal::cli::say(stderr, "\n");
  });
  print_study(sc, r);
  hapticcal::write_file_atomically(out.dir() + "/results.json", hapticcal::study_json(sc, r));
  const std::string reported = report(hapticcal::study_report(sc, r), out.dir(), o.out);
  out.commit();
  fmt::print("{}", reported);
  fmt::print("{}", hapticcal::cli::output_summary(out, o.out));
  return 0;
}

struct ForceOptions {
  std::string actual, nominal, calibrated, out = "hapticcal-out/force", posture;
  int lock = -1;  // 1-based; 0: none; -1: the default (ForceScenario::kLockRedundant)
  ChainOptions chain;
  hapticcal::ForceScenario scenario;
};

std::string force_csv(const hapticcal::ForceRun& run) {
  std::string out = "t,Fd_x,Fd_y,Fd_z,F_x,F_y,F_z,M_x,M_y,M_z\n";
  for (size_t k = 0; k < run.t.size(); ++k) {
    const auto& d = run.desired[k];
    const auto& m = run.measured[k];
    out += fmt::format("{},{},{},{},{},{},{},{},{},{}\n", run.t[k], d[0], d[1], d[2], m[0], m[1],
                       m[2], m[3], m[4], m[5]);
  }
  return out;
}

int run_force_study(ForceOptions o) {
  o.chain.check_used({o.actual, o.nominal, o.calibrated});
  const hapticcal::DeviceModel actual = o.chain.load(o.actual);
  const hapticcal::DeviceModel nominal = o.chain.load(o.nominal);
  const hapticcal::DeviceModel calibrated = o.chain.load(o.calibrated);
  hapticcal::ForceScenario& sc = o.scenario;
  if (o.lock >= 0) sc.locked_joint = o.lock - 1;  // 0 -> kNoLock
  sc.locked_joint = hapticcal::resolved_locked_joint(sc, actual.dof());
  hapticcal::OutputSet out(o.out, "force");
  if (!o.posture.empty()) {
    const std::vector<std::string> v = names(o.posture);
    sc.posture.resize(v.size());
    for (size_t i = 0; i < v.size(); ++i) {
      try {
        sc.posture[i] = std::stod(v[i]);
      } catch (const std::exception&) {
        throw hapticcal::InputError(fmt::format("--posture: '{}' is not a number", v[i]));
      }
    }
  }
  const double limit = hapticcal::force_study_gain_limit(actual, nominal, calibrated, sc);
  if (!(std::abs(sc.gain) < limit)) {
    throw hapticcal::InputError(fmt::format(
        "--gain {} is outside the stable range: |G| < {:.4f} for these models (1 / spectral radius "
        "of the rendering map)",
        sc.gain, limit));
  }
  const hapticcal::ForceStudy study = hapticcal::run_force_study(actual, nominal, calibrated, sc);
  sc = study.scenario;
  const hapticcal::ForceRun& before = study.nominal;
  const hapticcal::ForceRun& after = study.calibrated;
  const double reduction = study.reduction_pct;
  std::string posture;
  for (int i = 0; i < sc.posture.size(); ++i)
    posture += fmt::format("{}{}", i ? "," : "", sc.posture[i]);
  fmt::print(
      "hapticcal force: virtual wall K = {} N/m moved {} mm along the handle's z in {} s, "
      "held {} s, at {} Hz; gain G = {} (stable for |G| < {:.4f}); {}; posture q = "
      "[{}] rad{}\n",
      sc.stiffness, sc.travel * 1e3, sc.move_seconds, sc.hold_seconds, sc.rate_hz, sc.gain, limit,
      sc.locked_joint >= 0 ? fmt::format("joint {} locked", sc.locked_joint + 1)
                           : "no joint locked",
      posture,
      o.posture.empty() && actual.dof() == 7
          ? " (home with j6 = 0.3 rad: home is a wrist singularity of this model)"
          : "");
  fmt::print(
      "  transverse force (|Fx, Fy|) RMS: nominal model {:.4f} N, calibrated model {:.4f} N, "
      "reduction {:.1f} %\n",
      before.transverse_rms, after.transverse_rms, reduction);
  fmt::print("  at the end: Fz {:.4f} N desired, {:.4f} N nominal, {:.4f} N calibrated\n",
             before.desired.back()[2], before.measured.back()[2], after.measured.back()[2]);
  hapticcal::write_file_atomically(out.dir() + "/force_nominal.csv", force_csv(before));
  hapticcal::write_file_atomically(out.dir() + "/force_calibrated.csv", force_csv(after));
  nlohmann::ordered_json j;
  j["format"] = "hapticcal-force/1";
  j["actual"] = o.actual;
  j["nominal"] = o.nominal;
  j["calibrated"] = o.calibrated;
  j["stiffness"] = sc.stiffness;
  j["travel"] = sc.travel;
  j["gain"] = sc.gain;
  j["stable_gain_limit"] = limit;
  j["sensor_noise"] = sc.sensor_noise;
  j["seed"] = sc.seed;
  j["posture"] = std::vector<double>(sc.posture.data(), sc.posture.data() + sc.posture.size());
  j["transverse_rms_nominal"] = before.transverse_rms;
  j["transverse_rms_calibrated"] = after.transverse_rms;
  j["reduction_pct"] = reduction;
  hapticcal::write_file_atomically(
      out.dir() + "/results.json",
      j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
  hapticcal::Report force_report = hapticcal::force_report(before, after);
  force_report.outcome = hapticcal::force_outcome(study);
  const std::string reported = report(force_report, out.dir(), o.out);
  out.commit();
  fmt::print("{}", reported);
  fmt::print("{}", hapticcal::cli::output_summary(out, o.out));
  return 0;
}

struct ConvertOptions {
  std::string in, out;
  ChainOptions chain;
};

// Device file -> URDF or URDF -> device file, by the file names' extensions.
int run_convert(const ConvertOptions& o) {
  for (const std::string* path : {&o.in, &o.out}) {
    if (!hapticcal::is_urdf_path(*path) && !hapticcal::is_yaml_path(*path)) {
      hapticcal::cli::say(
          stderr,
          "hapticcal: convert: '{}' is neither a device file (.yaml, .yml) nor a URDF "
          "(.urdf)\n",
          hapticcal::printable(*path, 200));
      return kExitBadInput;
    }
  }
  const bool to_urdf = hapticcal::is_urdf_path(o.out);
  if (hapticcal::is_urdf_path(o.in) == to_urdf) {
    hapticcal::cli::say(stderr, "hapticcal: convert: {} and {} are both {}: nothing to convert\n",
                        hapticcal::printable(o.in, 200), hapticcal::printable(o.out, 200),
                        to_urdf ? "URDF" : "device files");
    return kExitBadInput;
  }
  const hapticcal::DeviceModel model = hapticcal::load_model(o.in, o.chain.tip, o.chain.root);
  if (to_urdf) {
    std::string with_transmission;
    for (const hapticcal::Link& l : model.links) {
      if (!l.transmission.is_none())
        with_transmission += (with_transmission.empty() ? "" : ", ") + l.name;
    }
    hapticcal::write_file_atomically(o.out, hapticcal::device_to_urdf(model));
    if (!with_transmission.empty()) {
      hapticcal::cli::say(
          stderr,
          "hapticcal: warning: URDF cannot express transmissions: those of {} are only "
          "XML comments in {}\n",
          with_transmission, o.out);
    }
    fmt::print("wrote {} ({}, {} joints; its chain is hapticcal_measurement -> tool)\n", o.out,
               model.name, model.dof());
  } else {
    hapticcal::save_device(model, o.out);
    fmt::print("wrote {} ({}, {} joints: {})\n", o.out, model.name, model.dof(), [&] {
      std::string names;
      for (const hapticcal::Link& l : model.links) names += (names.empty() ? "" : " ") + l.name;
      return names;
    }());
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  hapticcal::cli::guard_standard_streams();
  hapticcal::remove_staging_on_signals();
  CLI::App app{"hapticcal: kinematic calibration of haptic devices and robots with transmissions"};
  app.set_version_flag("--version", "hapticcal 0.1.0");
  app.require_subcommand(1);
  app.footer(
      "Exit codes: 0 success; 2 bad input; 3 calibration not usable (the previous "
      "calibrated.yaml is kept); 1 anything else (I/O errors with the system's reason).");

  SimulateOptions sim;
  sim.device = hapticcal::builtin_device_path();
  std::string out;
  auto* simulate = app.add_subcommand(
      "simulate",
      "Run the paper's simulation study (main job), or one on any device and measurement");
  simulate->add_option("--scenario", sim.scenario, "Scenario file (YAML)");
  simulate->add_option("--trials", sim.trials, "Monte Carlo trials (default 1)")
      ->check(whole_number(1, 100000));
  simulate->add_option("--seed", sim.seed, "Random seed (default 1)")->check(whole_number(0));
  simulate->add_option("--threads", sim.threads, "Threads (default: all cores)")
      ->check(whole_number(1, 256));
  simulate->add_option("--device", sim.device,
                       "Nominal device file or URDF (default: the built-in 7-DOF)");
  simulate->add_option("--out", sim.out, "Output directory (default hapticcal-out/simulate)");
  add_chain_options(simulate, sim.chain);

  CalibrateOptions cal;
  auto* calibrate = app.add_subcommand("calibrate", "Two-step identification from a log");
  calibrate
      ->add_option("--model", cal.model,
                   "The nominal model: a device file (YAML) or a URDF (.urdf, with --tip; then "
                   "calibrated.urdf is written too)")
      ->required();
  add_chain_options(calibrate, cal.chain);
  calibrate->add_option("--log", cal.log, "Measurement log (CSV)")->required();
  calibrate->add_flag("--no-transmission", cal.no_transmission,
                      "Skip step 1: kinematic-only calibration");
  calibrate
      ->add_option("--samples", cal.samples,
                   "Use N random poses of the log (0: all; repeated rows count as one pose)")
      ->check(whole_number(0, 100000000));
  calibrate->add_option("--seed", cal.seed, "Seed of the row sample")->check(whole_number(0));
  calibrate
      ->add_option("--sigma", cal.sigma,
                   "Measurement noise sd [m] for the standard deviations (default: "
                   "estimated from the residuals)")
      ->check(within(1e-12, 1, "m"));
  calibrate
      ->add_option("--polynomial-order", cal.polynomial_order,
                   "Order of polynomial transmissions (default: the device file's, else 10)")
      ->check(whole_number(1, 30));
  calibrate->add_option("--fix", cal.fix, "Kinematic parameters held at nominal, e.g. j1.a,j2.d");
  calibrate->add_option("--free", cal.free,
                        "Parameters added to the candidates, e.g. j2.beta (a beta is one by "
                        "default only where neighbouring joint axes are parallel)");
  calibrate->add_option("--point-distance", cal.point_distance,
                        "A known distance between two fixture points of the log (column point): "
                        "A:B=METRES (repeatable)");
  calibrate->add_option("--fixture", cal.fixture,
                        "Fixture file (YAML): known positions (points) and distances of the "
                        "log's fixture points");
  calibrate->add_flag("--keep-all", cal.keep_all,
                      "No model selection: fit every identifiable parameter the data excite, "
                      "even those they do not support");
  calibrate
      ->add_option("--folds", cal.folds,
                   "K of the K-fold cross-validated (held-out) RMS by pose (default 5; 0: none)")
      ->check(whole_number(0, 1000));
  calibrate
      ->add_option("--loss", cal.loss,
                   "Loss for poses the outlier test flags (residual beyond the Bonferroni "
                   "quantile in robust sds): cauchy (default), huber, or none (plain least "
                   "squares; outliers still named)")
      ->check(CLI::IsMember({"cauchy", "huber", "none"}));
  calibrate->add_flag("--strict", cal.strict,
                      "A suspect fit (training RMS beyond 100 x the repeatability, or held-out "
                      "RMS above the nominal model's with its base fitted) is unusable: exit 3, "
                      "the previous calibrated.yaml kept");
  calibrate->add_option("--columns", cal.columns, "Column names of a log without header");
  calibrate
      ->add_option("--dependency-tolerance", cal.tolerance,
                   "A parameter whose scaled Jacobian column lies within this relative "
                   "distance of the span of those before it is held (default 1e-6)")
      ->check(within(1e-12, 0.5));
  calibrate->add_flag(
      "--force", cal.force,
      "Calibrate even if the log looks implausible for the model (readings "
      "outside the joint limits, nominal error beyond 5 % of the reach with the base "
      "fitted)");
  calibrate->add_option("--out", cal.out,
                        "Output folder, replaced as a whole when the run succeeds (default "
                        "hapticcal-out/calibrate)");

  EvaluateOptions eval;
  auto* evaluate = app.add_subcommand("evaluate", "RMS and max error of a model on a log");
  evaluate->add_option("--model", eval.model, "Device file (YAML) or URDF (.urdf)")->required();
  add_chain_options(evaluate, eval.chain);
  evaluate->add_option("--log", eval.log, "Measurement log (CSV)")->required();
  evaluate->add_flag("--json", eval.json,
                     "Print one JSON object (metres); writes no files unless --out is given");
  evaluate->add_option("--out", eval.out,
                       "Output directory: report.html, results.json (default "
                       "hapticcal-out/evaluate)");
  evaluate->add_option("--point-distance", eval.point_distance,
                       "A known distance between two fixture points: A:B=METRES (repeatable)");
  evaluate->add_option("--fixture", eval.fixture,
                       "Fixture file (YAML): known positions (points) and distances of the log's "
                       "fixture points");
  evaluate->add_option("--reference", eval.reference,
                       "A second device file (e.g. the nominal one): adds the paper's eq. 9 "
                       "improvement of --model over it on the same log");
  evaluate->add_option("--columns", eval.columns,
                       "Column names of a log without header, comma separated, _ skips one "
                       "(e.g. q1[deg],q2[deg],x,y,z,_)");
  evaluate->add_option("--register", eval.register_what,
                       "frame or frame,tool: fit the measurement frame (the base pose), and the "
                       "tool point, on this log before scoring (a tracker moved since); each "
                       "model on its own with --reference");

  ForceOptions fo;
  auto* force = app.add_subcommand("force", "Force-control study (virtual wall, paper Figs 11-12)");
  force->add_option("--actual", fo.actual, "Device file of the true device")->required();
  force->add_option("--nominal", fo.nominal, "Controller model before calibration")->required();
  force
      ->add_option("--calibrated", fo.calibrated,
                   "Controller model after calibration (the actual file: the truth as the model)")
      ->required();
  force->add_option("--out", fo.out, "Output directory (default hapticcal-out/force)");
  force->add_option("--gain", fo.scenario.gain, "Force-loop gain G (default 0.5)")
      ->check(within(-100, 100));
  force->add_option("--noise", fo.scenario.sensor_noise, "Force sensor noise sd [N] (default 0)")
      ->check(within(0, 1000, "N"));
  force->add_option("--stiffness", fo.scenario.stiffness, "Wall stiffness [N/m] (default 100)")
      ->check(within(1e-3, 1e6, "N/m"));
  force
      ->add_option("--travel", fo.scenario.travel,
                   "Wall travel along the handle's z [m] (default 0.02)")
      ->check(within(-1, 1, "m"));
  force
      ->add_option("--seconds", fo.scenario.move_seconds,
                   "Time the wall takes (default 2 s; at most 600 s at the 1 kHz loop rate)")
      ->check(within(0, 600, "s"));
  force->add_option("--posture", fo.posture,
                    "Readings q of the fixed handle, comma separated (default: home, j6 = 0.3 rad "
                    "on a 7-joint device)");
  force->add_option("--seed", fo.scenario.seed, "Seed of the sensor noise")->check(whole_number(0));
  force
      ->add_option("--lock", fo.lock,
                   "Joint to lock, 1-based; 0: none (default: joint 3 on a 7-joint device, none "
                   "on a 6-joint one; 6 joints must remain)")
      ->check(whole_number(0, 1000));
  add_chain_options(force, fo.chain);

  ConvertOptions conv;
  auto* convert = app.add_subcommand(
      "convert", "Convert a device file (.yaml, .yml) to URDF (.urdf) or a URDF to a device file");
  convert->add_option("IN", conv.in, "Model to read")->required();
  convert->add_option("OUT", conv.out, "File to write (replaced atomically)")->required();
  add_chain_options(convert, conv.chain);

  hapticcal::cli::PlanCommandOptions plan_options;
  CLI::App* plan = hapticcal::cli::add_plan_command(app, plan_options);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) {  // --help, --version
      return hapticcal::cli::finish_streams(app.exit(e));
    }
    if (dynamic_cast<const CLI::RequiredError*>(&e) && app.get_subcommands().empty()) {
      hapticcal::cli::say(stderr,
                          "hapticcal: give a command (calibrate, evaluate, simulate, plan, force, "
                          "convert); see hapticcal --help\n");
      return kExitBadInput;
    }
    // One line, whatever the argument held (a newline, a control byte).
    hapticcal::cli::say(stderr, "hapticcal: {}\n", hapticcal::printable(e.what(), 400));
    return hapticcal::cli::finish_streams(kExitBadInput);
  }

  int code = 1;
  try {
    if (*evaluate) {
      eval.out_given = evaluate->get_option("--out")->count() > 0;
      eval.register_given = evaluate->get_option("--register")->count() > 0;
      code = run_evaluate(eval);
    }
    if (*simulate) code = run_simulate(sim);
    if (*calibrate) code = run_calibrate(cal);
    if (*force) code = run_force_study(fo);
    if (*convert) code = run_convert(conv);
    if (*plan) code = hapticcal::cli::run_plan(plan_options);
  } catch (const hapticcal::InputError& e) {
    hapticcal::finish_if_interrupted();
    hapticcal::cli::say(stderr, "hapticcal: {}\n", e.what());
    code = kExitBadInput;
  } catch (const hapticcal::IoError& e) {
    hapticcal::finish_if_interrupted();
    hapticcal::cli::say(stderr, "hapticcal: {}\n", e.what());
    code = 1;
  } catch (const std::runtime_error& e) {  // the system's: a write to stdout failed (a closed
                                           // pipe), a file system error
    hapticcal::finish_if_interrupted();
    hapticcal::cli::say(stderr, "hapticcal: {}\n", e.what());
    code = 1;
  } catch (const std::exception& e) {
    hapticcal::finish_if_interrupted();
    hapticcal::cli::say(stderr, "hapticcal: internal error: {}\n", e.what());
    code = 1;
  }
  hapticcal::finish_if_interrupted();
  return hapticcal::cli::finish_streams(code);
}
