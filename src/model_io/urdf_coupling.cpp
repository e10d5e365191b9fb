// URDF couplings and ranges: <mimic> and hapticcal's own <hapticcal_coupling>
// and <hapticcal_range> elements read into a chain's model (DeviceModel's
// coupling, Link::range_lower and range_upper).
#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <optional>
#include <set>
#include <string_view>

#include "hapticcal/core/error.hpp"
#include "hapticcal/model/joint_effect.hpp"
#include "hapticcal/model_io/device.hpp"
#include "model_io/urdf_internal.hpp"

namespace hapticcal::detail {

std::string joint_key(const std::string& name) {
  return fmt::format("joint '{}'", printable(name, 80));
}

namespace {

// A number as urdfdom reads one (blanks and a leading + allowed), or none.
std::optional<double> attribute_number(std::string_view t) {
  while (!t.empty() && is_blank(t.front())) t.remove_prefix(1);
  while (!t.empty() && is_blank(t.back())) t.remove_suffix(1);
  if (t.starts_with('+')) t.remove_prefix(1);
  double v = 0;
  const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
  if (ec != std::errc() || end != t.data() + t.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

}  // namespace

// A mimic joint's value is multiplier * (the mimicked joint's) + offset: a
// passive joint coupled to one reading (DeviceModel::coupling row
// multiplier at the mimicked joint's column, the offset added to its own).
void couple_mimics(const std::vector<ChainMimic>& mimics, const std::string& origin,
                   DeviceModel& model) {
  if (mimics.empty()) return;
  const int n = model.dof();
  Eigen::MatrixXd C = Eigen::MatrixXd::Identity(n, n);
  for (const ChainMimic& m : mimics) {
    int k = 0;
    while (k < n && model.links[k].name != m.mimic.joint_name) ++k;
    auto fail = [&](const std::string& why) {
      throw InputError(
          origin, m.line, joint_key(m.name),
          fmt::format("its <mimic> of '{}': {}", printable(m.mimic.joint_name, 80), why));
    };
    if (k == n) fail("not a movable joint of the chain");
    for (const ChainMimic& other : mimics) {
      if (other.link == k) fail("itself a mimic joint (mimic the joint it follows instead)");
    }
    if (!std::isfinite(m.mimic.multiplier) || !std::isfinite(m.mimic.offset) ||
        std::abs(m.mimic.multiplier) > kMaxCouplingCoefficient ||
        std::abs(m.mimic.multiplier) < kMinCouplingCoefficient) {
      fail(fmt::format(
          "multiplier {:.6g} and offset {:.6g}: a multiplier of magnitude in [{:g}, "
          "{:g}] and a finite offset are needed",
          m.mimic.multiplier, m.mimic.offset, kMinCouplingCoefficient, kMaxCouplingCoefficient));
    }
    C.row(m.link).setZero();
    C(m.link, k) = m.mimic.multiplier;
    model.links[m.link].offset += m.mimic.offset;
  }
  if (const std::string why = coupling_problem(C, model.links); !why.empty()) {
    throw InputError(origin, mimics.front().line, joint_key(mimics.front().name),
                     "<mimic>: " + why);
  }
  model.coupling = C;
}

// A joint's <hapticcal_coupling> elements (none if its element is not in the text).
std::vector<const XmlElement*> coupling_terms(const Document& doc, const std::string& joint) {
  const XmlElement* e = doc.joint(joint);
  return e ? doc.children(*e, kCouplingElement) : std::vector<const XmlElement*>{};
}

// A coupled joint's own stops (Link::range_lower, range_upper) on its coupled
// value, which <limit> (the readings') cannot say: under the <joint>,
//   <hapticcal_range lower="-0.81" upper="1.25"/>.
constexpr std::string_view kRangeElement = "hapticcal_range";

// hapticcal's elements where they mean something: under a <joint> of the
// robot, with their own attributes alone (<hapticcal_coupling> joint= and
// multiplier=, <hapticcal_range> lower= and upper=). Anywhere else (inside a
// <link>, at the top) or with another attribute (an offset=: the joint's own
// offset is its <origin>'s) every other program and this one would ignore it:
// refused, wherever it is, as the file is read.
void check_coupling_elements(const Document& doc, const std::string& origin) {
  for (const XmlElement& e : doc.elements) {
    const bool coupling = e.name == kCouplingElement, effect = e.name == kEffectElement;
    if (!coupling && !effect && e.name != kRangeElement) continue;
    const std::string key = fmt::format("<{}>", e.name);
    const XmlElement* parent = e.parent >= 0 ? &doc.elements[e.parent] : nullptr;
    if (!parent || parent->name != "joint" || parent->parent != doc.robot) {
      const XmlAttribute* name = parent ? parent->attribute("name") : nullptr;
      throw InputError(
          origin, e.line, key,
          fmt::format("inside {}: it belongs under the <joint> whose value it gives (a direct "
                      "child of <robot>)",
                      !parent ? std::string("nothing")
                              : fmt::format("<{}{}>", printable(parent->name, 40),
                                            name ? " name=\"" + printable(name->value, 80) + "\""
                                                 : std::string())));
    }
    // Each element's own attributes.
    const std::pair<const char*, const char*> own = coupling ? std::pair{"joint", "multiplier"}
                                                    : effect ? std::pair{"name", "value"}
                                                             : std::pair{"lower", "upper"};
    for (const XmlAttribute& a : e.attributes) {
      if (a.name == own.first || a.name == own.second) continue;
      throw InputError(origin, e.line, key,
                       fmt::format("unknown attribute '{}' ({}= and {}= only{})",
                                   printable(a.name, 40), own.first, own.second,
                                   coupling ? "; a joint's offset is its <origin>'s" : ""));
    }
  }
}

// The joints' <hapticcal_range> (at most one a joint, both bounds given); the
// model's checks (check_device) then judge the range.
void read_ranges(const Document& doc, const std::string& origin, DeviceModel& model) {
  for (Link& link : model.links) {
    const XmlElement* joint = doc.joint(link.name);
    const std::vector<const XmlElement*> ranges =
        joint ? doc.children(*joint, kRangeElement) : std::vector<const XmlElement*>{};
    if (ranges.empty()) continue;
    const XmlElement& e = *ranges.front();
    auto fail = [&](const std::string& why) {
      throw InputError(origin, e.line, joint_key(link.name),
                       fmt::format("<{}>: {}", kRangeElement, why));
    };
    if (ranges.size() > 1) fail("given twice");
    const XmlAttribute* lower = e.attribute("lower");
    const XmlAttribute* upper = e.attribute("upper");
    if (!lower || !upper) fail("needs lower=\"<value>\" and upper=\"<value>\"");
    const std::optional<double> lo = attribute_number(lower->value);
    const std::optional<double> hi = attribute_number(upper->value);
    if (!lo || !hi) {
      fail(fmt::format("lower '{}', upper '{}': finite numbers are needed",
                       printable(lower->value, 40), printable(upper->value, 40)));
    }
    link.range_lower = *lo;
    link.range_upper = *hi;
  }
}

void read_effects(const Document& doc, const std::string& origin, DeviceModel& model) {
  for (Link& link : model.links) {
    const XmlElement* joint = doc.joint(link.name);
    if (!joint) continue;
    for (const XmlElement* e : doc.children(*joint, kEffectElement)) {
      auto fail = [&](const std::string& why) {
        throw InputError(origin, e->line, joint_key(link.name),
                         fmt::format("<{}>: {}", kEffectElement, why));
      };
      const XmlAttribute* name = e->attribute("name");
      const XmlAttribute* value = e->attribute("value");
      if (!name || !value) fail("needs name=\"<a joint effect>\" and value=\"<c>\"");
      if (!find_joint_effect(name->value)) {
        fail(fmt::format("'{}' is not a joint effect this program registered",
                         printable(name->value, 80)));
      }
      const std::optional<double> c = attribute_number(value->value);
      if (!c)
        fail(fmt::format("value '{}': a finite number is needed", printable(value->value, 40)));
      if (!link.effects.emplace(name->value, *c).second)
        fail(fmt::format("'{}' given twice", printable(name->value, 80)));
    }
  }
}

// A <mimic> of a joint driven by <hapticcal_coupling>: URDF's mimic follows a
// joint's value, the coupling here a reading. Refused.
void refuse_mimics_of_coupled(const std::vector<ChainMimic>& mimics,
                              const std::vector<ChainCoupling>& couplings,
                              const std::string& origin) {
  for (const ChainMimic& m : mimics) {  // URDF's mimic follows a joint's value, ours a reading
    for (const ChainCoupling& c : couplings) {
      if (c.name != m.mimic.joint_name) continue;
      throw InputError(
          origin, m.line, joint_key(m.name),
          fmt::format("its <mimic> of '{}', a joint driven by <{}>: give its readings with <{}> "
                      "too",
                      printable(c.name, 80), kCouplingElement, kCouplingElement));
    }
  }
}

void couple_readings(const std::vector<ChainCoupling>& couplings, const std::string& origin,
                     DeviceModel& model) {
  if (couplings.empty()) return;
  const int n = model.dof();
  Eigen::MatrixXd C = model.coupled() ? model.coupling : Eigen::MatrixXd::Identity(n, n);
  for (const ChainCoupling& c : couplings) {
    C.row(c.link).setZero();
    std::set<int> named;
    for (const XmlElement* e : c.terms) {
      auto fail = [&](const std::string& why) {
        throw InputError(origin, e->line, joint_key(c.name),
                         fmt::format("<{}>: {}", kCouplingElement, why));
      };
      const XmlAttribute* joint = e->attribute("joint");
      const XmlAttribute* multiplier = e->attribute("multiplier");
      if (!joint || !multiplier)
        fail("needs joint=\"<a joint of the chain>\" and multiplier=\"<c>\"");
      int k = 0;
      while (k < n && model.links[k].name != joint->value) ++k;
      if (k == n)
        fail(fmt::format("'{}' is not a movable joint of the chain", printable(joint->value, 80)));
      if (!named.insert(k).second)
        fail(fmt::format("'{}' named twice", printable(joint->value, 80)));
      const double v = attribute_number(multiplier->value).value_or(0.0);
      if (std::abs(v) < kMinCouplingCoefficient || std::abs(v) > kMaxCouplingCoefficient) {
        fail(fmt::format("multiplier '{}': a number of magnitude in [{:g}, {:g}] is needed",
                         printable(multiplier->value, 40), kMinCouplingCoefficient,
                         kMaxCouplingCoefficient));
      }
      C(c.link, k) = v;
    }
  }
  if (const std::string why = coupling_problem(C, model.links); !why.empty()) {
    throw InputError(origin, couplings.front().terms.front()->line,
                     joint_key(couplings.front().name),
                     fmt::format("<{}>: {}", kCouplingElement, why));
  }
  model.coupling = C;
}

}  // namespace hapticcal::detail
