// The joint-error family "backlash" (families/family.hpp).
#include <fmt/format.h>

#include <algorithm>

#include "hapticcal/core/error.hpp"
#include "identification/families/family.hpp"

namespace hapticcal::detail {

const JointErrorFamily* backlash_family();

namespace {

// "backlash": each joint whose log column dir<i> says from which side it
// approached its poses gets a backlash b (the joint value moves by b s, s the
// side): half the dead band of a gear or a cable, seen only where the same
// joint arrives from both sides.
void offer_backlash(FamilyOffer& offer) {
  const Log& poses = offer.poses;
  std::vector<int> joints;
  for (int i = 0; i < offer.model.dof(); ++i) {
    if (poses.directed(i) && poses.direction.col(i).any()) joints.push_back(i);
  }
  if (joints.empty()) {
    throw InputError(
        "--joint-errors backlash: the log says for no joint from which side it approached its "
        "poses (give dir<i> columns: +1 moving up in q, -1 moving down)");
  }
  DeviceModel::FittedBlock block = backlash_family()->block(offer.model);
  std::erase_if(block.parameters, [&](const DeviceModel::FittedParameter& f) {
    return std::find(joints.begin(), joints.end(), f.link) == joints.end();
  });
  add_block(offer, block);
}

class BacklashFamily : public JointErrorFamily {
 public:
  std::string_view name() const override { return "backlash"; }
  bool applies(const DeviceModel& model, const Log& poses) const override {
    for (int i = 0; i < model.dof(); ++i) {
      if (poses.directed(i) && poses.direction.col(i).any()) return true;
    }
    return false;
  }
  void offer(FamilyOffer& o) const override { offer_backlash(o); }
  DeviceModel::FittedBlock block(const DeviceModel& model) const override {
    return per_link_block<&Link::backlash>(model, "backlash", "backlash", ParameterUnit::kAngle,
                                           ParameterUnit::kLength);
  }
  void add_stages(const DeviceModel& model, const AddStage& add) const override {
    // The joint values are formed with the model's backlash.
    add_block_stages(model, name(), add, [&](const DeviceModel::FittedParameter& f) {
      return model.links[f.link].backlash;
    });
  }
  // A backlash's feature: the side the joint approached the pose from.
  class Sides : public PoseFeatures {
   public:
    explicit Sides(const DeviceModel& model) : model_(model) {}
    void operator()(const double*, const Eigen::VectorXd&,
                    const Eigen::Ref<const Eigen::RowVectorXd>& direction,
                    double* out) const override {
      for (const auto& b : model_.fitted_block("backlash")->parameters)
        *out++ = direction.size() == model_.dof() ? direction[b.link] : 0.0;
    }

   private:
    const DeviceModel& model_;
  };
  std::unique_ptr<PoseFeatures> pose_features(const DeviceModel& model) const override {
    if (!model.fitted_block(name())) return nullptr;
    return std::make_unique<Sides>(model);
  }
  // Each fitted backlash is the link's now.
  std::string fold(DeviceModel& model) const override {
    drop_block(model, name());
    return "";
  }
  // 1 mrad (1 mm for a sliding joint).
  double tolerance() const override { return 1e-3; }
};

}  // namespace

const JointErrorFamily* backlash_family() {
  static const BacklashFamily family;
  return &family;
}

}  // namespace hapticcal::detail
