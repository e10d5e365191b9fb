#include "hapticcal/model.hpp"

#include <cassert>

namespace hapticcal {

Eigen::VectorXd DeviceModel::kinematic_parameters() const {
  const ChainStructure s = structure();
  Eigen::VectorXd p = Eigen::VectorXd::Zero(s.num_slots());
  for (int k = 0; k < kBaseSlots; ++k) p[k] = base[k];
  for (int i = 0; i < dof(); ++i) {
    const Link& l = links[i];
    p.segment<kLinkSlots>(s.link_slot(i)) << l.a, l.alpha, l.d, l.theta, l.beta;
  }
  for (int k = 0; k < kToolSlots; ++k) p[s.tool_slot() + k] = tool[k];
  return p;
}

void DeviceModel::set_kinematic_parameters(const Eigen::VectorXd& p) {
  const ChainStructure s = structure();
  assert(p.size() == s.num_slots());
  for (int k = 0; k < kBaseSlots; ++k) base[k] = p[k];
  for (int i = 0; i < dof(); ++i) {
    Link& l = links[i];
    const int o = s.link_slot(i);
    l.a = p[o + kLinkA];
    l.alpha = p[o + kLinkAlpha];
    l.d = p[o + kLinkD];
    l.theta = p[o + kLinkTheta];
    l.beta = p[o + kLinkBeta];
  }
  for (int k = 0; k < kToolSlots; ++k) tool[k] = p[s.tool_slot() + k];
}

std::vector<ParameterInfo> DeviceModel::parameter_info() const {
  using U = ParameterUnit;
  const ChainStructure s = structure();
  std::vector<ParameterInfo> info;
  if (base_kind == BaseKind::kDh) {
    info.push_back({"base.a", 0, U::kLength});
    info.push_back({"base.alpha", 1, U::kAngle});
    info.push_back({"base.d", 2, U::kLength});
    info.push_back({"base.theta", 3, U::kAngle});
  } else {
    const char* names[] = {"base.x", "base.y", "base.z", "base.roll", "base.pitch", "base.yaw"};
    for (int k = 0; k < 6; ++k) info.push_back({names[k], k, k < 3 ? U::kLength : U::kAngle});
  }
  for (int i = 0; i < dof(); ++i) {
    const std::string& n = links[i].name;
    const int o = s.link_slot(i);
    info.push_back({n + ".a", o + kLinkA, U::kLength});
    info.push_back({n + ".alpha", o + kLinkAlpha, U::kAngle});
    info.push_back({n + ".d", o + kLinkD, U::kLength});
    info.push_back({n + ".theta", o + kLinkTheta, U::kAngle});
    info.push_back({n + ".beta", o + kLinkBeta, U::kAngle});
  }
  const char* tool_names[] = {"tool.x", "tool.y", "tool.z", "tool.roll", "tool.pitch", "tool.yaw"};
  for (int k = 0; k < 6; ++k) {
    info.push_back({tool_names[k], s.tool_slot() + k, k < 3 ? U::kLength : U::kAngle});
  }
  return info;
}

Eigen::VectorXd DeviceModel::compensate(const Eigen::VectorXd& q) const {
  assert(q.size() == dof());
  Eigen::VectorXd joint(dof());
  for (int i = 0; i < dof(); ++i) joint[i] = q[i] + links[i].transmission.error(q[i]);
  return joint;
}

}  // namespace hapticcal
