// The joint-error family "backlash" (families/family.hpp).
#include <fmt/format.h>

#include "hapticcal/core/error.hpp"
#include "identification/calibration_run.hpp"
#include "identification/families/family.hpp"

namespace hapticcal::detail {
namespace {

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

class BacklashFamily : public JointErrorFamily {
 public:
  std::string_view name() const override { return "backlash"; }
  bool applies(const CalibrationRun& run) const override {
    for (int i = 0; i < run.model.dof(); ++i) {
      if (run.poses.directed(i) && run.poses.direction.col(i).any()) return true;
    }
    return false;
  }
  void offer(CalibrationRun& run) const override { offer_backlash(run); }
  void add_stages(const DeviceModel& model, const AddStage& add) const override {
    int slot = model.structure().backlash_slot();
    for (const int i : model.fitted_backlash) add(i, slot++, 1, model.links[i].backlash, nullptr);
  }
  // A backlash's feature: the side the joint approached the pose from.
  class Sides : public PoseFeatures {
   public:
    explicit Sides(const DeviceModel& model) : model_(model) {}
    void operator()(const double*, const Eigen::VectorXd&,
                    const Eigen::Ref<const Eigen::RowVectorXd>& direction,
                    double* out) const override {
      for (const int i : model_.fitted_backlash)
        *out++ = direction.size() == model_.dof() ? direction[i] : 0.0;
    }

   private:
    const DeviceModel& model_;
  };
  std::unique_ptr<PoseFeatures> pose_features(const DeviceModel& model) const override {
    if (model.fitted_backlash.empty()) return nullptr;
    return std::make_unique<Sides>(model);
  }
  // Each fitted backlash is the link's now.
  std::string fold(DeviceModel& model) const override {
    model.fitted_backlash.clear();
    return "";
  }
};

}  // namespace

const JointErrorFamily* backlash_family() {
  static const BacklashFamily family;
  return &family;
}

}  // namespace hapticcal::detail
