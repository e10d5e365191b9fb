// Joint errors in step 2 (issue 25): the families offered to the fit, folded
// into the calibrated model, and what they bought on held-out poses.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/identification.hpp"
#include "identification/calibration_run.hpp"

namespace hapticcal::detail {

// The joint-error families of step 2 (CalibrationOptions::joint_errors): each
// turning joint gets a Harmonic stage of its angle's first and second harmonic,
// and its motor's where a capstan (alone or in a chain) gives the ratio R.
void offer_joint_errors(CalibrationRun& run) {
  if (run.options.joint_errors.empty()) return;
  run.fit().joint_error_families = run.options.joint_errors;
  std::vector<Transmission> stages(run.model.dof());
  for (int i = 0; i < run.model.dof(); ++i) {
    const Link& l = run.model.links[i];
    if (l.prismatic()) continue;
    Harmonic h;
    h.frequencies = {1, 2};
    const Transmission& t = l.transmission;
    const Capstan* capstan = std::get_if<Capstan>(&t.model());
    if (const auto* chain = std::get_if<Chain>(&t.model())) {
      for (const Transmission& stage : chain->stages)
        capstan = capstan ? capstan : std::get_if<Capstan>(&stage.model());
    }
    if (capstan && capstan->ratio > 2) {
      h.frequencies.push_back(capstan->ratio);
      h.frequencies.push_back(2 * capstan->ratio);
    }
    h.coefficients.assign(2 * h.frequencies.size(), 0.0);
    stages[i] = Transmission(h);
  }
  run.model.joint_errors = stages;
  run.step2_nominal.joint_errors = stages;
}

// The joint-error stages as fitted, folded into the calibrated model's
// transmissions (after the link's own: the angle v becomes v + stage(v)); a
// stage whose coefficients all stayed zero is left out.
std::string fold_joint_errors(DeviceModel& model) {
  std::string refused;
  for (int i = 0; i < static_cast<int>(model.joint_errors.size()); ++i) {
    const Transmission& stage = model.joint_errors[i];
    if (stage.is_none() || stage.parameters().isZero(0)) continue;
    if (const std::string why = stage.check(model.links[i].lower, model.links[i].upper);
        !why.empty() && refused.empty()) {
      refused = fmt::format("{}'s joint-error stage as fitted is no transmission: {}",
                            model.links[i].name, why);
    }
    Transmission& t = model.links[i].transmission;
    t = t.is_none() ? stage : Transmission(Chain{{t, stage}});
  }
  model.joint_errors.clear();
  return refused;
}

// What the joint-error families bought: the same calibration without them,
// its cross-validated RMS beside the run's.
void compare_without_joint_errors(const DeviceModel& nominal, const Log& log,
                                  const CalibrationOptions& options, CalibrationRun& run) {
  // The options without the joint errors' names (they name no parameter there).
  CalibrationOptions plain = options;
  plain.joint_errors.clear();
  std::set<std::string> names;
  const std::vector<ParameterInfo> info = run.problem.model.parameter_info();
  for (const ParameterInfo& p : info) {
    if (p.joint == joint_error_block(run.problem.model.dof())) names.insert(p.name);
  }
  const auto named = [&](const std::string& n) { return names.count(n) > 0; };
  std::erase_if(plain.fix, named);
  std::erase_if(plain.free, named);
  std::erase_if(plain.tolerances.by_name, [&](const auto& item) { return named(item.first); });
  KinematicFit& fit = run.fit();
  CalibrationResult without;
  try {
    without = calibrate(nominal, log, plain);
  } catch (const InputError& e) {
    run.result.notes.push_back(
        fmt::format("joint errors ({}): the calibration without them could not run: {}",
                    fmt::join(options.joint_errors, ", "), e.what()));
    return;
  }
  fit.cv_rms_without_joint_errors = without.kinematics.cv_rms;
  run.result.notes.push_back(fmt::format(
      "joint errors ({}): held-out RMS {:.4f} mm with them, {:.4f} mm without (the geometry "
      "alone, {})",
      fmt::join(options.joint_errors, ", "), fit.cv_rms * 1e3, without.kinematics.cv_rms * 1e3,
      to_string(without.status)));
}

}  // namespace hapticcal::detail
