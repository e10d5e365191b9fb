// The joint-error family "coupling" (families/family.hpp).
#include <fmt/format.h>

#include "hapticcal/core/error.hpp"
#include "identification/calibration_run.hpp"
#include "identification/families/family.hpp"

namespace hapticcal::detail {
namespace {

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

class CouplingFamily : public JointErrorFamily {
 public:
  std::string_view name() const override { return "coupling"; }
  bool applies(const CalibrationRun& run) const override { return coupled_between(run.model); }
  void offer(CalibrationRun& run) const override { offer_coupling(run); }
  void add_stages(const DeviceModel& model, const AddStage& add) const override {
    int slot = model.structure().coupling_slot();
    for (const auto& [i, k] : model.fitted_coupling)
      add(i, slot++, 1, model.coupling(i, k), nullptr);
  }
  // A coefficient C_ik's feature: reading k through its own transmission.
  class Readings : public PoseFeatures {
   public:
    explicit Readings(const DeviceModel& model) : model_(model) {}
    void operator()(const double*, const Eigen::VectorXd& q,
                    const Eigen::Ref<const Eigen::RowVectorXd>&, double* out) const override {
      for (const auto& [i, k] : model_.fitted_coupling)
        *out++ = q[k] + model_.links[k].transmission.error(q[k]);
    }

   private:
    const DeviceModel& model_;
  };
  std::unique_ptr<PoseFeatures> pose_features(const DeviceModel& model) const override {
    if (model.fitted_coupling.empty()) return nullptr;
    return std::make_unique<Readings>(model);
  }
  // The fitted coefficients are the coupling now.
  std::string fold(DeviceModel& model) const override {
    if (model.fitted_coupling.empty()) return "";
    model.fitted_coupling.clear();
    const std::string why = coupling_problem(model.coupling, model.links);
    return why.empty() ? "" : "the coupling as fitted is no coupling: " + why;
  }
};

}  // namespace

const JointErrorFamily* coupling_family() {
  static const CouplingFamily family;
  return &family;
}

}  // namespace hapticcal::detail
