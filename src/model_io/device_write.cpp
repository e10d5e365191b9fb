// Writing a device file: a model as the YAML that parse_device reads back
// (version 1 when it can hold the model, else version 2).
#include <fmt/format.h>

#include <Eigen/Core>
#include <string>
#include <variant>
#include <vector>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/model/joint_effect.hpp"
#include "hapticcal/model_io/device.hpp"
#include "model_io/device_tree.hpp"

namespace hapticcal {

using detail::kFormat;
using detail::kFormat2;
using detail::quoted;

std::string detail::quoted(const std::string& s) {
  std::string out = "\"";
  for (const char ch : s) {
    if (ch == '"' || ch == '\\') {
      out += '\\';
      out += ch;
    } else if (static_cast<unsigned char>(ch) < 0x20) {
      out += fmt::format("\\x{:02x}", static_cast<unsigned char>(ch));
    } else {
      out += ch;
    }
  }
  return out + "\"";
}

namespace {

std::string num(double v) { return fmt::format("{}", v); }

std::string numbers_text(const std::vector<double>& values) {
  std::string out = "[";
  for (size_t i = 0; i < values.size(); ++i) out += (i ? ", " : "") + num(values[i]);
  return out + "]";
}

std::string transmission_text(const Transmission& t) {
  struct Visitor {
    std::string operator()(const std::monostate&) const { return {}; }
    std::string operator()(const Capstan& c) const {
      return fmt::format(
          "{{type: capstan, ratio: {}, drum_distance: {}, offset: {}, ratio_error: {}, r_out: {}, "
          "beta_out: {}, r_in: {}, beta_in: {}}}",
          num(c.ratio), num(c.drum_distance), num(c.offset), num(c.ratio_error), num(c.r_out),
          num(c.beta_out), num(c.r_in), num(c.beta_in));
    }
    std::string operator()(const Parallelogram& P) const {
      return fmt::format("{{type: parallelogram, L1: {}, L2: {}, L3: {}, L4: {}}}", num(P.L1),
                         num(P.L2), num(P.L3), num(P.L4));
    }
    std::string operator()(const Polynomial& p) const {
      return fmt::format("{{type: polynomial, basis: {}, domain: [{}, {}], coefficients: {}}}",
                         p.basis == PolynomialBasis::kChebyshev ? "chebyshev" : "monomial",
                         num(p.lower), num(p.upper), numbers_text(p.coefficients));
    }
    std::string operator()(const Harmonic& h) const {
      std::vector<double> s, c;
      for (size_t i = 0; i < h.frequencies.size(); ++i) {
        s.push_back(h.coefficients[2 * i]);
        c.push_back(h.coefficients[2 * i + 1]);
      }
      return fmt::format("{{type: harmonic, frequencies: {}, sin: {}, cos: {}}}",
                         numbers_text(h.frequencies), numbers_text(s), numbers_text(c));
    }
    std::string operator()(const Extension& e) const {
      std::string out = fmt::format("{{type: {}", e.definition->name());
      const std::vector<std::string> names = e.definition->parameter_names();
      for (size_t k = 0; k < names.size(); ++k)
        out += fmt::format(", {}: {}", names[k], num(e.parameters[k]));
      return out + "}";
    }
    std::string operator()(const Chain& chain) const {
      std::string out = "{type: chain, stages: [";
      for (size_t k = 0; k < chain.stages.size(); ++k) {
        out += (k ? ", " : "") + transmission_text(chain.stages[k]);
      }
      return out + "]}";
    }
  };
  return std::visit(Visitor{}, t.model());
}

}  // namespace
std::string device_to_yaml(const DeviceModel& model) {
  if (const std::string why = tree_problem(model); !why.empty())
    throw InputError("", 0, "", "refusing to write a model whose tree is not one: " + why);
  std::string out;
  // Version 1 holds a model whose links are all revolute with one DH or MDH geometry.
  const Geometry first = model.links.empty() ? Geometry::kDh : model.links[0].geometry;
  bool uniform = traits(first).dh_parameters;
  for (const Link& l : model.links) {
    uniform = uniform && l.geometry == first && !l.prismatic() && !l.continuous();
  }
  bool masses = false;  // masses, compliance, gravity and backlash are version 2's, like a coupling
  for (const Link& l : model.links)
    masses = masses || l.mass != 0 || l.compliance != 0 || l.lateral_compliance != 0;
  uniform = uniform && !model.coupled() && !masses && !model.has_backlash() && !model.tree() &&
            !has_joint_effects(model);
  auto geometry_name = [](Geometry g) { return traits(g).name; };
  out += fmt::format("format: {}\n", uniform ? kFormat : kFormat2);
  out += fmt::format("name: {}\n", quoted(model.name));
  out += fmt::format("convention: {}\n", geometry_name(first));
  const auto& b = model.base;
  if (!model.base_is_pose()) {
    out += fmt::format("base:\n  dh: {{a: {}, alpha: {}, d: {}, theta: {}}}\n", num(b[0]),
                       num(b[1]), num(b[2]), num(b[3]));
  } else {
    out += fmt::format("base:\n  pose: {{xyz: [{}, {}, {}], rpy: [{}, {}, {}]}}\n", num(b[0]),
                       num(b[1]), num(b[2]), num(b[3]), num(b[4]), num(b[5]));
  }
  out += "links:\n";
  for (const Link& l : model.links) {
    out += fmt::format("  - name: {}\n", quoted(l.name));
    if (model.tree()) out += detail::parent_yaml(model, static_cast<int>(&l - model.links.data()));
    if (!uniform) {
      out += fmt::format("    geometry: {}\n", geometry_name(l.geometry));
      out += fmt::format("    type: {}\n", to_string(l.type));
    }
    if (!l.dh_parameters()) {
      const auto& o = l.origin;
      out += fmt::format("    origin: {{xyz: [{}, {}, {}], rpy: [{}, {}, {}]}}\n", num(o[0]),
                         num(o[1]), num(o[2]), num(o[3]), num(o[4]), num(o[5]));
      out +=
          fmt::format("    axis: [{}, {}, {}]\n", num(l.axis[0]), num(l.axis[1]), num(l.axis[2]));
      out += fmt::format("    offset: {}\n", num(l.offset));
    } else {
      out += fmt::format("    a: {}\n    alpha: {}\n    d: {}\n    theta: {}\n", num(l.a),
                         num(l.alpha), num(l.d), num(l.theta));
      out += fmt::format("    beta: {}\n", num(l.beta));
    }
    out += fmt::format("    limits: [{}, {}]\n", num(l.lower), num(l.upper));
    if (l.has_range()) {
      out += fmt::format("    range: [{}, {}]\n", num(l.range_lower), num(l.range_upper));
    }
    if (!l.transmission.is_none()) {
      out += fmt::format("    transmission: {}\n", transmission_text(l.transmission));
    }
    const int i = static_cast<int>(&l - model.links.data());
    if (model.coupled() && model.coupling.row(i) != Eigen::RowVectorXd::Unit(model.dof(), i)) {
      std::string terms;
      for (int k = 0; k < model.dof(); ++k) {
        if (model.coupling(i, k) == 0) continue;
        terms += fmt::format("{}{}: {}", terms.empty() ? "" : ", ", quoted(model.links[k].name),
                             num(model.coupling(i, k)));
      }
      out += fmt::format("    coupling: {{{}}}\n", terms);
    }
    if (l.mass != 0) {
      out += fmt::format("    mass: {{m: {}, com: [{}, {}, {}]}}\n", num(l.mass), num(l.com[0]),
                         num(l.com[1]), num(l.com[2]));
    }
    if (l.compliance != 0) out += fmt::format("    compliance: {}\n", num(l.compliance));
    if (l.lateral_compliance != 0)
      out += fmt::format("    lateral_compliance: {}\n", num(l.lateral_compliance));
    if (l.backlash != 0) out += fmt::format("    backlash: {}\n", num(l.backlash));
    for (const auto& [name, c] : l.effects) out += fmt::format("    {}: {}\n", name, num(c));
  }
  if (masses) {
    const Eigen::Vector3d& g = model.gravity;
    out += fmt::format("gravity: [{}, {}, {}]\n", num(g[0]), num(g[1]), num(g[2]));
  }
  if (model.tree()) return out + detail::tips_yaml(model);
  const auto& t = model.tool;
  out += fmt::format("tool:\n  pose: {{xyz: [{}, {}, {}], rpy: [{}, {}, {}]}}\n", num(t[0]),
                     num(t[1]), num(t[2]), num(t[3]), num(t[4]), num(t[5]));
  return out;
}

void save_device(const DeviceModel& model, const std::string& path) {
  const std::string why = check_device(model);
  if (!why.empty()) throw InputError(path, 0, "", "refusing to write an unusable model: " + why);
  write_file_atomically(path, device_to_yaml(model));
}
}  // namespace hapticcal
