// The joint-error families (families/family.hpp): one line a family, in the
// model search's order.
#include <algorithm>

#include "identification/families/family.hpp"

namespace hapticcal::detail {

const JointErrorFamily* compliance_family();
const JointErrorFamily* harmonic_family();
const JointErrorFamily* coupling_family();
const JointErrorFamily* backlash_family();

const std::vector<const JointErrorFamily*>& joint_error_families() {
  static const std::vector<const JointErrorFamily*> families = {
      compliance_family(),
      harmonic_family(),
      coupling_family(),
      backlash_family(),
  };
  return families;
}

const JointErrorFamily* find_joint_error_family(std::string_view name) {
  const auto& all = joint_error_families();
  const auto it = std::find_if(all.begin(), all.end(),
                               [&](const JointErrorFamily* f) { return f->name() == name; });
  return it == all.end() ? nullptr : *it;
}

}  // namespace hapticcal::detail
