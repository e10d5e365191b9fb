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
};

}  // namespace

const JointErrorFamily* backlash_family() {
  static const BacklashFamily family;
  return &family;
}

}  // namespace hapticcal::detail
