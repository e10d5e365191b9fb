#include "hapticcal/model/model.hpp"

#include <fmt/format.h>

#include <Eigen/LU>
#include <algorithm>
#include <cassert>
#include <cmath>
#include <stdexcept>
#include <utility>

namespace hapticcal {
namespace {

int block_size(const Link& l) {
  return l.geometry == Geometry::kOrigin ? kOriginSlots : kLinkSlots;
}

const char* const kPoseNames[] = {"x", "y", "z", "roll", "pitch", "yaw"};
const char* const kBaseDhNames[] = {"a", "alpha", "d", "theta"};

}  // namespace

const GeometryTraits& traits(Geometry geometry) {
  static const GeometryTraits table[] = {
      {"dh", true, +1, "after"}, {"mdh", true, -1, "before"}, {"urdf", false, 0, ""}};
  return table[static_cast<int>(geometry)];
}

std::optional<Geometry> geometry_named(const std::string& name) {
  for (Geometry g : {Geometry::kDh, Geometry::kMdh, Geometry::kOrigin}) {
    if (name == traits(g).name) return g;
  }
  return std::nullopt;
}

const char* to_string(JointType type) {
  static const char* const names[] = {"revolute", "continuous", "prismatic"};
  return names[static_cast<int>(type)];
}

std::optional<JointType> joint_type_named(const std::string& name) {
  for (JointType t : {JointType::kRevolute, JointType::kContinuous, JointType::kPrismatic}) {
    if (name == to_string(t)) return t;
  }
  return std::nullopt;
}

const std::vector<std::string>& block_names(Geometry geometry) {
  static const std::vector<std::string> dh = {"a", "alpha", "d", "theta", "beta"};
  static const std::vector<std::string> origin = {"x", "y", "z", "roll", "pitch", "yaw", "offset"};
  return geometry == Geometry::kOrigin ? origin : dh;
}

ChainStructure DeviceModel::structure() const {
  assert(dof() <= kMaxDof);
  ChainStructure s;
  s.base_kind = base_kind;
  s.dof = dof();
  int slot = s.base_slots();
  for (int i = 0; i < dof(); ++i) {
    const Link& l = links[i];
    JointStructure& j = s.joints[i];
    j.geometry = l.geometry;
    j.type = l.type;
    j.axis = {l.axis[0], l.axis[1], l.axis[2]};
    j.slot = slot;
    slot += block_size(l);
  }
  s.tool = slot;
  if (tree()) {
    s.tools_end = slot + kPoseSlots * tips();
    s.tips = tips();
    for (int i = 0; i < dof(); ++i) s.parent[i] = parent(i);
    for (int t = 0; t < tips(); ++t) s.tip_link[t] = tip_link_of(t);
  }
  s.instrument = instrument_zero ? 1 : 0;
  for (const FittedBlock& b : fitted) s.errors += static_cast<int>(b.parameters.size());
  return s;
}

ChainStructure DeviceModel::structure(int tip) const { return structure().tip(tip); }

int ChainStructure::path(int k, int* links) const {
  assert(k >= 0 && k < tips);
  if (tips == 1) {
    for (int i = 0; i < dof; ++i) links[i] = i;
    return dof;
  }
  int n = 0;
  for (int i = tip_link[k]; i >= 0; i = parent[i]) links[n++] = i;
  std::reverse(links, links + n);
  return n;
}

ChainStructure ChainStructure::tip(int k) const {
  if (tips == 1) return *this;
  ChainStructure s = *this;
  std::array<int, kMaxDof> links;
  s.dof = path(k, links.data());
  for (int i = 0; i < s.dof; ++i) s.joints[i] = joints[links[i]];
  s.tool = tool + kPoseSlots * k;
  s.tips = 1;
  return s;
}

int DeviceModel::tip_link_of(int tip) const {
  assert(tip >= 0 && tip < tips());
  if (tip > 0) return branches[tip - 1].link;
  return tip_link >= 0 ? tip_link : dof() - 1;
}

const std::array<double, 6>& DeviceModel::tip_tool(int tip) const {
  assert(tip >= 0 && tip < tips());
  return tip == 0 ? tool : branches[tip - 1].tool;
}

std::array<double, 6>& DeviceModel::tip_tool(int tip) {
  return const_cast<std::array<double, 6>&>(std::as_const(*this).tip_tool(tip));
}

const std::string& DeviceModel::tip_name(int tip) const {
  assert(tip >= 0 && tip < tips());
  return tip == 0 ? this->tip : branches[tip - 1].tip;
}

std::vector<int> DeviceModel::path(int tip) const {
  std::array<int, kMaxDof> links;
  const int n = structure().path(tip, links.data());
  return {links.begin(), links.begin() + n};
}

int DeviceModel::tool_slot(int tip) const { return structure().tool_slot() + kPoseSlots * tip; }

const DeviceModel::FittedBlock* DeviceModel::fitted_block(std::string_view family) const {
  for (const FittedBlock& b : fitted) {
    if (family == b.family) return &b;
  }
  return nullptr;
}

DeviceModel::FittedBlock* DeviceModel::fitted_block(std::string_view family) {
  return const_cast<FittedBlock*>(std::as_const(*this).fitted_block(family));
}

int DeviceModel::fitted_slot(std::string_view family) const {
  int slot = structure().errors_slot();
  for (const FittedBlock& b : fitted) {
    if (family == b.family) break;
    slot += static_cast<int>(b.parameters.size());
  }
  return slot;
}

bool DeviceModel::fitted_element(std::string_view family, int element) const {
  const FittedBlock* b = fitted_block(family);
  if (!b) return false;
  for (const FittedParameter& p : b->parameters) {
    if (p.element == element) return true;
  }
  return false;
}

Eigen::VectorXd DeviceModel::kinematic_parameters() const {
  const ChainStructure s = structure();
  Eigen::VectorXd p(s.num_slots());
  for (int k = 0; k < s.base_slots(); ++k) p[k] = base[k];
  for (int i = 0; i < dof(); ++i) {
    const Link& l = links[i];
    const int o = s.link_slot(i);
    if (l.geometry == Geometry::kOrigin) {
      for (int k = 0; k < 6; ++k) p[o + k] = l.origin[k];
      p[o + kOriginOffset] = l.offset;
    } else {
      p.segment<kLinkSlots>(o) << l.a, l.alpha, l.d, l.theta, l.beta;
    }
  }
  for (int t = 0; t < tips(); ++t) {
    for (int k = 0; k < kPoseSlots; ++k) p[s.tool_slot() + kPoseSlots * t + k] = tip_tool(t)[k];
  }
  if (instrument_zero) p[s.instrument_slot()] = *instrument_zero;
  int e = s.errors_slot();
  for (const FittedBlock& b : fitted) {
    for (const FittedParameter& f : b.parameters) p[e++] = f.get ? f.get(*this, f) : f.value;
  }
  return p;
}

void DeviceModel::set_kinematic_parameters(const Eigen::VectorXd& p) {
  const ChainStructure s = structure();
  assert(p.size() == s.num_slots());
  for (int k = 0; k < s.base_slots(); ++k) base[k] = p[k];
  for (int i = 0; i < dof(); ++i) {
    Link& l = links[i];
    const int o = s.link_slot(i);
    if (l.geometry == Geometry::kOrigin) {
      for (int k = 0; k < 6; ++k) l.origin[k] = p[o + k];
      l.offset = p[o + kOriginOffset];
    } else {
      l.a = p[o + kLinkA];
      l.alpha = p[o + kLinkAlpha];
      l.d = p[o + kLinkD];
      l.theta = p[o + kLinkTheta];
      l.beta = p[o + kLinkBeta];
    }
  }
  for (int t = 0; t < tips(); ++t) {
    for (int k = 0; k < kPoseSlots; ++k) tip_tool(t)[k] = p[s.tool_slot() + kPoseSlots * t + k];
  }
  if (instrument_zero) instrument_zero = p[s.instrument_slot()];
  int e = s.errors_slot();
  for (FittedBlock& b : fitted) {
    for (FittedParameter& f : b.parameters) {
      if (f.set) {
        f.set(*this, f, p[e++]);
      } else {
        f.value = p[e++];
      }
    }
  }
}

std::vector<ParameterInfo> DeviceModel::parameter_info() const {
  using U = ParameterUnit;
  using B = ParameterBlock;
  const ChainStructure s = structure();
  std::vector<ParameterInfo> info;
  if (base_kind == BaseKind::kDh) {
    for (int k = 0; k < 4; ++k) {
      info.push_back({std::string("base.") + kBaseDhNames[k], k, k % 2 ? U::kAngle : U::kLength, -1,
                      k, B::kBase});
    }
  } else {
    for (int k = 0; k < 6; ++k) {
      info.push_back({std::string("base.") + kPoseNames[k], k, k < 3 ? U::kLength : U::kAngle, -1,
                      k, B::kBase});
    }
  }
  for (int i = 0; i < dof(); ++i) {
    const Link& l = links[i];
    const int o = s.link_slot(i);
    const std::vector<std::string>& names = block_names(l.geometry);
    for (int k = 0; k < static_cast<int>(names.size()); ++k) {
      U unit;
      if (l.geometry == Geometry::kOrigin) {
        unit = k < 3 || (k == kOriginOffset && l.prismatic()) ? U::kLength : U::kAngle;
      } else {
        unit = k == kLinkA || k == kLinkD ? U::kLength : U::kAngle;
      }
      info.push_back({l.name + "." + names[k], o + k, unit, i, k});
    }
  }
  for (int t = 0; t < tips(); ++t) {
    const std::string prefix = tree() ? tip_name(t) + ".tool." : std::string("tool.");
    for (int k = 0; k < 6; ++k) {
      info.push_back({prefix + kPoseNames[k], s.tool_slot() + kPoseSlots * t + k,
                      k < 3 ? U::kLength : U::kAngle, dof(), k, B::kTool});
    }
  }
  if (instrument_zero)
    info.push_back(
        {"instrument.zero", s.instrument_slot(), U::kLength, dof() + 1, 0, B::kInstrument});
  int e = s.errors_slot();
  for (const FittedBlock& b : fitted) {
    for (const FittedParameter& f : b.parameters) {
      info.push_back({links[f.link].name + "." + f.name, e++, f.unit, dof() + 2, f.element,
                      B::kJointError, b.family});
    }
  }
  return info;
}

// DeviceModel::compensate and reading_jacobian: kinematics/joint_values.cpp
// (the gravity torques of joint compliance need the kinematics).

void DeviceModel::apply_backlash(const Eigen::Ref<const Eigen::RowVectorXd>& direction,
                                 Eigen::Ref<Eigen::VectorXd> joint) const {
  if (direction.size() == 0) return;
  for (int i = 0; i < dof(); ++i) joint[i] += links[i].backlash * direction[i];
}

int DeviceModel::outside_range(const Eigen::Ref<const Eigen::VectorXd>& q, double play) const {
  for (int i = 0; i < dof(); ++i) {
    const Link& l = links[i];
    if (!l.has_range()) continue;
    const double value = coupled() ? coupling.row(i).dot(q) : q[i];
    if (value < l.range_lower - play || value > l.range_upper + play) return i;
  }
  return -1;
}

bool DeviceModel::within_limits(const Eigen::Ref<const Eigen::VectorXd>& q) const {
  for (int i = 0; i < dof(); ++i) {
    const Link& l = links[i];
    if (q[i] < l.lower || q[i] > l.upper) return false;
  }
  return outside_range(q) < 0;
}

DeviceModel::LimitCoordinates DeviceModel::limit_coordinates() const {
  const int n = dof();
  LimitCoordinates c;
  Eigen::MatrixXd M = Eigen::MatrixXd::Identity(n, n);
  c.lower.resize(n);
  c.upper.resize(n);
  c.reading_lower.resize(n);
  c.reading_upper.resize(n);
  for (int i = 0; i < n; ++i) {
    const Link& l = links[i];
    if (l.has_range() && coupled()) {
      M.row(i) = coupling.row(i);
      c.ranged = true;
    }
    c.lower[i] = l.has_range() ? l.range_lower : l.lower;
    c.upper[i] = l.has_range() ? l.range_upper : l.upper;
    c.reading_lower[i] = l.lower;
    c.reading_upper[i] = l.upper;
  }
  const Eigen::FullPivLU<Eigen::MatrixXd> lu(M);
  c.determined = lu.isInvertible();
  c.readings_of = lu.inverse();
  return c;
}

Eigen::VectorXd DeviceModel::LimitCoordinates::readings(const Eigen::VectorXd& x) const {
  if (!ranged) return x;
  return (readings_of * x).cwiseMax(reading_lower).cwiseMin(reading_upper);
}

std::optional<Eigen::VectorXd> DeviceModel::try_draw_readings(std::mt19937_64& rng,
                                                              int draws) const {
  Eigen::VectorXd q(dof());
  for (int draw = 0; draw < draws; ++draw) {
    for (int j = 0; j < dof(); ++j) {
      q[j] = std::uniform_real_distribution<double>(links[j].lower, links[j].upper)(rng);
    }
    if (outside_range(q) < 0) return q;
  }
  return std::nullopt;
}

Eigen::VectorXd DeviceModel::draw_readings(std::mt19937_64& rng) const {
  if (std::optional<Eigen::VectorXd> q = try_draw_readings(rng, kRangeDraws)) return *q;
  throw std::runtime_error(
      fmt::format("{}: {} readings drawn within the limits all put a joint outside its range", name,
                  kRangeDraws));
}

bool DeviceModel::has_backlash() const {
  for (const Link& l : links) {
    if (l.backlash != 0) return true;
  }
  return false;
}

bool DeviceModel::compliant() const {
  for (int i = 0; i < dof(); ++i) {
    if (links[i].compliance != 0 && !compliance_fitted(i)) return true;
  }
  return false;
}

bool DeviceModel::laterally_compliant() const {
  for (int i = 0; i < dof(); ++i) {
    if (links[i].lateral_compliance != 0 && !fitted_element("lateral", i)) return true;
  }
  return false;
}

std::string tree_problem(const DeviceModel& model) {
  if (!model.tree() && model.parents.empty()) return {};
  const int n = model.dof();
  if (n > kMaxDof || model.tips() > kMaxDof)
    return fmt::format("{} links and {} tips: at most {} of each", n, model.tips(), kMaxDof);
  if (static_cast<int>(model.parents.size()) != n)
    return fmt::format("{} parents for {} links", model.parents.size(), n);
  std::vector<int> children(static_cast<size_t>(n), 0);
  for (int i = 0; i < n; ++i) {
    const int p = model.parents[static_cast<size_t>(i)];
    if (p < -1 || p >= i)
      return fmt::format("link {}'s parent {} is not a link before it", model.links[i].name, p);
    if (p >= 0) ++children[static_cast<size_t>(p)];
  }
  std::vector<bool> ends(static_cast<size_t>(n), false);
  for (int t = 0; t < model.tips(); ++t) {
    const int link = t == 0 ? model.tip_link : model.branches[static_cast<size_t>(t - 1)].link;
    if (link < (t == 0 ? -1 : 0) || link >= n)
      return fmt::format("tip {}'s link {} is not one of the {} links", t, link, n);
    const int at = link < 0 ? n - 1 : link;
    if (ends[static_cast<size_t>(at)] || children[static_cast<size_t>(at)] > 0)
      return fmt::format("tip {} ends at link {}, which another tip ends at or passes",
                         model.tip_name(t), model.links[static_cast<size_t>(at)].name);
    ends[static_cast<size_t>(at)] = true;
  }
  return {};
}

std::string coupling_problem(const Eigen::MatrixXd& coupling, const std::vector<Link>& links) {
  const int n = static_cast<int>(links.size());
  if (coupling.size() == 0) return {};
  if (coupling.rows() != n || coupling.cols() != n) {
    return fmt::format("{} x {} for {} joints", coupling.rows(), coupling.cols(), n);
  }
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < n; ++k) {
      const double c = coupling(i, k);
      if (!std::isfinite(c) || std::abs(c) > kMaxCouplingCoefficient ||
          (c != 0 && std::abs(c) < kMinCouplingCoefficient)) {
        return fmt::format(
            "{}'s coefficient of {}: {:.6g} is not 0 or a number of magnitude in [{:g}, {:g}]",
            links[i].name, links[k].name, c, kMinCouplingCoefficient, kMaxCouplingCoefficient);
      }
    }
  }
  for (int i = 0; i < n; ++i) {
    if (!coupling.row(i).any()) return fmt::format("{} uses no reading", links[i].name);
  }
  for (int k = 0; k < n; ++k) {
    if (!coupling.col(k).any() && !links[k].transmission.is_none()) {
      return fmt::format(
          "{} is passive (no joint uses its reading), so its transmission acts on nothing",
          links[k].name);
    }
  }
  if (coupling.isIdentity(0)) return "the identity (no coupling): leave it out";
  return {};
}

}  // namespace hapticcal
