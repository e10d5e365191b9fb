// The joint-error families (families/family.hpp): one line a family, in the
// model search's order.
#include <fmt/format.h>

#include <algorithm>
#include <mutex>
#include <set>
#include <stdexcept>

#include "identification/families/family.hpp"

namespace hapticcal::detail {

const JointErrorFamily* compliance_family();
const JointErrorFamily* harmonic_family();
const JointErrorFamily* coupling_family();
const JointErrorFamily* backlash_family();
const JointErrorFamily* lateral_family();

namespace {

std::vector<const JointErrorFamily*>& registry() {
  static std::vector<const JointErrorFamily*> families = {
      compliance_family(), harmonic_family(), coupling_family(),
      backlash_family(),   lateral_family(),
  };
  return families;
}

}  // namespace

}  // namespace hapticcal::detail

namespace hapticcal {

const std::vector<const JointErrorFamily*>& joint_error_families() { return detail::registry(); }

void register_joint_error_family(const JointErrorFamily* family) {
  if (find_joint_error_family(family->name()) || family->name() == "none") {
    throw std::invalid_argument(
        fmt::format("joint-error family '{}': a family has that name", family->name()));
  }
  detail::registry().push_back(family);
}

void add_block(FamilyOffer& offer, const DeviceModel::FittedBlock& block) {
  // A block names its family, and its parameters' names name nothing else
  // (the geometry's "j2.a", another family's): --fix, --free, --tolerance and
  // the results go by name.
  if (!find_joint_error_family(block.family)) {
    throw std::logic_error(
        fmt::format("a joint-error block of '{}', which is no registered family", block.family));
  }
  std::set<std::string> names;
  for (const ParameterInfo& p : offer.model.parameter_info()) names.insert(p.name);
  for (const DeviceModel::FittedParameter& f : block.parameters) {
    const std::string name = offer.model.links.at(f.link).name + "." + f.name;
    if (!names.insert(name).second) {
      throw std::logic_error(fmt::format(
          "joint-error family '{}': its parameter {} has the name of another", block.family, name));
    }
  }
  // The block's family name as the registry keeps it: a pointer that outlives
  // whatever string the family built its block from.
  // (The model search offers from several threads.)
  static std::mutex guard;
  static std::set<std::string> interned;
  DeviceModel::FittedBlock kept = block;
  {
    const std::lock_guard<std::mutex> lock(guard);
    kept.family = interned.emplace(block.family).first->c_str();
  }
  offer.model.fitted.push_back(kept);
  offer.nominal.fitted.push_back(kept);
}

bool own_reading(const DeviceModel& m, int i) {
  return !m.coupled() || (m.coupling.row(i) == Eigen::RowVectorXd::Unit(m.dof(), i) &&
                          m.coupling.col(i) == Eigen::VectorXd::Unit(m.dof(), i));
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

}  // namespace hapticcal
