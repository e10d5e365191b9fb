// The joint-error families (families/family.hpp): one line a family, in the
// model search's order.
#include <algorithm>

#include "identification/calibration_run.hpp"
#include "identification/families/family.hpp"

namespace hapticcal::detail {

const JointErrorFamily* compliance_family();
const JointErrorFamily* harmonic_family();
const JointErrorFamily* coupling_family();
const JointErrorFamily* backlash_family();

namespace {

std::vector<const JointErrorFamily*>& registry() {
  static std::vector<const JointErrorFamily*> families = {
      compliance_family(),
      harmonic_family(),
      coupling_family(),
      backlash_family(),
  };
  return families;
}

}  // namespace

const std::vector<const JointErrorFamily*>& joint_error_families() { return registry(); }

void register_joint_error_family(const JointErrorFamily* family) {
  if (!find_joint_error_family(family->name())) registry().push_back(family);
}

void add_block(CalibrationRun& run, const DeviceModel::FittedBlock& block) {
  run.model.fitted.push_back(block);
  run.step2_nominal.fitted.push_back(block);
}

void add_block_stages(const DeviceModel& model, std::string_view family, const AddStage& add,
                      const std::function<double(const DeviceModel::FittedParameter&)>& nominal) {
  const DeviceModel::FittedBlock* block = model.fitted_block(family);
  if (!block) return;
  int slot = model.fitted_slot(family);
  for (const DeviceModel::FittedParameter& f : block->parameters)
    add(f.link, slot++, 1, nominal(f), nullptr);
}

void drop_block(DeviceModel& model, std::string_view family) {
  std::erase_if(model.fitted,
                [&](const DeviceModel::FittedBlock& b) { return family == b.family; });
}

const JointErrorFamily* find_joint_error_family(std::string_view name) {
  const auto& all = joint_error_families();
  const auto it = std::find_if(all.begin(), all.end(),
                               [&](const JointErrorFamily* f) { return f->name() == name; });
  return it == all.end() ? nullptr : *it;
}

}  // namespace hapticcal::detail
