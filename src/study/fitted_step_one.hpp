// The step-1 models as a calibration fitted them, for the two-step Jacobians
// of the study's Cramer-Rao bound (study.cpp) and of an ISO test's predicted
// AP (iso9283_study.cpp). Internal.
#pragma once

#include <string>
#include <vector>

#include "hapticcal/identification/identification.hpp"
#include "hapticcal/identification/two_step.hpp"

namespace hapticcal::detail {

// Each fitted transmission as its joint now has it (a polynomial in its basis),
// with its parameters' dotted names.
inline std::vector<StepOneModel> fitted_step_one(const CalibrationResult& calibration) {
  std::vector<StepOneModel> out;
  for (const TransmissionFit& t : calibration.transmissions) {
    const Transmission& model = calibration.calibrated.links[t.joint].transmission;
    out.push_back(
        {t.joint, model,
         std::vector<std::string>(t.names.begin(), t.names.begin() + model.num_parameters())});
  }
  return out;
}

}  // namespace hapticcal::detail
