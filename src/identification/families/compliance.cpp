// The joint-error family "compliance" (families/family.hpp).
#include <fmt/format.h>

#include <array>

#include "hapticcal/core/error.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "identification/families/family.hpp"

namespace hapticcal::detail {

const JointErrorFamily* compliance_family();

void gravity_loads(FamilyOffer& offer, std::string_view family, std::string_view parameter) {
  DeviceModel& m = offer.model;
  if (!(m.gravity.norm() > 0)) {
    throw InputError(fmt::format(
        "--joint-errors {}: the model's gravity is zero, so no joint is loaded: give the "
        "device file's gravity: [gx, gy, gz] (base frame, m/s^2)",
        family));
  }
  bool masses = false;
  for (const Link& l : m.links) masses = masses || l.mass > 0;
  if (masses) return;
  for (DeviceModel* model : {&offer.model, &offer.nominal}) {
    for (Link& l : model->links) {
      l.mass = 1.0;
      l.com.setZero();
    }
  }
  offer.notes.push_back(fmt::format(
      "--joint-errors {}: the model gives no masses: each link is a lumped 1 kg at its "
      "frame's origin (written into the calibrated model), so each {} is in rad per N m of that "
      "model, not of the device's own torques",
      family, parameter));
}

namespace {

// "compliance": every joint's compliance k is a step-2 parameter (its gravity
// torque the feature). Without masses in the model each link is a lumped 1 kg
// at its frame's origin, written into the calibrated model (k then absorbs the
// scale of the true masses).
void offer_compliance(FamilyOffer& offer) {
  gravity_loads(offer, "compliance", "k");
  add_block(offer, compliance_family()->block(offer.model));
}

class ComplianceFamily : public JointErrorFamily {
 public:
  std::string_view name() const override { return "compliance"; }
  bool applies(const DeviceModel& model, const Log&) const override {
    return model.gravity.norm() > 0;
  }
  void offer(FamilyOffer& o) const override { offer_compliance(o); }
  DeviceModel::FittedBlock block(const DeviceModel& model) const override {
    return per_link_block<&Link::compliance>(model, "compliance", "k", ParameterUnit::kAngle,
                                             ParameterUnit::kAngle);
  }
  void add_stages(const DeviceModel& model, const AddStage& add) const override {
    // nominal 0: compensate leaves a fitted compliance's joint undeflected.
    add_block_stages(model, name(), add, [](const DeviceModel::FittedParameter&) { return 0.0; });
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
      for (const auto& k : model_.fitted_block("compliance")->parameters) *out++ = tau[k.link];
    }

   private:
    const DeviceModel& model_;
    GravityModel gravity_;
  };
  std::unique_ptr<PoseFeatures> pose_features(const DeviceModel& model) const override {
    if (!model.fitted_block(name())) return nullptr;
    return std::make_unique<Torques>(model);
  }
  // Each fitted k is the link's compliance now.
  std::string fold(DeviceModel& model) const override {
    drop_block(model, name());
    return "";
  }
  double tolerance() const override { return 1e-3; }  // rad / N m
};

}  // namespace

const JointErrorFamily* compliance_family() {
  static const ComplianceFamily family;
  return &family;
}

}  // namespace hapticcal::detail
