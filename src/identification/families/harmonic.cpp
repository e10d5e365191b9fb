// The joint-error family "harmonic" (families/family.hpp).
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <stdexcept>

#include "hapticcal/core/error.hpp"
#include "identification/calibration_run.hpp"
#include "identification/families/family.hpp"

namespace hapticcal::detail {

const JointErrorFamily* harmonic_family();

namespace {

// "harmonic": each turning joint gets a Harmonic stage of its angle's first and
// second harmonic, and its motor's where a capstan (alone or in a chain) gives
// the ratio R.
void offer_harmonics(FamilyOffer& offer) {
  std::vector<Transmission> stages(offer.model.dof());
  std::vector<std::string> coupled;
  for (int i = 0; i < offer.model.dof(); ++i) {
    const Link& l = offer.model.links[i];
    if (l.prismatic()) continue;
    // A stage is folded into the link's transmission, on its reading: only
    // where the joint's angle is its own reading alone and no other joint's uses it.
    if (!own_reading(offer.model, i)) {
      coupled.push_back(l.name);
      continue;
    }
    Harmonic h;
    h.frequencies = {1, 2};
    if (const double ratio = l.transmission.drive_ratio(); ratio > 2) {
      h.frequencies.push_back(ratio);
      h.frequencies.push_back(2 * ratio);
    }
    h.coefficients.assign(2 * h.frequencies.size(), 0.0);
    stages[i] = Transmission(h);
  }
  if (!coupled.empty()) {
    offer.notes.push_back(fmt::format(
        "--joint-errors: no harmonic stage on the coupled joint(s) {} (a stage acts on the "
        "joint's own reading, which the coupling mixes with others)",
        fmt::join(coupled, ", ")));
  }
  offer.model.joint_errors = stages;
  offer.nominal.joint_errors = stages;
  const DeviceModel::FittedBlock block = harmonic_family()->block(offer.model);
  if (!block.parameters.empty()) add_block(offer, block);
}

class HarmonicFamily : public JointErrorFamily {
 public:
  std::string_view name() const override { return "harmonic"; }
  bool applies(const DeviceModel& model, const Log&) const override {
    for (int i = 0; i < model.dof(); ++i) {
      if (!model.links[i].prismatic() && own_reading(model, i)) return true;
    }
    return false;
  }
  void offer(FamilyOffer& o) const override { offer_harmonics(o); }
  // Its parameters are the stages' coefficients: link i's c-th, element c.
  DeviceModel::FittedBlock block(const DeviceModel& model) const override {
    DeviceModel::FittedBlock block{"harmonic", {}};
    for (int i = 0; i < static_cast<int>(model.joint_errors.size()); ++i) {
      const std::vector<std::string> names = model.joint_errors[i].parameter_names();
      for (int c = 0; c < static_cast<int>(names.size()); ++c) {
        DeviceModel::FittedParameter h{names[c], ParameterUnit::kAngle, i, c};
        h.get = [](const DeviceModel& m, const DeviceModel::FittedParameter& f) {
          return m.joint_errors[f.link].parameters()[f.element];
        };
        h.set = [](DeviceModel& m, const DeviceModel::FittedParameter& f, double value) {
          Transmission& stage = m.joint_errors[f.link];
          Eigen::VectorXd v = stage.parameters();
          v[f.element] = value;
          stage.set_parameters(v.data());
        };
        block.parameters.push_back(h);
      }
    }
    return block;
  }
  void add_stages(const DeviceModel& model, const AddStage& add) const override {
    const DeviceModel::FittedBlock* block = model.fitted_block(name());
    if (!block) return;  // stages without their block have no slots
    int slot = model.fitted_slot(name());
    for (int i = 0; i < static_cast<int>(model.joint_errors.size()); ++i) {
      const Transmission& stage = model.joint_errors[i];
      if (stage.is_none()) continue;
      const Link& l = model.links[i];
      if (l.prismatic() || stage.kind() != TransmissionKind::kHarmonic) {
        throw InputError(
            fmt::format("{}: a joint-error stage must be harmonics of a turning joint", l.name));
      }
      add(i, slot, stage.num_parameters(), 0.0, &stage);
      slot += stage.num_parameters();
    }
    if (slot != model.fitted_slot(name()) + static_cast<int>(block->parameters.size())) {
      throw std::logic_error("the harmonic block does not match the model's joint-error stages");
    }
  }
  // Each stage as fitted folded into its link's transmission (after the
  // link's own: the angle v becomes v + stage(v)); a stage whose coefficients
  // all stayed zero is left out.
  std::string fold(DeviceModel& model) const override {
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
    drop_block(model, name());
    return refused;
  }
  // A gear's or capstan's transmission error, ~0.1-1 mrad (the paper's drums).
  double tolerance() const override { return 1e-3; }
};

}  // namespace

const JointErrorFamily* harmonic_family() {
  static const HarmonicFamily family;
  return &family;
}

}  // namespace hapticcal::detail
