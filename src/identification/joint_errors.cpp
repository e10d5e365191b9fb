// Joint errors in step 2: the families (families/) offered to the fit and
// folded into the calibrated model.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/identification.hpp"
#include "identification/calibration_run.hpp"
#include "identification/families/family.hpp"

namespace hapticcal::detail {

// The joint-error families of step 2 (CalibrationOptions::joint_errors), each
// offering its parameters (families/), in the registry's order.
void offer_joint_errors(CalibrationRun& run) {
  const std::vector<std::string>& named = run.options.joint_errors;
  if (named.empty() || named.front() == "none") return;
  run.fit().joint_error_families = named;
  for (const JointErrorFamily* family : joint_error_families()) {
    if (std::find(named.begin(), named.end(), family->name()) == named.end()) continue;
    FamilyOffer offer{run.model, run.step2_nominal, run.poses, run.result.notes};
    family->offer(offer);
  }
}

// The joint-error stages as fitted, folded into the calibrated model's
// transmissions (after the link's own: the angle v becomes v + stage(v)); a
// stage whose coefficients all stayed zero is left out.
std::string fold_joint_errors(DeviceModel& model) {
  std::string refused;
  for (const JointErrorFamily* family : joint_error_families()) {
    const std::string why = family->fold(model);
    if (refused.empty()) refused = why;
  }
  return refused;
}

bool coupled_between(const DeviceModel& m) {
  for (int i = 0; i < m.dof() && m.coupled(); ++i) {
    for (int k = 0; k < m.dof(); ++k) {
      if (i != k && m.coupling(i, k) != 0) return true;
    }
  }
  return false;
}

std::vector<std::string> applicable_families(const CalibrationRun& run) {
  std::vector<std::string> out;
  for (const JointErrorFamily* family : joint_error_families()) {
    if (family->applies(run.model, run.poses)) out.emplace_back(family->name());
  }
  return out;
}

}  // namespace hapticcal::detail
