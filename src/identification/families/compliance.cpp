// The joint-error family "compliance" (families/family.hpp).
#include <fmt/format.h>

#include <array>

#include "hapticcal/core/error.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
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
  void add_stages(const DeviceModel& model, const AddStage& add) const override {
    int slot = model.structure().compliance_slot();
    for (int i = 0; i < model.dof(); ++i) {
      if (model.compliance_fitted(i)) add(i, slot++, 1, 0.0, nullptr);
    }
  }
  // A compliance's feature: its link's gravity torque at the pose's joint
  // values, from the start's geometry and masses.
  class Torques : public PoseFeatures {
   public:
    explicit Torques(const DeviceModel& model) : model_(model), gravity_(model) {}
    bool of_joint_values() const override { return true; }
    void operator()(const double* joint, const Eigen::VectorXd&,
                    const Eigen::Ref<const Eigen::RowVectorXd>&, double* out) const override {
      std::array<double, kMaxDof> tau;
      gravity_.torques(joint, tau.data());
      for (int i = 0; i < model_.dof(); ++i) {
        if (model_.compliance_fitted(i)) *out++ = tau[i];
      }
    }

   private:
    const DeviceModel& model_;
    GravityModel gravity_;
  };
  std::unique_ptr<PoseFeatures> pose_features(const DeviceModel& model) const override {
    for (int i = 0; i < model.dof(); ++i) {
      if (model.compliance_fitted(i)) return std::make_unique<Torques>(model);
    }
    return nullptr;
  }
  // Each fitted k is the link's compliance now.
  std::string fold(DeviceModel& model) const override {
    model.fitted_compliance.clear();
    return "";
  }
};

}  // namespace

const JointErrorFamily* compliance_family() {
  static const ComplianceFamily family;
  return &family;
}

}  // namespace hapticcal::detail
