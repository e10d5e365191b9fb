// The joint-error family "coupling" (families/family.hpp).
#include <fmt/format.h>

#include "hapticcal/core/error.hpp"
#include "identification/calibration_run.hpp"
#include "identification/families/family.hpp"

namespace hapticcal::detail {

const JointErrorFamily* coupling_family();

namespace {

// "coupling": each coefficient C_ik (i != k) the model's coupling declares is a
// step-2 parameter (the reading u_k its feature): a drive's coupling ratio, a
// passive joint's share of the joints that drive it. The diagonal is each
// joint's own scale, a transmission's (step 1), and a zero stays zero.
void offer_coupling(FamilyOffer& offer) {
  const DeviceModel& m = offer.model;
  if (!m.coupled()) {
    throw InputError(
        "--joint-errors coupling: the model has no coupled joints (give the device file's "
        "coupling, or a URDF's <mimic>)");
  }
  const DeviceModel::FittedBlock block = coupling_family()->block(m);
  if (block.parameters.empty()) {
    throw InputError(
        "--joint-errors coupling: the model's coupling has no coefficient between two joints "
        "(only the diagonal, which the transmissions scale)");
  }
  add_block(offer, block);
}

class CouplingFamily : public JointErrorFamily {
 public:
  std::string_view name() const override { return "coupling"; }
  bool applies(const DeviceModel& model, const Log&) const override {
    return coupled_between(model);
  }
  void offer(FamilyOffer& o) const override { offer_coupling(o); }
  // C_ik: the parameter of link i, element k, named "c_<joint k>".
  DeviceModel::FittedBlock block(const DeviceModel& model) const override {
    DeviceModel::FittedBlock block{"coupling", {}};
    for (int i = 0; i < model.dof() && model.coupled(); ++i) {
      for (int k = 0; k < model.dof(); ++k) {
        if (i == k || model.coupling(i, k) == 0) continue;
        DeviceModel::FittedParameter c{"c_" + model.links[k].name, ParameterUnit::kAngle, i, k};
        c.get = [](const DeviceModel& m, const DeviceModel::FittedParameter& f) {
          return m.coupling(f.link, f.element);
        };
        c.set = [](DeviceModel& m, const DeviceModel::FittedParameter& f, double value) {
          m.coupling(f.link, f.element) = value;
        };
        block.parameters.push_back(c);
      }
    }
    return block;
  }
  void add_stages(const DeviceModel& model, const AddStage& add) const override {
    add_block_stages(model, name(), add, [&](const DeviceModel::FittedParameter& f) {
      return model.coupling(f.link, f.element);
    });
  }
  // A coefficient C_ik's feature: reading k through its own transmission.
  class Readings : public PoseFeatures {
   public:
    explicit Readings(const DeviceModel& model) : model_(model) {}
    void operator()(const double*, const Eigen::VectorXd& q,
                    const Eigen::Ref<const Eigen::RowVectorXd>&, double* out) const override {
      for (const auto& c : model_.fitted_block("coupling")->parameters)
        *out++ = q[c.element] + model_.links[c.element].transmission.error(q[c.element]);
    }

   private:
    const DeviceModel& model_;
  };
  std::unique_ptr<PoseFeatures> pose_features(const DeviceModel& model) const override {
    if (!model.fitted_block(name())) return nullptr;
    return std::make_unique<Readings>(model);
  }
  // The fitted coefficients are the coupling now.
  std::string fold(DeviceModel& model) const override {
    if (!model.fitted_block(name())) return "";
    drop_block(model, name());
    const std::string why = coupling_problem(model.coupling, model.links);
    return why.empty() ? "" : "the coupling as fitted is no coupling: " + why;
  }
  // A drive's ratio to 1 %.
  double tolerance() const override { return 1e-2; }
};

}  // namespace

const JointErrorFamily* coupling_family() {
  static const CouplingFamily family;
  return &family;
}

}  // namespace hapticcal::detail
