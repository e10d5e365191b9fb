// Step 1 alone on a log of external encoders: its outcome.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>

#include "hapticcal/identification/identification.hpp"
#include "identification/calibration_run.hpp"

namespace hapticcal::detail {

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
