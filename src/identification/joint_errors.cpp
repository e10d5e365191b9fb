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

namespace {

// "harmonic": each turning joint gets a Harmonic stage of its angle's first and
// second harmonic, and its motor's where a capstan (alone or in a chain) gives
// the ratio R.
void offer_harmonics(CalibrationRun& run) {
  std::vector<Transmission> stages(run.model.dof());
  std::vector<std::string> coupled;
  for (int i = 0; i < run.model.dof(); ++i) {
    const Link& l = run.model.links[i];
    if (l.prismatic()) continue;
    // A stage is folded into the link's transmission, on its reading: only
    // where the joint's angle is its own reading alone and no other joint's uses it.
    const DeviceModel& m = run.model;
    if (m.coupled() && (m.coupling.row(i) != Eigen::RowVectorXd::Unit(m.dof(), i) ||
                        m.coupling.col(i) != Eigen::VectorXd::Unit(m.dof(), i))) {
      coupled.push_back(l.name);
      continue;
    }
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
  if (!coupled.empty()) {
    run.result.notes.push_back(fmt::format(
        "--joint-errors: no harmonic stage on the coupled joint(s) {} (a stage acts on the "
        "joint's own reading, which the coupling mixes with others)",
        fmt::join(coupled, ", ")));
  }
  run.model.joint_errors = stages;
  run.step2_nominal.joint_errors = stages;
}

// "compliance": every joint's compliance k is a step-2 parameter (its gravity
// torque the feature). Without masses in the model each link is a lumped 1 kg
// at its frame's origin, written into the calibrated model (k then absorbs the
// scale of the true masses).
void offer_compliance(CalibrationRun& run) {
  DeviceModel& m = run.model;
  if (!(m.gravity.norm() > 0)) {
    throw InputError(
        "--joint-errors compliance: the model's gravity is zero, so no joint is loaded: give the "
        "device file's gravity: [gx, gy, gz] (base frame, m/s^2)");
  }
  bool masses = false;
  for (const Link& l : m.links) masses = masses || l.mass > 0;
  if (!masses) {
    for (DeviceModel* model : {&run.model, &run.step2_nominal}) {
      for (Link& l : model->links) {
        l.mass = 1.0;
        l.com.setZero();
      }
    }
    run.result.notes.push_back(
        "--joint-errors compliance: the model gives no masses: each link is a lumped 1 kg at its "
        "frame's origin (written into the calibrated model), so each k is in rad per N m of that "
        "model, not of the device's own torques");
  }
  run.model.fitted_compliance.assign(m.dof(), true);
  run.step2_nominal.fitted_compliance.assign(m.dof(), true);
}

// "coupling": each coefficient C_ik (i != k) the model's coupling declares is a
// step-2 parameter (the reading u_k its feature): a drive's coupling ratio, a
// passive joint's share of the joints that drive it. The diagonal is each
// joint's own scale, a transmission's (step 1), and a zero stays zero.
void offer_coupling(CalibrationRun& run) {
  const DeviceModel& m = run.model;
  if (!m.coupled()) {
    throw InputError(
        "--joint-errors coupling: the model has no coupled joints (give the device file's "
        "coupling, or a URDF's <mimic>)");
  }
  std::vector<std::array<int, 2>> entries;
  for (int i = 0; i < m.dof(); ++i) {
    for (int k = 0; k < m.dof(); ++k) {
      if (i != k && m.coupling(i, k) != 0) entries.push_back({i, k});
    }
  }
  if (entries.empty()) {
    throw InputError(
        "--joint-errors coupling: the model's coupling has no coefficient between two joints "
        "(only the diagonal, which the transmissions scale)");
  }
  run.model.fitted_coupling = entries;
  run.step2_nominal.fitted_coupling = entries;
}

// "backlash": each joint whose log column dir<i> says from which side it
// approached its poses gets a backlash b (the joint value moves by b s, s the
// side): half the dead band of a gear or a cable, seen only where the same
// joint arrives from both sides.
void offer_backlash(CalibrationRun& run) {
  const Log& poses = run.poses;
  std::vector<int> joints;
  for (int i = 0; i < run.model.dof(); ++i) {
    if (poses.directed(i) && poses.direction.col(i).any()) joints.push_back(i);
  }
  if (joints.empty()) {
    throw InputError(
        "--joint-errors backlash: the log says for no joint from which side it approached its "
        "poses (give dir<i> columns: +1 moving up in q, -1 moving down)");
  }
  run.model.fitted_backlash = joints;
  run.step2_nominal.fitted_backlash = joints;
}

bool has_family(const CalibrationOptions& options, const char* family) {
  return std::find(options.joint_errors.begin(), options.joint_errors.end(), family) !=
         options.joint_errors.end();
}

}  // namespace

// The joint-error families of step 2 (CalibrationOptions::joint_errors).
void offer_joint_errors(CalibrationRun& run) {
  if (run.options.joint_errors.empty() || run.options.joint_errors.front() == "none") return;
  run.fit().joint_error_families = run.options.joint_errors;
  if (has_family(run.options, "harmonic")) offer_harmonics(run);
  if (has_family(run.options, "compliance")) offer_compliance(run);
  if (has_family(run.options, "coupling")) offer_coupling(run);
  if (has_family(run.options, "backlash")) offer_backlash(run);
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
  model.fitted_compliance.clear();       // each fitted k is the link's compliance now
  model.fitted_backlash.clear();         // likewise each backlash
  if (!model.fitted_coupling.empty()) {  // the fitted coefficients are the coupling now
    model.fitted_coupling.clear();
    if (const std::string why = coupling_problem(model.coupling, model.links);
        !why.empty() && refused.empty()) {
      refused = "the coupling as fitted is no coupling: " + why;
    }
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
  const DeviceModel& m = run.model;
  std::vector<std::string> out;
  if (m.gravity.norm() > 0) out.push_back("compliance");
  bool own_reading = false;  // a turning joint whose angle is its own reading alone
  for (int i = 0; i < m.dof(); ++i) {
    own_reading = own_reading ||
                  (!m.links[i].prismatic() &&
                   (!m.coupled() || (m.coupling.row(i) == Eigen::RowVectorXd::Unit(m.dof(), i) &&
                                     m.coupling.col(i) == Eigen::VectorXd::Unit(m.dof(), i))));
  }
  if (own_reading) out.push_back("harmonic");
  if (coupled_between(m)) out.push_back("coupling");
  bool sides = false;
  for (int i = 0; i < m.dof(); ++i) {
    sides = sides || (run.poses.directed(i) && run.poses.direction.col(i).any());
  }
  if (sides) out.push_back("backlash");
  return out;
}

}  // namespace hapticcal::detail
