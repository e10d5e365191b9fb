// The joint-error family "lateral" (families/family.hpp): lateral compliance.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <array>
#include <cmath>

#include "hapticcal/core/error.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "identification/families/family.hpp"

namespace hapticcal::detail {

const JointErrorFamily* lateral_family();

namespace {

// A URDF joint turning about its origin's x axis: its bend (about that axis)
// would be its own turn, which "compliance" fits.
bool can_bend(const Link& l) {
  return l.geometry != Geometry::kOrigin || l.prismatic() || std::abs(l.axis.x()) < 0.9;
}

// "lateral": each joint's lateral compliance c (Link::lateral_compliance) is a
// step-2 parameter "kx"; its stage bends the link about its lateral axis
// (kinematics.hpp) by c tau_x, tau_x its lateral gravity torque at the pose (the start's geometry
// and masses, the joint values before deflection: the feature).
void offer_lateral(FamilyOffer& offer) {
  gravity_loads(offer, "lateral", "kx");
  DeviceModel::FittedBlock block = lateral_family()->block(offer.model);
  std::vector<std::string> skipped;
  std::erase_if(block.parameters, [&](const DeviceModel::FittedParameter& f) {
    const Link& l = offer.model.links[f.link];
    if (can_bend(l)) return false;
    skipped.push_back(l.name);
    return true;
  });
  if (!skipped.empty()) {
    offer.notes.push_back(fmt::format(
        "--joint-errors lateral: {} turn about their origin's x axis, so a bend about it is their "
        "own turn (compliance): no lateral compliance fitted there",
        fmt::join(skipped, ", ")));
  }
  if (block.parameters.empty()) {
    throw InputError("--joint-errors lateral: no joint can bend about an axis of its own");
  }
  add_block(offer, block);
}

class LateralFamily : public JointErrorFamily {
 public:
  std::string_view name() const override { return "lateral"; }
  // Offered unasked only where the model gives the masses: a lateral torque
  // from lumped masses is a guess at the load's direction.
  bool applies(const DeviceModel& model, const Log&) const override {
    return model.gravity.norm() > 0 &&
           std::any_of(model.links.begin(), model.links.end(),
                       [](const Link& l) { return l.mass > 0; }) &&
           std::any_of(model.links.begin(), model.links.end(), can_bend);
  }
  void offer(FamilyOffer& o) const override { offer_lateral(o); }
  DeviceModel::FittedBlock block(const DeviceModel& model) const override {
    return per_link_block<&Link::lateral_compliance>(model, "lateral", "kx", ParameterUnit::kAngle,
                                                     ParameterUnit::kAngle);
  }
  void add_stages(const DeviceModel& model, const AddStage& add) const override {
    // nominal 0: the kinematics leave a fitted lateral compliance to the stage.
    add_block_stages(model, name(), add, [](const DeviceModel::FittedParameter&) { return 0.0; });
  }
  bool bends() const override { return true; }
  // A lateral compliance's feature: its link's lateral gravity torque at the
  // pose's joint values, from the start's geometry and masses.
  class Torques : public PoseFeatures {
   public:
    explicit Torques(const DeviceModel& model) : model_(model), gravity_(model), prepared_(model) {}
    bool of_joint_values() const override { return true; }
    // On the chain before any deflection (the readings' joint values, as the
    // kinematics form the bend), or the joint values given alone.
    void operator()(const double* joint, const Eigen::VectorXd& q,
                    const Eigen::Ref<const Eigen::RowVectorXd>&, double* out) const override {
      std::array<double, kMaxDof> rigid, tau;
      if (q.size() == model_.dof()) {
        prepared_.rigid_joints(q.data(), rigid.data());
        joint = rigid.data();
      }
      gravity_.lateral_torques(joint, tau.data());
      for (const auto& k : model_.fitted_block("lateral")->parameters) *out++ = tau[k.link];
    }

   private:
    const DeviceModel& model_;
    GravityModel gravity_;
    PreparedModel prepared_;
  };
  std::unique_ptr<PoseFeatures> pose_features(const DeviceModel& model) const override {
    if (!model.fitted_block(name())) return nullptr;
    return std::make_unique<Torques>(model);
  }
  // Each fitted kx is the link's lateral compliance now.
  std::string fold(DeviceModel& model) const override {
    drop_block(model, name());
    return "";
  }
  double tolerance() const override { return 1e-3; }  // rad / N m
};

}  // namespace

const JointErrorFamily* lateral_family() {
  static const LateralFamily family;
  return &family;
}

}  // namespace hapticcal::detail
