// `hapticcal calibrate`: the two-step identification (paper Fig. 6) of a log,
// its summary on the terminal and its output set.
#include <fmt/format.h>

#include <cmath>
#include <string>
#include <vector>

#include "commands.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/core/output_set.hpp"
#include "hapticcal/data_io/fixture.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/model_io/urdf.hpp"
#include "hapticcal/report/calibration_outputs.hpp"
#include "number_options.hpp"
#include "output_summary.hpp"

namespace hapticcal::cli {
namespace {

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
          link, hapticcal::to_string(t.kind), t.n, t.rms_before * 1e3, t.rms_after * 1e3,
          t.converged ? "" : " (did not converge)");
      if (t.kind == hapticcal::TransmissionKind::kCapstan) {
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

}  // namespace

CLI::App* add_calibrate_command(CLI::App& app, CalibrateOptions& o) {
  auto* calibrate = app.add_subcommand("calibrate", "Two-step identification from a log");
  calibrate
      ->add_option("--model", o.model,
                   "The nominal model: a device file (YAML) or a URDF (.urdf, with --tip; then "
                   "calibrated.urdf is written too)")
      ->required();
  add_chain_options(calibrate, o.chain);
  calibrate->add_option("--log", o.log, "Measurement log (CSV)")->required();
  calibrate->add_flag("--no-transmission", o.no_transmission,
                      "Skip step 1: kinematic-only calibration");
  calibrate
      ->add_option("--samples", o.samples,
                   "Use N random poses of the log (0: all; repeated rows count as one pose)")
      ->check(whole_number(0, 100000000));
  calibrate->add_option("--seed", o.seed, "Seed of the row sample")->check(whole_number(0));
  calibrate
      ->add_option("--sigma", o.sigma,
                   "Measurement noise sd [m] for the standard deviations (default: "
                   "estimated from the residuals)")
      ->check(within(1e-12, 1, "m"));
  calibrate
      ->add_option("--polynomial-order", o.polynomial_order,
                   "Order of polynomial transmissions (default: the device file's, else 10)")
      ->check(whole_number(1, 30));
  calibrate->add_option("--fix", o.fix, "Kinematic parameters held at nominal, e.g. j1.a,j2.d");
  calibrate->add_option("--free", o.free,
                        "Parameters added to the candidates, e.g. j2.beta (a beta is one by "
                        "default only where neighbouring joint axes are parallel)");
  calibrate->add_option("--point-distance", o.point_distance,
                        "A known distance between two fixture points of the log (column point): "
                        "A:B=METRES (repeatable)");
  calibrate->add_option("--fixture", o.fixture,
                        "Fixture file (YAML): known positions (points) and distances of the "
                        "log's fixture points");
  calibrate->add_flag("--keep-all", o.keep_all,
                      "No model selection: fit every identifiable parameter the data excite, "
                      "even those they do not support");
  calibrate
      ->add_option("--folds", o.folds,
                   "K of the K-fold cross-validated (held-out) RMS by pose (default 5; 0: none)")
      ->check(whole_number(0, 1000));
  calibrate
      ->add_option("--loss", o.loss,
                   "Loss for poses the outlier test flags (residual beyond the Bonferroni "
                   "quantile in robust sds): cauchy (default), huber, or none (plain least "
                   "squares; outliers still named)")
      ->check(CLI::IsMember({"cauchy", "huber", "none"}));
  calibrate->add_flag("--strict", o.strict,
                      "A suspect fit (training RMS beyond 100 x the repeatability, or held-out "
                      "RMS above the nominal model's with its base fitted) is unusable: exit 3, "
                      "the previous calibrated.yaml kept");
  calibrate->add_option("--columns", o.columns, "Column names of a log without header");
  calibrate
      ->add_option("--dependency-tolerance", o.tolerance,
                   "A parameter whose scaled Jacobian column lies within this relative "
                   "distance of the span of those before it is held (default 1e-6)")
      ->check(within(1e-12, 0.5));
  calibrate->add_flag(
      "--force", o.force,
      "Calibrate even if the log looks implausible for the model (readings "
      "outside the joint limits, nominal error beyond 5 % of the reach with the base "
      "fitted)");
  calibrate->add_option("--out", o.out,
                        "Output folder, replaced as a whole when the run succeeds (default "
                        "hapticcal-out/calibrate)");
  return calibrate;
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

}  // namespace hapticcal::cli
