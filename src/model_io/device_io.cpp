#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <Eigen/LU>
#include <charconv>
#include <cmath>
#include <numbers>
#include <set>

#include "core/yaml_reader.hpp"
#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model/frame.hpp"
#include "hapticcal/model/joint_effect.hpp"
#include "hapticcal/model_io/device.hpp"
#include "model_io/device_tree.hpp"

namespace hapticcal {

using detail::device_name_problem;
using detail::kFormat;
using detail::kFormat2;

namespace {

using detail::join;

class Reader : public detail::YamlReader {
 public:
  using YamlReader::YamlReader;

  Transmission transmission(const YAML::Node& node, const std::string& path, double lower,
                            double upper) const {
    expect_map(node, path);
    const std::string type = string(require(node, path, "type"), join(path, "type"));
    const std::optional<TransmissionKind> kind = transmission_kind_named(type);
    if (kind == TransmissionKind::kCapstan) {
      check_keys(node, path,
                 {"type", "ratio", "drum_distance", "offset", "ratio_error", "r_out", "beta_out",
                  "r_in", "beta_in"});
      Capstan c;
      c.ratio = number(node, path, "ratio");
      c.drum_distance = number(node, path, "drum_distance");
      // The error terms default to the ideal drive (zero).
      auto optional = [&](const char* key, double& field) {
        if (node[key]) field = number(node[key], join(path, key));
      };
      optional("offset", c.offset);
      optional("ratio_error", c.ratio_error);
      optional("r_out", c.r_out);
      optional("beta_out", c.beta_out);
      optional("r_in", c.r_in);
      optional("beta_in", c.beta_in);
      return Transmission(c);
    }
    if (kind == TransmissionKind::kParallelogram) {
      check_keys(node, path, {"type", "L1", "L2", "L3", "L4"});
      return Transmission(Parallelogram{number(node, path, "L1"), number(node, path, "L2"),
                                        number(node, path, "L3"), number(node, path, "L4")});
    }
    if (kind == TransmissionKind::kPolynomial) {
      check_keys(node, path, {"type", "basis", "domain", "coefficients"});
      Polynomial poly;
      poly.lower = lower;
      poly.upper = upper;
      if (node["basis"]) {
        const std::string basis = string(node["basis"], join(path, "basis"));
        if (basis == "monomial") {
          poly.basis = PolynomialBasis::kMonomial;
        } else if (basis != "chebyshev") {
          fail(node["basis"], join(path, "basis"),
               fmt::format("'{}' is not a basis (chebyshev or monomial)", printable(basis)));
        }
      }
      if (node["domain"]) {
        const auto d = numbers(node["domain"], join(path, "domain"), 2);
        poly.lower = d[0];
        poly.upper = d[1];
      }
      // --polynomial-order's bound: a longer list would only make every fit crawl.
      constexpr size_t kMaxCoefficients = 31;
      const YAML::Node coefficients = require(node, path, "coefficients");
      if (coefficients.IsSequence() && coefficients.size() > kMaxCoefficients) {
        fail(coefficients, join(path, "coefficients"),
             fmt::format("{} coefficients: at most {} (order 30)", coefficients.size(),
                         kMaxCoefficients));
      }
      poly.coefficients = numbers(coefficients, join(path, "coefficients"), -1);
      return Transmission(poly);
    }
    if (kind == TransmissionKind::kChain) {
      check_keys(node, path, {"type", "stages"});
      const YAML::Node stages = require(node, path, "stages");
      if (!stages.IsSequence()) fail(stages, join(path, "stages"), "expected a list");
      constexpr size_t kMaxStages = 8;  // a chain is a motor, a gear, a capstan: a few
      if (stages.size() > kMaxStages) {
        fail(stages, join(path, "stages"),
             fmt::format("{} stages: at most {}", stages.size(), kMaxStages));
      }
      Chain chain;
      for (size_t k = 0; k < stages.size(); ++k) {
        chain.stages.push_back(
            transmission(stages[k], fmt::format("{}.stages[{}]", path, k), lower, upper));
      }
      return Transmission(chain);
    }
    if (kind == TransmissionKind::kHarmonic) {
      check_keys(node, path, {"type", "frequencies", "sin", "cos"});
      const YAML::Node f = require(node, path, "frequencies");
      if (f.IsSequence() && f.size() > Harmonic::kMaxFrequencies) {
        fail(f, join(path, "frequencies"),
             fmt::format("{} frequencies: at most {}", f.size(), Harmonic::kMaxFrequencies));
      }
      Harmonic h;
      h.frequencies = numbers(f, join(path, "frequencies"), -1);
      const size_t n = h.frequencies.size();
      // The coefficients default to none (zero), as a capstan's error terms.
      std::vector<double> s(n, 0.0), c(n, 0.0);
      if (node["sin"]) s = numbers(node["sin"], join(path, "sin"), static_cast<int>(n));
      if (node["cos"]) c = numbers(node["cos"], join(path, "cos"), static_cast<int>(n));
      for (size_t i = 0; i < n; ++i) h.coefficients.insert(h.coefficients.end(), {s[i], c[i]});
      return Transmission(h);
    }
    if (const TransmissionDefinition* definition = find_transmission_kind(type)) {
      // A registered kind: its parameters by name, 0 where not given.
      std::vector<std::string> keys = definition->parameter_names();
      Extension e{definition, std::vector<double>(keys.size(), 0.0)};
      for (size_t k = 0; k < keys.size(); ++k) {
        if (node[keys[k]]) e.parameters[k] = number(node[keys[k]], join(path, keys[k]));
      }
      keys.push_back("type");
      check_keys(node, path, keys);
      return Transmission(e);
    }
    std::string kinds = "capstan, parallelogram, polynomial, chain, harmonic";
    for (const std::string& name : registered_transmission_kinds()) kinds += ", " + name;
    fail(node["type"], join(path, "type"),
         fmt::format("'{}' is not a transmission ({})", printable(type), kinds));
  }

  // A geometry name: dh or mdh, and urdf in version 2.
  Geometry geometry(const YAML::Node& node, const std::string& key, bool v2) const {
    const std::string text = string(node, key);
    const std::optional<Geometry> g = geometry_named(text);
    if (g && (v2 || traits(*g).dh_parameters)) return *g;  // urdf: version 2 only
    fail(node, key,
         fmt::format("'{}' is not {}", printable(text), v2 ? "dh, mdh or urdf" : "dh or mdh"));
  }

 private:
  std::string origin_;
};

// What a device file's header fixes for every link: its version and the
// convention a link without its own geometry follows.
struct FileConvention {
  bool v2 = false;
  Geometry convention{};
};

// The base: a DH base {a, alpha, d, theta} or a pose.
void read_base(const Reader& r, const YAML::Node& root, DeviceModel& model) {
  const YAML::Node base = r.require(root, "", "base");
  r.check_keys(base, "base", {"dh", "pose"});
  if (base.size() != 1) r.fail(base, "base", "give exactly one of dh or pose");
  if (base["dh"]) {
    model.base_kind = BaseKind::kDh;
    const YAML::Node dh = base["dh"];
    r.check_keys(dh, "base.dh", {"a", "alpha", "d", "theta"});
    model.base = {r.number(dh, "base.dh", "a"),
                  r.number(dh, "base.dh", "alpha"),
                  r.number(dh, "base.dh", "d"),
                  r.number(dh, "base.dh", "theta"),
                  0.0,
                  0.0};
  } else {
    model.base_kind = BaseKind::kPose;
    r.pose(base["pose"], "base.pose", model.base);
  }
}

// A version-2 link's keys: `keys`, then the registered joint effects' names.
std::vector<std::string> with_effects(std::vector<std::string> keys) {
  for (const JointEffect* e : joint_effects()) keys.emplace_back(e->name());
  return keys;
}

// One entry of `links` (at `path`), read as its file's version and convention
// allow; the checks against the other links are check_link's.
Link read_link(const Reader& r, const YAML::Node& node, const std::string& path,
               const FileConvention& file) {
  Link link;
  link.geometry = file.convention;
  if (file.v2 && node.IsMap() && node["geometry"]) {
    link.geometry = r.geometry(node["geometry"], join(path, "geometry"), file.v2);
  }
  if (!link.dh_parameters()) {
    r.check_keys(node, path,
                 with_effects({"name", "geometry", "type", "origin", "axis", "offset", "limits",
                               "transmission", "coupling", "range", "mass", "compliance",
                               "lateral_compliance", "backlash", "parent"}));
  } else if (file.v2) {
    r.check_keys(node, path,
                 with_effects({"name", "geometry", "type", "a", "alpha", "d", "theta", "beta",
                               "limits", "transmission", "coupling", "range", "mass", "compliance",
                               "lateral_compliance", "backlash", "parent"}));
  } else {
    r.check_keys(node, path,
                 {"name", "a", "alpha", "d", "theta", "beta", "limits", "transmission"});
  }
  link.name = r.string(r.require(node, path, "name"), join(path, "name"));
  if (node["type"]) {
    const std::string type = r.string(node["type"], join(path, "type"));
    if (const std::optional<JointType> t = joint_type_named(type)) {
      link.type = *t;
    } else {
      r.fail(node["type"], join(path, "type"),
             fmt::format("'{}' is not revolute, continuous or prismatic", printable(type)));
    }
  }
  if (!link.dh_parameters()) {
    r.pose(r.require(node, path, "origin"), join(path, "origin"), link.origin);
    const auto axis = r.numbers(r.require(node, path, "axis"), join(path, "axis"), 3);
    link.axis = Eigen::Vector3d(axis[0], axis[1], axis[2]);
    if (!(link.axis.norm() > 0)) r.fail(node["axis"], join(path, "axis"), "zero axis");
    link.axis = unit_axis(link.axis);
    if (node["offset"]) link.offset = r.number(node["offset"], join(path, "offset"));
  } else {
    link.a = r.number(node, path, "a");
    link.alpha = r.number(node, path, "alpha");
    link.d = r.number(node, path, "d");
    link.theta = r.number(node, path, "theta");
    if (node["beta"]) link.beta = r.number(node["beta"], join(path, "beta"));
  }
  const auto limits = r.numbers(r.require(node, path, "limits"), join(path, "limits"), 2);
  link.lower = limits[0];
  link.upper = limits[1];
  if (!(link.lower < link.upper)) {
    r.fail(node["limits"], join(path, "limits"),
           fmt::format("lower {} must be below upper {}", link.lower, link.upper));
  }
  if (node["range"]) {  // a coupled joint's own stops, on (C q)_i
    const auto range = r.numbers(node["range"], join(path, "range"), 2);
    link.range_lower = range[0];
    link.range_upper = range[1];
  }
  if (node["transmission"]) {
    link.transmission =
        r.transmission(node["transmission"], join(path, "transmission"), link.lower, link.upper);
  }
  if (node["mass"]) {  // {m: kg, com: [x, y, z]} in the link's frame
    const YAML::Node mass = node["mass"];
    const std::string key = join(path, "mass");
    r.check_keys(mass, key, {"m", "com"});
    link.mass = r.number(mass, key, "m");
    const auto com = r.numbers(r.require(mass, key, "com"), join(key, "com"), 3);
    link.com = Eigen::Vector3d(com[0], com[1], com[2]);
  }
  if (node["compliance"]) link.compliance = r.number(node["compliance"], join(path, "compliance"));
  if (node["lateral_compliance"]) {
    link.lateral_compliance =
        r.number(node["lateral_compliance"], join(path, "lateral_compliance"));
  }
  if (node["backlash"]) link.backlash = r.number(node["backlash"], join(path, "backlash"));
  for (const JointEffect* e : joint_effects()) {
    const std::string name(e->name());
    if (file.v2 && node[name]) link.effects[name] = r.number(node[name], join(path, name));
  }
  return link;
}

// The links' `coupling` maps (version 2), {reading link's name: coefficient},
// into model.coupling once every link is read; a link without one uses its own
// reading alone.
void read_coupling(const Reader& r, const YAML::Node& links, DeviceModel& model) {
  const int n = model.dof();
  Eigen::MatrixXd C = Eigen::MatrixXd::Identity(n, n);
  int first = -1;  // the first link with a coupling: where a problem of the whole C is told
  for (int i = 0; i < n; ++i) {
    const YAML::Node node = links[i]["coupling"];
    if (!node) continue;
    const std::string path = fmt::format("links[{}].coupling", i);
    if (!node.IsMap() || node.size() == 0) {
      r.fail(node, path, "expected a map {link name: coefficient, ...} of at least one reading");
    }
    if (first < 0) first = i;
    C.row(i).setZero();
    for (const auto& entry : node) {
      const std::string name = r.string(entry.first, path);
      const std::string key = join(path, name);
      int k = 0;
      while (k < n && model.links[k].name != name) ++k;
      if (k == n) r.fail(entry.first, key, fmt::format("'{}' is not a link", printable(name)));
      C(i, k) = r.number(entry.second, key);
    }
  }
  if (first < 0) return;
  if (const std::string why = coupling_problem(C, model.links); !why.empty()) {
    r.fail(links[first]["coupling"], fmt::format("links[{}].coupling", first), why);
  }
  model.coupling = C;
}

constexpr size_t kMaxLinkName = 64;     // bytes
constexpr size_t kMaxDeviceName = 200;  // bytes

// An identifier [A-Za-z_][A-Za-z0-9_]* of at most kMaxLinkName characters.
bool usable_link_name(const std::string& name) {
  auto letter = [](char c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || c == '_'; };
  if (name.empty() || name.size() > kMaxLinkName || !letter(name[0])) return false;
  for (const char c : name) {
    if (!letter(c) && !(c >= '0' && c <= '9')) return false;
  }
  return name != "base" && name != "tool";
}

}  // namespace

std::string detail::device_name_problem(const std::string& name) {
  if (name.size() > kMaxDeviceName)
    return fmt::format("longer than {} bytes ({})", kMaxDeviceName, name.size());
  const std::string why = text_problem(name);
  return why.empty() ? why : fmt::format("'{}': {}", printable(name), why);
}

namespace {

// Semantic checks shared by the loader and check_device: (key, reason) or empty.
std::pair<std::string, std::string> check_link(const DeviceModel& model, int i) {
  const Link& link = model.links[i];
  const std::string key = fmt::format("links[{}]", i);
  if (!usable_link_name(link.name)) {
    return {key + ".name", fmt::format("'{}' is not a usable link name (letters, digits, _; at "
                                       "most {} characters; not 'base' or 'tool')",
                                       printable(link.name), kMaxLinkName)};
  }
  for (int j = 0; j < i; ++j) {
    if (model.links[j].name == link.name)
      return {key + ".name", fmt::format("'{}' repeats links[{}]", link.name, j)};
  }
  for (double v :
       {link.a, link.alpha, link.d, link.theta, link.beta, link.lower, link.upper, link.offset}) {
    if (!std::isfinite(v)) return {key, "non-finite value"};
  }
  for (double v : link.origin) {
    if (!std::isfinite(v)) return {key + ".origin", "non-finite value"};
  }
  if (!link.dh_parameters()) {
    if (!link.axis.allFinite() || std::abs(link.axis.norm() - 1) > 1e-9) {
      return {key + ".axis", "must be a unit vector"};
    }
    if (link.a != 0 || link.alpha != 0 || link.d != 0 || link.theta != 0 || link.beta != 0) {
      return {key, "a, alpha, d, theta and beta belong to dh and mdh geometry"};
    }
  } else if (link.offset != 0 || link.origin != std::array<double, 6>{} ||
             link.axis != Eigen::Vector3d::UnitZ()) {
    return {key, "origin, axis and offset belong to urdf geometry"};
  }
  if (!(link.lower < link.upper)) {
    return {key + ".limits",
            fmt::format("lower {} must be below upper {}", link.lower, link.upper)};
  }
  if (link.has_range() && !(std::isfinite(link.range_lower) && std::isfinite(link.range_upper) &&
                            link.range_lower < link.range_upper)) {
    return {key + ".range", fmt::format("lower {} must be below upper {}, both finite",
                                        link.range_lower, link.range_upper)};
  }
  if (!(link.mass >= 0 && link.mass <= kMaxLinkMass)) {
    return {key + ".mass", fmt::format("m must be in [0, {}] kg", kMaxLinkMass)};
  }
  if (!link.com.allFinite() || link.com.norm() > kMaxComDistance) {
    return {key + ".mass", fmt::format("com must be finite, within {} m", kMaxComDistance)};
  }
  if (!(std::abs(link.compliance) <= kMaxCompliance)) {
    return {key + ".compliance",
            fmt::format("{} is not a compliance of magnitude at most {} rad/N m", link.compliance,
                        kMaxCompliance)};
  }
  if (!(std::abs(link.lateral_compliance) <= kMaxCompliance)) {
    return {key + ".lateral_compliance",
            fmt::format("{} is not a compliance of magnitude at most {} rad/N m",
                        link.lateral_compliance, kMaxCompliance)};
  }
  if (!(std::abs(link.backlash) <= kMaxBacklash)) {
    return {key + ".backlash",
            fmt::format("{} is not a backlash of magnitude at most {} {}", link.backlash,
                        kMaxBacklash, link.prismatic() ? "m" : "rad")};
  }
  for (const auto& [name, c] : link.effects) {
    const JointEffect* e = find_joint_effect(name);
    if (!e) return {key + "." + name, "not a registered joint effect"};
    if (!(std::abs(c) <= e->bound())) {
      return {key + "." + name,
              fmt::format("{} is not a value of magnitude at most {}", c, e->bound())};
    }
  }
  const std::string why = link.transmission.check(link.lower, link.upper);
  if (!why.empty()) return {key + ".transmission", why};
  for (double v : link.transmission.parameters()) {
    if (!std::isfinite(v)) return {key + ".transmission", "non-finite value"};
  }
  return {};
}

// Why a link's range cannot be (its index and the reason), or empty: a range
// belongs to a coupled joint (another's is its limits), and the ranges must
// leave readings within the limits (one box draw in a thousand at least).
std::pair<int, std::string> range_problem(const DeviceModel& model) {
  int first = -1;
  for (int i = 0; i < model.dof(); ++i) {
    if (!model.links[i].has_range()) continue;
    if (first < 0) first = i;
    if (!model.coupled() || model.coupling.row(i) == Eigen::RowVectorXd::Unit(model.dof(), i)) {
      return {i,
              "a range belongs to a coupled joint (a joint on its own reading has its "
              "limits for a range)"};
    }
  }
  if (first < 0) return {-1, ""};
  if (!model.limit_coordinates().determined) {
    return {first,
            "the ranged joints' couplings and the other readings do not determine the "
            "readings (a joint's range must not repeat another's limits)"};
  }
  constexpr int kDraws = kRangeDraws / 100;
  std::mt19937_64 rng(1);
  if (model.try_draw_readings(rng, kDraws)) return {-1, ""};
  return {first, fmt::format("none of {} readings drawn within the limits puts every coupled "
                             "joint within its range",
                             kDraws)};
}

}  // namespace

DeviceModel parse_device(const std::string& text, const std::string& origin) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(origin, e.mark.is_null() ? 0 : e.mark.line + 1, "", "YAML: " + e.msg);
  }
  const Reader r(origin);
  if (!root || root.IsNull()) throw InputError(origin, 0, "", "empty device file");
  r.check_keys(root, "",
               {"format", "name", "convention", "base", "links", "tool", "gravity", "tips"});
  const std::string format = r.string(r.require(root, "", "format"), "format");
  if (format != kFormat && format != kFormat2) {
    r.fail(root["format"], "format",
           fmt::format("'{}' is not '{}' or '{}'", printable(format), kFormat, kFormat2));
  }
  const bool v2 = format == kFormat2;
  DeviceModel model;
  model.name = r.string(r.require(root, "", "name"), "name");
  if (const std::string why = device_name_problem(model.name); !why.empty())
    r.fail(root["name"], "name", why);
  const FileConvention file{v2, r.geometry(r.require(root, "", "convention"), "convention", v2)};
  read_base(r, root, model);

  const YAML::Node links = r.require(root, "", "links");
  if (!links.IsSequence() || links.size() == 0) r.fail(links, "links", "expected a non-empty list");
  if (links.size() > static_cast<size_t>(kMaxDof)) {
    r.fail(links, "links", fmt::format("at most {} links are supported", kMaxDof));
  }
  for (size_t i = 0; i < links.size(); ++i) {
    const YAML::Node node = links[i];
    model.links.push_back(read_link(r, node, fmt::format("links[{}]", i), file));
    const auto [key, why] = check_link(model, static_cast<int>(i));
    if (!why.empty()) {
      // The key's own node (links[i].<field>), else the link's.
      const std::string field = key.substr(key.rfind('.') + 1);
      const YAML::Node at = node[field] ? node[field] : node;
      r.fail(at, key, why);
    }
  }
  read_coupling(r, links, model);
  if (const auto [i, why] = range_problem(model); !why.empty()) {
    r.fail(links[i]["range"], fmt::format("links[{}].range", i), why);
  }
  if (root["tips"] && !v2) r.fail(root["tips"], "tips", "belongs to format hapticcal-device/2");
  detail::read_tree(r, root, links, model);

  if (root["gravity"]) {  // in the base frame [m/s^2]
    if (!v2) r.fail(root["gravity"], "gravity", "belongs to format hapticcal-device/2");
    const auto g = r.numbers(root["gravity"], "gravity", 3);
    model.gravity = Eigen::Vector3d(g[0], g[1], g[2]);
    if (!(model.gravity.norm() <= kMaxGravity)) {
      r.fail(root["gravity"], "gravity", fmt::format("longer than {} m/s^2", kMaxGravity));
    }
  }
  if (root["tool"]) {
    const YAML::Node tool = root["tool"];
    r.check_keys(tool, "tool", {"pose"});
    r.pose(r.require(tool, "tool", "pose"), "tool.pose", model.tool);
  }
  return model;
}

DeviceModel load_device(const std::string& path) {
  return parse_device(read_file(path, FileKind::kDevice), path);
}

std::string check_device(const DeviceModel& model) {
  if (const std::string why = device_name_problem(model.name); !why.empty()) return "name: " + why;
  if (model.links.empty()) return "links: no links";
  if (model.dof() > kMaxDof) return fmt::format("links: at most {} links are supported", kMaxDof);
  if (const std::string why = detail::tips_problem(model); !why.empty()) return why;
  for (double v : model.base) {
    if (!std::isfinite(v)) return "base: non-finite value";
  }
  if (!model.base_is_pose() && (model.base[4] != 0 || model.base[5] != 0)) {
    return "base: unused DH slots must be zero";
  }
  for (double v : model.tool) {
    if (!std::isfinite(v)) return "tool: non-finite value";
  }
  for (int i = 0; i < model.dof(); ++i) {
    const auto [key, why] = check_link(model, i);
    if (!why.empty()) return key + ": " + why;
  }
  if (const std::string why = coupling_problem(model.coupling, model.links); !why.empty()) {
    return "coupling: " + why;
  }
  if (const auto [i, why] = range_problem(model); !why.empty()) {
    return fmt::format("links[{}].range: {}", i, why);
  }
  if (!(model.gravity.norm() <= kMaxGravity)) return "gravity: not finite or too long";
  return {};
}

}  // namespace hapticcal
