// The joint-error family "compliance" (families/family.hpp).
#include <fmt/format.h>

#include "hapticcal/core/error.hpp"
#include "identification/calibration_run.hpp"
#include "identification/families/family.hpp"

namespace hapticcal::detail {
namespace {

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

class ComplianceFamily : public JointErrorFamily {
 public:
  std::string_view name() const override { return "compliance"; }
  bool applies(const CalibrationRun& run) const override { return run.model.gravity.norm() > 0; }
  void offer(CalibrationRun& run) const override { offer_compliance(run); }
};

}  // namespace

const JointErrorFamily* compliance_family() {
  static const ComplianceFamily family;
  return &family;
}

}  // namespace hapticcal::detail
