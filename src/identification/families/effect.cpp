// The step-2 family of a registered joint effect (model/joint_effect.hpp): one
// parameter c a link, the effect's value, its feature the effect's f at the
// joint's reading; folded into the link's effects.
#include <fmt/format.h>

#include <memory>
#include <string>
#include <vector>

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/joint_error_family.hpp"
#include "hapticcal/model/joint_effect.hpp"

namespace hapticcal {
namespace {

// Its features: f(q) of each parameter's link at the pose's readings.
class EffectFeatures : public PoseFeatures {
 public:
  EffectFeatures(const JointEffect& effect, const DeviceModel::FittedBlock& block)
      : effect_(effect), block_(block) {}
  void operator()(const double*, const Eigen::VectorXd& q,
                  const Eigen::Ref<const Eigen::RowVectorXd>&, double* out) const override {
    for (const DeviceModel::FittedParameter& f : block_.parameters)
      *out++ = effect_.feature(q[f.link]);
  }

 private:
  const JointEffect& effect_;
  const DeviceModel::FittedBlock& block_;
};

class EffectFamily : public JointErrorFamily {
 public:
  explicit EffectFamily(const JointEffect& effect) : effect_(effect), name_(effect.name()) {}
  std::string_view name() const override { return name_; }
  // Every joint whose reading is its own (a coupling mixes readings).
  bool applies(const DeviceModel& model, const Log&) const override {
    return !block(model).parameters.empty();
  }
  void offer(FamilyOffer& offer) const override {
    const DeviceModel::FittedBlock b = block(offer.model);
    if (b.parameters.empty()) {
      throw InputError(
          fmt::format("--joint-errors {}: no joint reads its own reading alone", effect_.name()));
    }
    add_block(offer, b);
  }
  // c of each such link, starting from the link's own value (the block keeps
  // it: the model's effects are the fold's).
  DeviceModel::FittedBlock block(const DeviceModel& model) const override {
    DeviceModel::FittedBlock b{name_.c_str(), {}};
    for (int i = 0; i < model.dof(); ++i) {
      if (!own_reading(model, i)) continue;
      DeviceModel::FittedParameter p{name_, ParameterUnit::kAngle, i, i};
      if (model.links[i].prismatic()) p.unit = ParameterUnit::kLength;
      p.value = value(model.links[i]);
      b.parameters.push_back(p);
    }
    return b;
  }
  // Each stage's value in the joint values: the link's own (compensate adds it).
  void add_stages(const DeviceModel& model, const AddStage& add) const override {
    add_block_stages(model, name(), add, [&](const DeviceModel::FittedParameter& f) {
      return value(model.links[f.link]);
    });
  }
  std::unique_ptr<PoseFeatures> pose_features(const DeviceModel& model) const override {
    const DeviceModel::FittedBlock* b = model.fitted_block(name());
    if (!b) return nullptr;
    return std::make_unique<EffectFeatures>(effect_, *b);
  }
  std::string fold(DeviceModel& model) const override {
    const DeviceModel::FittedBlock* b = model.fitted_block(name());
    if (!b) return "";
    for (const DeviceModel::FittedParameter& f : b->parameters) {
      if (f.value == 0) {
        model.links[f.link].effects.erase(name_);
      } else {
        model.links[f.link].effects[name_] = f.value;
      }
    }
    drop_block(model, name());
    return "";
  }
  double tolerance() const override { return effect_.bound(); }

 private:
  // The link's c of this effect (0 without it).
  double value(const Link& link) const {
    const auto it = link.effects.find(name_);
    return it == link.effects.end() ? 0.0 : it->second;
  }

  const JointEffect& effect_;
  const std::string name_;  // the block's family name lives as long as the family
};

}  // namespace

void register_joint_effect_family(const JointEffect* effect) {
  static std::vector<std::unique_ptr<EffectFamily>> families;
  register_joint_effect(effect);
  families.push_back(std::make_unique<EffectFamily>(*effect));
  register_joint_error_family(families.back().get());
}

}  // namespace hapticcal
