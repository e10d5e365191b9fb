// The outcome checks issue 25 added to calibrate: step 2's plausibility
// (a link moved beyond 10 tolerances), and step 1 alone on a log of encoders.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>

#include "hapticcal/identification/identification.hpp"
#include "identification/calibration_run.hpp"

namespace hapticcal::detail {

namespace {

// Whether link parameter `slot` trades with the set-up (README "Step 2's
// plausibility check"): a parameter of the first joint while the base is free,
// of the last while the tool is (the frame's and the marker's neighbours).
// `info`: step 2's parameters (the problem's model: instrument and joint-error
// slots included).
bool next_to_setup(const CalibrationRun& run, const std::vector<ParameterInfo>& info, int slot) {
  const auto free_in = [&](int joint) {
    for (int s : run.identified) {
      if (info[s].joint == joint) return true;
    }
    return false;
  };
  const int dof = run.problem.model.dof();
  return (info[slot].joint == 0 && free_in(-1)) || (info[slot].joint == dof - 1 && free_in(dof));
}

}  // namespace

// The default's plausibility check: a converged fit whose link parameter (not
// next to the set-up) moved beyond kImplausiblePriorSds sds of its stated prior
// (its tolerance) is unusable; the worst such parameter is the reason.
void refuse_implausible(CalibrationRun& run) {
  CalibrationResult& result = run.result;
  KinematicFit& fit = run.fit();
  if (!std::isfinite(run.prior_scale)) return;  // no prior: --keep-all, --select
  const Eigen::VectorXd start = run.step2_nominal.kinematic_parameters();
  // Step 2's layout: run.model has lost the instrument and the joint errors by now.
  const std::vector<ParameterInfo> info = run.problem.model.parameter_info();
  const int dof = run.problem.model.dof();
  int worst = -1;
  fit.most_moved_sds = 0;
  for (int slot : run.identified) {
    const bool link = info[slot].joint >= 0 && info[slot].joint < dof;
    if (!link || !std::isfinite(run.tolerance[slot]) || next_to_setup(run, info, slot)) continue;
    const double sds = std::abs(run.p[slot] - start[slot]) / run.tolerance[slot];
    if (sds > fit.most_moved_sds) {
      worst = slot;
      fit.most_moved_sds = sds;
    }
  }
  if (worst >= 0) fit.most_moved = run.name.at(worst);
  if (result.status != CalibrationStatus::kConverged || fit.most_moved_sds <= kImplausiblePriorSds)
    return;
  const DisplayUnit u = display_unit(info[worst].unit);
  result.status = CalibrationStatus::kImplausible;
  result.status_reason = fmt::format(
      "{} moved {:.4g} {}, {:.0f} times its tolerance {:.4g} {} (the limit is {:g}): not a "
      "deviation of this device; check step 1, the model and the log (or state its tolerance "
      "with --tolerance {}=...)",
      run.name.at(worst), (run.p[worst] - start[worst]) * u.scale, u.unit, fit.most_moved_sds,
      run.tolerance[worst] * u.scale, u.unit, kImplausiblePriorSds, run.name.at(worst));
}

// A log of external encoders only: step 1 is the calibration. The kinematic
// parameters stay the model's; usable when every transmission fit converged.
CalibrationResult conclude_step_one(CalibrationRun& run) {
  CalibrationResult& result = run.result;
  result.step_one_only = true;
  result.calibrated = run.model;
  result.notes.insert(result.notes.begin(),
                      "the log has external encoders and no measurements: step 1 "
                      "(transmissions) alone; the kinematic parameters are the model's");
  for (const TransmissionFit& t : result.transmissions) {
    if (!t.converged || !t.value.allFinite() || !std::isfinite(t.rms_after)) {
      result.status =
          t.converged ? CalibrationStatus::kNumericalFailure : CalibrationStatus::kNotConverged;
      result.status_reason =
          fmt::format("step 1: the transmission fit of {} {}", run.model.links[t.joint].name,
                      t.converged ? "is not finite" : "did not converge");
      return std::move(result);
    }
  }
  result.status_reason =
      fmt::format("step 1 alone: {} transmission{} fitted", result.transmissions.size(),
                  result.transmissions.size() == 1 ? "" : "s");
  for (const TransmissionFit& t : result.transmissions) {
    if (!t.flagged) continue;
    const std::string why = step_one_flag_reason(t, run.model, *run.options.encoder_resolution);
    result.kinematics.suspect.suspect = true;
    result.kinematics.suspect.reasons.push_back(why);
    if (run.options.strict && result.status == CalibrationStatus::kConverged) {
      result.status = CalibrationStatus::kSuspect;
      result.status_reason = "suspect fit (--strict): " + why;
    }
  }
  return std::move(result);
}

}  // namespace hapticcal::detail
