#include "hapticcal/model/joint_effect.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <stdexcept>

namespace hapticcal {
namespace {

std::vector<const JointEffect*>& registry() {
  static std::vector<const JointEffect*> effects;
  return effects;
}

// The keys a link has in a device file (model_io/device_io.cpp reads them): no
// effect may take one.
bool link_key(std::string_view name) {
  static const char* const kKeys[] = {
      "name",         "geometry", "type",  "origin", "axis",       "offset",
      "limits",       "a",        "alpha", "d",      "theta",      "beta",
      "transmission", "coupling", "range", "mass",   "compliance", "lateral_compliance",
      "backlash",     "parent"};
  return std::any_of(std::begin(kKeys), std::end(kKeys),
                     [&](const char* key) { return name == key; });
}

}  // namespace

void register_joint_effect(const JointEffect* effect) {
  if (!effect) throw std::invalid_argument("register_joint_effect: no effect");
  const std::string_view name = effect->name();
  const bool word = !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || c == '_';
  });
  if (!word || link_key(name) || find_joint_effect(name)) {
    throw std::invalid_argument(fmt::format(
        "joint effect '{}': not a name of a-z and '_', or a link key or an effect has it", name));
  }
  registry().push_back(effect);
}

const std::vector<const JointEffect*>& joint_effects() { return registry(); }

const JointEffect* find_joint_effect(std::string_view name) {
  for (const JointEffect* e : registry()) {
    if (e->name() == name) return e;
  }
  return nullptr;
}

namespace {

// The effect of a link's entry (a model holds only registered ones: the
// readers refuse others).
const JointEffect& effect_named(const std::string& name) {
  const JointEffect* e = find_joint_effect(name);
  if (!e) throw std::logic_error("joint effect '" + name + "' is not registered");
  return *e;
}

}  // namespace

double effects_error(const Link& link, double q) {
  double sum = 0;
  for (const auto& [name, c] : link.effects) sum += c * effect_named(name).feature(q);
  return sum;
}

double effects_slope(const Link& link, double q) {
  double sum = 0;
  for (const auto& [name, c] : link.effects) sum += c * effect_named(name).slope(q);
  return sum;
}

bool has_joint_effects(const DeviceModel& model) {
  return std::any_of(model.links.begin(), model.links.end(),
                     [](const Link& l) { return !l.effects.empty(); });
}

}  // namespace hapticcal
