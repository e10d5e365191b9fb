// The calibration's summary, a line each (report/calibration_lines.hpp).
#include "hapticcal/report/calibration_lines.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "hapticcal/identification/tree.hpp"
#include "hapticcal/study/study.hpp"
#include "report/report_parts.hpp"

namespace hapticcal {
namespace {

// Values in mm and deg (a pose's angles: detail::parameter_units), their
// deviation and sd in mm and mrad; names padded to `width`.
std::string kinematic_row(const ParameterEstimate& e, const DeviceModel& nominal, size_t width) {
  const detail::ParameterUnits u = detail::parameter_units(e, nominal);
  const double f = u.value.scale, g = u.change.scale;
  return fmt::format("  {:<{}} {:>12.4f} {:>12.4f} {:<4} {:>10.4f} +- {:<9.4f} {:<4}  {:>6.3f} {}",
                     e.name, width, e.nominal * f, e.value * f, u.value.unit,
                     (e.value - e.nominal) * g, e.sd * g, u.change.unit, e.max_correlation,
                     e.max_correlation_with) +
         (e.set_by_prior ? fmt::format("  set by the prior (data share {:.2f})", e.data_share)
                         : std::string());
}

// The step-2 table: the identified parameters, those fitted but not
// determined by the data (apart, with why), and those held at nominal; returns
// how many were not determined.
int parameter_lines(const KinematicFit& k, const DeviceModel& nominal,
                    std::vector<std::string>& out) {
  size_t width = 12;
  for (const ParameterEstimate& e : k.parameters) {
    if (e.identifiable) width = std::max(width, e.name.size());
  }
  out.push_back(fmt::format("  {:<{}} {:>12} {:>12} {:<4} {:>10}    {:<9} {:<4}  {}", "parameter",
                            width, "nominal", "identified", "unit", "deviation", "sd", "unit",
                            "largest correlation"));
  int undetermined = 0;
  for (const ParameterEstimate& e : k.parameters) {
    if (e.identifiable && e.determined) out.push_back(kinematic_row(e, nominal, width));
    undetermined += e.identifiable && !e.determined;
  }
  if (undetermined > 0) {
    out.push_back(fmt::format(
        "  not determined by these data (fitted, but sd above the tolerance or correlated beyond "
        "{} with another):",
        kUndeterminedCorrelation));
    for (const ParameterEstimate& e : k.parameters) {
      if (!e.identifiable || e.determined) continue;
      out.push_back(kinematic_row(e, nominal, width));
      out.push_back(fmt::format("  {:<{}} {}", "", width, detail::undetermined_text(e, nominal)));
    }
  }
  out.push_back(fmt::format("  held at nominal:"));
  for (const ParameterEstimate& e : k.parameters) {
    if (!e.identifiable) out.push_back(fmt::format("  {:<{}} {}", e.name, width, e.reason));
  }
  return undetermined;
}

// The held-out RMS (the model search's, with its standard error, warned of
// where the poses are too few to trust it; or the cross-validation's).
void held_out_lines(const KinematicFit& k, std::vector<std::string>& out) {
  if (k.search.ran && std::isfinite(k.cv_rms)) {
    const SearchCandidate* kept =
        k.search.kept >= 0 ? &k.search.candidates[static_cast<size_t>(k.search.kept)] : nullptr;
    const double se = kept ? kept->se : std::numeric_limits<double>::quiet_NaN();
    out.push_back(fmt::format(
        "  held-out RMS (the model search's: {} folds x {} shuffles by {}): {:.4f}{} mm",
        k.search.folds, k.search.repeats, k.search.unit, k.cv_rms * 1e3,
        std::isfinite(se) ? fmt::format(" +- {:.4f}", se * 1e3) : ""));
    if (kept && k.search.measured_rows < 3 * kept->parameters) {
      out.push_back(fmt::format(
          "  warning: the held-out error rests on {} {}s for {:.1f} parameters: too few to trust "
          "it closely (+- {:.4f} mm, and held-out poses drawn from so few tend to flatter it); "
          "measure more poses",
          k.search.units, k.search.unit, kept->parameters, se * 1e3));
    }
  } else if (k.cv_folds > 0 && std::isfinite(k.cv_rms)) {
    out.push_back(fmt::format("  held-out RMS ({}-fold cross-validation by pose): {:.4f} mm",
                              k.cv_folds, k.cv_rms * 1e3));
  } else if (!k.cv_note.empty()) {
    out.push_back(fmt::format("  held-out RMS (cross-validation): {}", k.cv_note));
  }
}

// A warning line a flagged pose, at most kShownOutliers, then how many more.
void outlier_lines(const RobustFit& robust, std::vector<std::string>& out) {
  constexpr size_t kShownOutliers = 10;
  const std::vector<OutlierPose>& outliers = robust.outliers;
  for (size_t i = 0; i < outliers.size() && i < kShownOutliers; ++i) {
    const OutlierPose& o = outliers[i];
    std::string lines;
    for (size_t l = 0; l < o.lines.size(); ++l)
      lines += (l ? ", " : "") + std::to_string(o.lines[l]);
    out.push_back(fmt::format(
        "warning: outlier: log line{} {}: residual {:.4f} mm, {:.1f} robust sds (beyond {:.2f}); "
        "{}",
        o.lines.size() == 1 ? "" : "s", lines, o.residual * 1e3, o.statistic, robust.threshold,
        o.weight < 1 ? fmt::format("weight {:.3g} ({} loss)", o.weight, to_string(robust.loss))
                     : std::string("not down-weighted")));
  }
  if (outliers.size() > kShownOutliers) {
    out.push_back(fmt::format("warning: outlier: and {} more (results.json lists them all)",
                              outliers.size() - kShownOutliers));
  }
}

// Two streams' clocks, one line.
std::string clock_line(const ClockEstimate& c) {
  return fmt::format(
      "Clocks: device time = tracker time + offset{}; offset {:.4f} ms +- {:.4f} ms{} ({}; "
      "coarse {:.1f} ms, speed correlation {:.3f}, searched +-{:g} s)",
      c.drift_fitted ? " + drift (tracker time - first stamp)" : "", 1e3 * c.clock.offset,
      1e3 * c.offset_sd,
      c.drift_fitted
          ? fmt::format(", drift {:.3f} ppm +- {:.3f} ppm", 1e6 * c.clock.drift, 1e6 * c.drift_sd)
          : std::string(),
      c.converged ? fmt::format("{} steps", c.iterations) : "NOT settled", 1e3 * c.coarse_offset,
      c.coarse_correlation, c.search_range);
}

}  // namespace

// The model search's candidates (docs/calibrate.md, "The model search"): the best few by
// held-out RMS and the one kept.
void search_lines(const ModelSearch& search, std::vector<std::string>& out) {
  if (!search.ran) {
    if (!search.note.empty()) out.push_back("  model search: " + search.note);
    return;
  }
  out.push_back(fmt::format(
      "  model search: {} candidates on held-out {}s ({} folds x {} shuffles, seed {}); the "
      "nominal model with its {} fitted: {:.4f} mm",
      search.candidates.size(), search.unit, search.folds, search.repeats, search.seed,
      search.nominal_fitted.empty() ? "nothing" : search.nominal_fitted, search.nominal_rms * 1e3));
  std::vector<int> order;
  for (int i = 0; i < static_cast<int>(search.candidates.size()); ++i) {
    if (std::isfinite(search.candidates[i].cv_rms)) order.push_back(i);
  }
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    return search.candidates[a].cv_rms < search.candidates[b].cv_rms;
  });
  constexpr int kShown = 5;
  if (static_cast<int>(order.size()) > kShown) {
    const bool kept_shown =
        std::find(order.begin(), order.begin() + kShown, search.kept) != order.begin() + kShown;
    order.resize(kShown);
    if (!kept_shown && search.kept >= 0) order.push_back(search.kept);
  }
  out.push_back(fmt::format("    {:<4} {:<40} {:<17} {:>12} {:>10} {:>10}", "", "model",
                            "estimator", "held-out mm", "+- mm", "parameters"));
  for (int i : order) {
    const SearchCandidate& c = search.candidates[i];
    std::string model = c.families.empty()
                            ? "geometry"
                            : "geometry + " + fmt::format("{}", fmt::join(c.families, " + "));
    if (c.zero) model += " + instrument zero";
    out.push_back(fmt::format("    {:<4} {:<40} {:<17} {:>12.4f} {:>10.4f} {:>10.1f}{}",
                              i == search.kept ? "kept" : "", model, to_string(c.estimator),
                              c.cv_rms * 1e3, c.se * 1e3, c.parameters,
                              !c.allowed  ? "  (reference)"
                              : !c.usable ? "  (worse than nominal)"
                                          : ""));
  }
}

namespace {

// Step 2's title: what it fits, from how many of the log's rows.
std::string step_two_title(const KinematicFit& k, const DeviceModel& nominal, bool paper) {
  return fmt::format("Step 2: kinematic parameters from {} ({}){}", traits(k.type).plural,
                     samples_text(k.rows, nominal.tips(), "row"), paper ? " (paper Table 5)" : "");
}

}  // namespace

std::vector<std::string> calibration_lines(const CalibrationResult& r, const DeviceModel& nominal) {
  std::vector<std::string> out;
  // The paper's table numbers name the paper's device's tables only.
  const bool paper = is_paper_device(nominal);
  if (!r.transmissions.empty()) {
    out.push_back(fmt::format("Step 1: transmissions from the external encoders{}",
                              paper ? " (paper Table 4)" : ""));
    for (const TransmissionFit& t : r.transmissions) {
      const std::string& link = nominal.links[t.joint].name;
      out.push_back(fmt::format(
          "  {} {} ({} samples): RMS of ext - q - c {:.4f} mrad before, {:.4f} mrad after, {:.4f} "
          "mrad on left-out samples ({}){}{}",
          link, t.type, t.n, t.rms_before * 1e3, t.rms_after * 1e3, t.held_out_rms * 1e3,
          t.model_choice, t.flagged ? " FLAGGED" : "", t.converged ? "" : " (did not converge)"));
      if (t.kind == TransmissionKind::kCapstan) {
        const char* labels[] = {"Re", "ro", "bo", "ri", "bi"};
        for (int k = 0; k < 5; ++k) {
          const DisplayUnit u = display_unit(t, k);
          out.push_back(fmt::format("    {:<3} {:>12.6f} +- {:<10.6f} {}", labels[k],
                                    t.value[k] * u.scale, t.sd[k] * u.scale, u.unit));
        }
      } else {
        std::string line = "    monomial view (rad):";
        for (int k = static_cast<int>(t.monomial.size()) - 1; k >= 0; --k) {
          line += fmt::format(" k{}={:.6f}", k, t.monomial[k]);
        }
        out.push_back(line);
      }
      out.push_back(fmt::format("    c (encoder zero, nuisance) {:.6f} +- {:.6f} mrad",
                                t.offset * 1e3, t.offset_sd * 1e3));
    }
  }
  if (r.step_one_only) {
    for (const std::string& reason : r.kinematics.suspect.reasons)
      out.push_back("warning: suspect fit: " + reason);
    for (const std::string& note : r.notes)
      out.push_back((note.rfind("warning: ", 0) == 0 ? "" : "note: ") + note);
    return out;
  }
  if (r.clock) out.push_back(clock_line(*r.clock));
  const KinematicFit& k = r.kinematics;
  out.push_back(step_two_title(k, nominal, paper));
  const int undetermined = parameter_lines(k, nominal, out);
  if (k.rows > k.poses) {
    out.push_back(fmt::format("  {} are {} (repeats averaged); {}",
                              samples_text(k.rows, nominal.tips(), "row"),
                              samples_text(k.poses, nominal.tips(), "pose"),
                              detail::repeatability_text(k.repeatability)));
  }
  out.push_back(fmt::format(
      "  {} parameters identified{}; condition number {:.4g}; observability O1 {:.4g}, O4 "
      "{:.4g} (angles scaled by {:.3f} m)",
      k.identified - undetermined,
      undetermined > 0 ? fmt::format(" ({} more fitted, not determined)", undetermined) : "",
      k.condition_number, k.observability.O1, k.observability.O4, k.length_scale));
  out.push_back(fmt::format("  sd from sigma = {:.4g} mm ({}); solver: {} after {} iterations",
                            k.sigma * 1e3, k.sigma_given ? "given" : "residual estimate",
                            k.converged ? "converged" : "NOT converged", k.iterations));
  out.push_back(fmt::format("  RMS residual: {:.4f} mm before, {:.4f} mm after (training)",
                            k.rms_before * 1e3, k.rms_after * 1e3));
  for (const std::string& line : tip_rms_lines(k, nominal)) out.push_back("    " + line);
  held_out_lines(k, out);
  if (k.model_selection) {
    out.push_back(fmt::format(
        "  model selection: {} of {} identifiable parameters kept (5 % family-wise significance; "
        "--keep-all keeps them all)",
        k.identified, k.structurally_identified));
  } else if (k.prior.used) {
    out.push_back(fmt::format(
        "  tolerance prior: scale {:.3g} of the tolerances ({}), {:.1f} effective parameters of "
        "the {} estimated (--select: the significance cut; --keep-all: least squares)",
        k.prior.scale, k.prior.scale_given ? "given" : "highest evidence",
        k.prior.effective_parameters, k.prior.fitted));
  } else if (!k.selection_note.empty()) {
    out.push_back(fmt::format("  model selection: {}", k.selection_note));
  }
  search_lines(k.search, out);
  if (const std::string line = geometry_model_line(r); !line.empty()) out.push_back("  " + line);
  outlier_lines(k.robust, out);
  for (const std::string& reason : k.suspect.reasons) {
    out.push_back(
        fmt::format("warning: suspect fit: {}{}", reason,
                    r.status == CalibrationStatus::kSuspect ? "" : " (--strict refuses it)"));
  }
  for (const ParameterEstimate& e : k.parameters)
    if (e.large_change) out.push_back("note: " + detail::large_change_text(e, k));
  for (const std::string& note : r.notes) {
    out.push_back(fmt::format("{}{}", note.rfind("warning: ", 0) == 0 ? "" : "note: ", note));
  }
  return out;
}

std::string geometry_model_line(const CalibrationResult& result) {
  if (!result.geometry) return "";
  const KinematicFit& g = result.geometry->kinematics;
  const KinematicFit& k = result.kinematics;
  const auto mm = [](double v) {
    return std::isfinite(v) ? fmt::format("{:.4f} mm", v * 1e3) : std::string("-");
  };
  std::string line = fmt::format(
      "geometry alone (what calibrated.urdf, a DH table or a driver's file holds), fitted as such "
      "by the {}: RMS {} on these poses, {} held out; the whole model (geometry + {}): {}, {} "
      "held out",
      to_string(g.estimator), mm(g.rms_after), mm(g.cv_rms),
      fmt::join(k.joint_error_families, " + "), mm(k.rms_after), mm(k.cv_rms));
  if (std::isfinite(g.cv_rms) && std::isfinite(k.cv_rms)) {
    line += fmt::format(": its families take {:.4f} mm off the held-out error",
                        (g.cv_rms - k.cv_rms) * 1e3);
  }
  if (result.geometry->status != CalibrationStatus::kConverged)
    line += fmt::format(" (the geometry alone is {}: {})", to_string(result.geometry->status),
                        result.geometry->status_reason);
  return line;
}

std::vector<std::string> tip_rms_lines(const KinematicFit& fit, const DeviceModel& nominal) {
  std::vector<std::string> out;
  for (size_t t = 0; t < fit.tip_rms_after.size() && t < fit.tip_rms_before.size(); ++t) {
    out.push_back(fmt::format("{}: {:.4f} mm before, {:.4f} mm after",
                              nominal.tip_name(static_cast<int>(t)), fit.tip_rms_before[t] * 1e3,
                              fit.tip_rms_after[t] * 1e3));
  }
  return out;
}

}  // namespace hapticcal
