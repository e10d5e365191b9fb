// Device models written as URDF: a model as a new URDF
// (device_to_urdf), and a calibrated model put back into its source URDF by a
// textual edit that keeps everything else of the text byte for byte
// (calibrated_urdf), at the positions urdf_shape.cpp locates.
#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <set>
#include <string_view>

#include "hapticcal/core/error.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model/frame.hpp"
#include "hapticcal/model/joint_effect.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/model_io/urdf.hpp"
#include "model_io/urdf_internal.hpp"

namespace hapticcal {
namespace {

using detail::Document;
using detail::pose_of;
using detail::read_chain;
using detail::UrdfChain;
using detail::XmlAttribute;
using detail::XmlElement;

// ---------------------------------------------------------------------------
// Frames and numbers.

Frame<double> translation(const Eigen::Vector3d& p) { return {Eigen::Matrix3d::Identity(), p}; }
Frame<double> rotation(const Eigen::Matrix3d& R) { return {R, Eigen::Vector3d::Zero()}; }

// A joint's motion by `value` (rad or m) about / along the unit `axis`.
Frame<double> motion(const Eigen::Vector3d& axis, bool prismatic, double value) {
  if (prismatic) return translation(value * axis);
  return rotation(Eigen::AngleAxisd(value, axis).toRotationMatrix());
}

bool is_identity(const std::array<double, 6>& pose) {
  return std::all_of(pose.begin(), pose.end(), [](double v) { return v == 0; });
}

std::string triple(double a, double b, double c) {
  return fmt::format("{} {} {}", a, b, c);  // shortest round-trip text
}
std::string xyz_text(const std::array<double, 6>& v) { return triple(v[0], v[1], v[2]); }
std::string rpy_text(const std::array<double, 6>& v) { return triple(v[3], v[4], v[5]); }

// Text that can stand inside <!-- -->: no "--", no '-' at the end.
std::string comment_safe(std::string s) {
  for (size_t k; (k = s.find("--")) != std::string::npos;) s.replace(k, 2, "- -");
  if (!s.empty() && s.back() == '-') s += ' ';
  return s;
}

// `name`, or `name` with "hapticcal_" before it (and a number after it) if taken.
std::string unique_name(const std::string& name, const std::set<std::string>& taken) {
  if (!taken.count(name)) return name;
  std::string candidate = "hapticcal_" + name;
  for (int k = 2; taken.count(candidate); ++k) candidate = fmt::format("hapticcal_{}_{}", name, k);
  return candidate;
}

// ---------------------------------------------------------------------------
// The textual edit.

struct Edit {
  size_t begin = 0, end = 0;  // replaced range
  std::string text;
};

std::string apply_edits(const std::string& text, std::vector<Edit> edits) {
  std::stable_sort(edits.begin(), edits.end(), [](const Edit& a, const Edit& b) {
    return a.begin != b.begin ? a.begin > b.begin : a.end > b.end;
  });
  std::string out = text;
  for (const Edit& e : edits) out.replace(e.begin, e.end - e.begin, e.text);
  return out;
}

// The blanks that start the line holding `pos`.
std::string indentation_at(const std::string& text, size_t pos) {
  const size_t start = text.rfind('\n', pos == 0 ? 0 : pos - 1);
  const size_t from = start == std::string::npos ? 0 : start + 1;
  size_t k = from;
  while (k < pos && (text[k] == ' ' || text[k] == '\t')) ++k;
  return text.substr(from, k - from);
}

// Sets the origin of `joint` to `pose`: the values of the xyz and rpy attributes
// of its <origin> are replaced (or added), or an <origin/> is added after the
// joint's start tag.
void set_origin(const std::string& text, const Document& doc, const XmlElement& joint,
                const std::array<double, 6>& pose, std::vector<Edit>& edits) {
  const std::string xyz = xyz_text(pose), rpy = rpy_text(pose);
  if (const XmlElement* o = doc.child(joint, "origin")) {
    std::string added;
    for (const auto& [key, value] : {std::pair{"xyz", &xyz}, std::pair{"rpy", &rpy}}) {
      if (const XmlAttribute* a = o->attribute(key)) {
        edits.push_back({a->value_begin, a->value_end, *value});
      } else {
        added += fmt::format(" {}=\"{}\"", key, *value);
      }
    }
    if (!added.empty()) edits.push_back({o->attributes_end, o->attributes_end, added});
    return;
  }
  const int index = static_cast<int>(&joint - doc.elements.data());
  std::string indent = indentation_at(text, joint.begin) + "  ";
  for (size_t k = index + 1; k < doc.elements.size(); ++k) {
    if (doc.elements[k].parent == index) {
      indent = indentation_at(text, doc.elements[k].begin);
      break;
    }
  }
  edits.push_back({joint.tag_end, joint.tag_end,
                   fmt::format("\n{}<origin xyz=\"{}\" rpy=\"{}\"/>", indent, xyz, rpy)});
}

// ---------------------------------------------------------------------------
// Writing a model as URDF.

// A_i = pre_i * motion(axis_i, q_i) * post_i with the joint's constants.
struct JointSplit {
  Frame<double> pre = Frame<double>::Identity(), post = Frame<double>::Identity();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
};

Frame<double> rot_x_frame(double a) { return rotation(rot_x(std::cos(a), std::sin(a))); }
Frame<double> rot_y_frame(double a) { return rotation(rot_y(std::cos(a), std::sin(a))); }
Frame<double> rot_z_frame(double a) { return rotation(rot_z(std::cos(a), std::sin(a))); }

JointSplit split_joint(const Link& l) {
  JointSplit s;
  switch (l.geometry) {
    case Geometry::kDh:
      // Rz(q + theta) T(a, 0, d) Rx(alpha) Ry(beta) = Rz(q) * C; prismatic:
      // Rz(theta) T(a, 0, d + q) Rx Ry = Tz(q) * C (Tz commutes with Rz(theta)).
      s.post = rot_z_frame(l.theta) * translation({l.a, 0, l.d}) * rot_x_frame(l.alpha) *
               rot_y_frame(l.beta);
      break;
    case Geometry::kMdh:
      // Rx(alpha) Tx(a) Ry(beta) Rz(theta + q) Tz(d) = [Rx Tx Ry Rz(theta) Tz(d)] * Rz(q)
      // (Rz(q) commutes with Tz(d)); prismatic: Tz(d + q) = Tz(d) Tz(q).
      s.pre = rot_x_frame(l.alpha) * translation({l.a, 0, 0}) * rot_y_frame(l.beta) *
              rot_z_frame(l.theta) * translation({0, 0, l.d});
      break;
    case Geometry::kOrigin:
      s.pre = pose_frame(l.origin) * motion(l.axis, l.prismatic(), l.offset);
      s.axis = l.axis;
      break;
  }
  return s;
}

// The `key` entries ("transmission", "coupling") of device_to_yaml's text, one
// per link (empty: none), so that the comments hold exactly what a device file would.
std::vector<std::string> link_yaml(const DeviceModel& model, std::string_view key) {
  std::vector<std::string> out;
  const std::string yaml = device_to_yaml(model);
  size_t pos = 0;
  bool in_links = false;
  while (pos < yaml.size()) {
    size_t eol = yaml.find('\n', pos);
    if (eol == std::string::npos) eol = yaml.size();
    const std::string_view line(yaml.data() + pos, eol - pos);
    if (line == "links:") in_links = true;
    if (in_links && line.starts_with("  - name:")) out.emplace_back();
    if (in_links && !line.starts_with(" ") && line != "links:") in_links = false;
    const std::string prefix = fmt::format("    {}: ", key);
    if (in_links && line.starts_with(prefix) && !out.empty()) {
      out.back() = std::string(line.substr(prefix.size()));
    }
    pos = eol + 1;
  }
  out.resize(model.links.size());
  return out;
}

// Joint i's coupling as URDF elements, one a line after `indent`: a passive
// joint that follows one other reading is a <mimic> (offset 0: the offsets are
// folded into the origins), any other row one <hapticcal_coupling> a reading
// (urdf_io.cpp reads it back; other programs ignore it).
std::string coupling_elements(const DeviceModel& model, int i, const std::string& indent) {
  if (!model.coupled()) return "";  // each joint its own reading
  const Eigen::RowVectorXd row = model.coupling.row(i);
  int k = 0;
  row.cwiseAbs().maxCoeff(&k);
  if ((row.array() != 0).count() == 1 && k != i && !model.reading_used(i)) {
    return fmt::format("{}<mimic joint=\"{}\" multiplier=\"{}\" offset=\"0\"/>\n", indent,
                       markup_escaped(model.links[k].name), row[k]);
  }
  std::string out;
  for (int r = 0; r < row.size(); ++r) {
    if (row[r] == 0) continue;
    out += fmt::format("{}<hapticcal_coupling joint=\"{}\" multiplier=\"{}\"/>\n", indent,
                       markup_escaped(model.links[r].name), row[r]);
  }
  return out;
}

// calibrated.urdf's coupling of joint i (whose origin, offset folded in, is
// rewritten with it): its <mimic> and <hapticcal_coupling> elements replaced by
// the calibrated row's, before the joint's end tag.
void set_coupling(const std::string& text, const Document& doc, const XmlElement& joint,
                  const DeviceModel& calibrated, int i, std::vector<Edit>& edits) {
  for (const std::string_view name : {"mimic", "hapticcal_coupling"}) {
    for (const XmlElement* e : doc.children(joint, name)) {
      size_t from = e->begin, to = e->end;  // the whole line where it is alone on it
      while (from > 0 && (text[from - 1] == ' ' || text[from - 1] == '\t')) --from;
      size_t after = to;
      while (after < text.size() && (text[after] == ' ' || text[after] == '\t')) ++after;
      if ((from == 0 || text[from - 1] == '\n') && after < text.size() && text[after] == '\n') {
        to = after + 1;
      } else {
        from = e->begin;
      }
      edits.push_back({from, to, ""});
    }
  }
  const size_t close = text.rfind("</", joint.end - 1);
  const std::string indent = indentation_at(text, joint.begin);
  std::string added = coupling_elements(calibrated, i, indent + "  ");
  size_t line = close;
  while (line > 0 && (text[line - 1] == ' ' || text[line - 1] == '\t')) --line;
  if (line > 0 && text[line - 1] == '\n') {
    edits.push_back({line, line, added});  // the end tag on a line of its own
  } else {
    added.pop_back();
    edits.push_back({close, close, "\n" + added + "\n" + indent});
  }
}

void write_joint(std::string& out, const std::string& name, const std::string& type,
                 const std::string& parent, const std::string& child, const Frame<double>& origin,
                 const Link* link, const Eigen::Vector3d& axis = Eigen::Vector3d::UnitZ(),
                 const std::string& extra = "") {
  const std::array<double, 6> pose = pose_of(origin);
  out += fmt::format("  <joint name=\"{}\" type=\"{}\">\n", markup_escaped(name), type);
  out += fmt::format("    <parent link=\"{}\"/>\n", markup_escaped(parent));
  out += fmt::format("    <child link=\"{}\"/>\n", markup_escaped(child));
  out += fmt::format("    <origin xyz=\"{}\" rpy=\"{}\"/>\n", xyz_text(pose), rpy_text(pose));
  if (link) {
    out += fmt::format("    <axis xyz=\"{}\"/>\n", triple(axis[0], axis[1], axis[2]));
    if (!link->continuous()) {
      out += fmt::format("    <limit lower=\"{}\" upper=\"{}\" effort=\"0\" velocity=\"0\"/>\n",
                         link->lower, link->upper);
    }
    if (link->has_range()) {  // urdf_io.cpp reads it back; other programs ignore it
      out += fmt::format("    <hapticcal_range lower=\"{}\" upper=\"{}\"/>\n", link->range_lower,
                         link->range_upper);
    }
    for (const auto& [effect, c] : link->effects)  // likewise
      out += fmt::format("    <{} name=\"{}\" value=\"{}\"/>\n", detail::kEffectElement, effect, c);
  }
  out += extra;
  out += "  </joint>\n";
}

}  // namespace

std::string device_to_urdf(const DeviceModel& model) {
  if (const std::string why = check_device(model); !why.empty()) {
    throw InputError("", 0, "", "cannot write an unusable model as URDF: " + why);
  }
  if (model.tree())
    throw InputError("", 0, "tips",
                     fmt::format("a tree of {} tips: a URDF is written from one chain (calibrate "
                                 "from the tree's URDF writes its calibrated.urdf)",
                                 model.tips()));
  const ChainStructure s = model.structure();
  const Eigen::VectorXd params = model.kinematic_parameters();
  const Frame<double> base = base_frame(s, params.data());
  const Frame<double> tool = tool_frame(s, params.data());
  const std::vector<std::string> transmissions = link_yaml(model, "transmission");
  const std::vector<std::string> couplings = link_yaml(model, "coupling");
  const std::vector<std::string> masses = link_yaml(model, "mass");
  const std::vector<std::string> compliances = link_yaml(model, "compliance");
  const std::vector<std::string> backlashes = link_yaml(model, "backlash");
  const std::vector<std::string> laterals = link_yaml(model, "lateral_compliance");

  std::set<std::string> joint_names;
  for (const Link& l : model.links) joint_names.insert(l.name);
  const std::string base_joint = unique_name("base_joint", joint_names);
  const std::string tool_joint = unique_name("tool_joint", joint_names);

  std::string out = "<?xml version=\"1.0\"?>\n";
  out +=
      "<!-- Written by hapticcal from a device model. The chain for hapticcal is\n"
      "     hapticcal_measurement -> tool (the measurement frame to the tool point);\n"
      "     joint offsets are folded into the joint origins. -->\n";
  out += fmt::format("<robot name=\"{}\">\n", markup_escaped(model.name));
  out += "  <link name=\"hapticcal_measurement\"/>\n";
  out += "  <link name=\"base_link\"/>\n";
  write_joint(out, base_joint, "fixed", "hapticcal_measurement", "base_link", base, nullptr);
  Frame<double> post = Frame<double>::Identity();  // C_0: base_joint carries B
  std::string parent = "base_link";
  for (size_t i = 0; i < model.links.size(); ++i) {
    const Link& l = model.links[i];
    const JointSplit split = split_joint(l);
    const std::string child = l.name + "_link";
    out += fmt::format("  <link name=\"{}\"/>\n", markup_escaped(child));
    if (!transmissions[i].empty()) {
      out += fmt::format(
          "  <!-- hapticcal: joint {} has a transmission, which URDF cannot express (as in a "
          "device file): {} -->\n",
          comment_safe(l.name), comment_safe(transmissions[i]));
    }
    if (!compliances[i].empty()) {
      out += fmt::format(
          "  <!-- hapticcal: joint {} deflects under gravity, which URDF cannot express (as in a "
          "device file): compliance: {}, mass: {}, gravity: [{}, {}, {}] -->\n",
          comment_safe(l.name), comment_safe(compliances[i]),
          comment_safe(masses[i].empty() ? "0" : masses[i]), model.gravity[0], model.gravity[1],
          model.gravity[2]);
    } else if (!masses[i].empty()) {
      out += fmt::format("  <!-- hapticcal: link {} carries mass: {} -->\n", comment_safe(l.name),
                         comment_safe(masses[i]));
    }
    if (!laterals[i].empty()) {
      out += fmt::format(
          "  <!-- hapticcal: joint {} bends about its x axis under gravity, which URDF cannot "
          "express (as in a device file): lateral_compliance: {} -->\n",
          comment_safe(l.name), comment_safe(laterals[i]));
    }
    if (!backlashes[i].empty()) {
      out += fmt::format(
          "  <!-- hapticcal: joint {} has backlash, which URDF cannot express (as in a device "
          "file): backlash: {} -->\n",
          comment_safe(l.name), comment_safe(backlashes[i]));
    }
    const std::string mimic =
        couplings[i].empty() ? "" : coupling_elements(model, static_cast<int>(i), "    ");
    if (mimic.find("hapticcal_coupling") != std::string::npos) {
      out += fmt::format(
          "  <!-- hapticcal: joint {}'s value is a combination of readings, which <mimic> "
          "cannot express: the hapticcal_coupling elements give it (ROS tools read the joint "
          "as independent: publish its value) -->\n",
          comment_safe(l.name));
    }
    const char* type = to_string(l.type);
    write_joint(out, l.name, type, parent, child, post * split.pre, &l, split.axis, mimic);
    post = split.post;
    parent = child;
  }
  out += "  <link name=\"tool\"/>\n";
  write_joint(out, tool_joint, "fixed", parent, "tool", post * tool, nullptr);
  out += "</robot>\n";
  return out;
}

// The calibrated base B (the measurement frame's pose: T_measurement_root) in
// the text. A chain read from a measurement-frame root (up_origins) has its
// first fixed joint's origin set so that o_1^-1 o_2^-1 ... = B; otherwise, if
// the base moved, a link `hapticcal_measurement` is added below the chain's
// root by a fixed joint with origin N B^-1 (N the nominal base: the root's own
// fixed joints before the first moving one), so that --root hapticcal_measurement
// gives the whole calibration and the robot's own root the robot alone.
// Returns the comment's words on the frame.
template <typename Mismatch>
std::string write_measurement_frame(const std::string& urdf_text, const UrdfChain& chain,
                                    const DeviceModel& nominal, const DeviceModel& calibrated,
                                    std::vector<Edit>& edits, std::vector<std::string>* notes,
                                    const Mismatch& mismatch) {
  const Frame<double> B = pose_frame(calibrated.base);
  if (!chain.up_origins.empty()) {
    if (calibrated.base == nominal.base) {
      return fmt::format("the measurement frame is the root {}", comment_safe(chain.root));
    }
    if (chain.up_elements.front() < 0) throw mismatch("measurement joint element not found");
    Frame<double> rest = Frame<double>::Identity();  // o_2^-1 o_3^-1 ...
    for (size_t k = 1; k < chain.up_origins.size(); ++k)
      rest = rest * chain.up_origins[k].inverse();
    set_origin(urdf_text, chain.doc, chain.doc.elements[chain.up_elements.front()],
               pose_of(rest * B.inverse()), edits);
    return fmt::format("the calibrated measurement frame is the root {}", comment_safe(chain.root));
  }
  if (calibrated.base == nominal.base || is_identity(calibrated.base)) {
    return "the measurement frame is the robot's root";
  }
  // A root that is a measurement frame hapticcal wrote (device_to_urdf's):
  // calibrated again, its first fixed joint takes the new frame, o_1 -> B o_1
  // (joint 1's origin was written against the old F_1 = o_1 o_2 ...), rather
  // than a second measurement link being added below it.
  if (chain.root.find("hapticcal_measurement") != std::string::npos &&
      !chain.root_elements.empty() && !chain.folded.empty()) {
    if (chain.root_elements.front() < 0) throw mismatch("measurement joint element not found");
    set_origin(urdf_text, chain.doc, chain.doc.elements[chain.root_elements.front()],
               pose_of(B * chain.root_origins.front()), edits);
    return fmt::format("the calibrated measurement frame is the root {}", comment_safe(chain.root));
  }
  std::set<std::string> joints, links;
  for (const auto& [name, index] : chain.doc.joints) joints.insert(name);
  for (const auto& [name, index] : chain.doc.links) links.insert(name);
  const std::string link = unique_name("hapticcal_measurement", links);
  const std::string joint = unique_name("hapticcal_measurement_joint", joints);
  const XmlElement& robot = chain.doc.elements[chain.doc.robot];
  const size_t close = urdf_text.rfind("</", robot.end - 1);
  std::string added = fmt::format(
      "  <!-- hapticcal: the measurement frame of the calibration (the tracker's or capture "
      "system's), below the root '{}': --root {} gives the calibrated chain in that frame, --root "
      "{} the robot alone -->\n",
      comment_safe(chain.root), comment_safe(link), comment_safe(chain.root));
  added += fmt::format("  <link name=\"{}\"/>\n", markup_escaped(link));
  // The chain from `link` is T_link_root * (the root's own fixed joints, the
  // nominal base N) * the joints: with T_root_link = N B^-1 it starts with B.
  write_joint(added, joint, "fixed", chain.root, link, pose_frame(nominal.base) * B.inverse(),
              nullptr);
  edits.push_back({close, close, added});
  if (notes) {
    notes->push_back(fmt::format(
        "calibrated.urdf holds the measurement frame as link '{}' (fixed joint '{}' below the "
        "root '{}'), where evaluate reads it from: --root {} gives the calibrated model in the "
        "measurement frame, --root {} the robot alone",
        link, joint, chain.root, link, chain.root));
  }
  return fmt::format("the measurement frame is the link {}", comment_safe(link));
}

// The calibrated model's parts a URDF cannot hold: joint compliance, lateral
// compliance, backlash, transmissions (joint errors), or empty.
std::string not_in_urdf(const DeviceModel& m) {
  std::vector<std::string> parts;
  if (m.compliant()) parts.push_back("joint compliance");
  if (m.laterally_compliant()) parts.push_back("lateral compliance");
  if (m.has_backlash()) parts.push_back("backlash");
  if (has_joint_effects(m)) parts.push_back("the joint effects");
  for (const Link& l : m.links) {
    if (!l.transmission.is_none()) {
      parts.push_back("the transmissions' errors");
      break;
    }
  }
  return fmt::format("{}", fmt::join(parts, ", "));
}

std::string calibrated_urdf(const std::string& urdf_text, const std::string& origin,
                            const std::string& tip, const std::string& root,
                            const DeviceModel& calibrated, std::vector<std::string>* notes) {
  const UrdfChain chain = read_chain(urdf_text, origin, tip, root);
  const DeviceModel& nominal = chain.model;
  auto mismatch = [&](const std::string& why) {
    return InputError(origin, 0, "",
                      fmt::format("the calibrated model does not match the chain '{}' -> '{}': {}",
                                  printable(chain.root, 80), printable(chain.tip, 80), why));
  };
  if (calibrated.dof() != nominal.dof()) {
    throw mismatch(fmt::format("{} joints, not {}", calibrated.dof(), nominal.dof()));
  }
  for (int i = 0; i < nominal.dof(); ++i) {
    const Link& c = calibrated.links[i];
    const Link& n = nominal.links[i];
    if (c.name != n.name || c.dh_parameters() || c.type != n.type ||
        (c.axis - n.axis).norm() > 1e-12) {
      throw mismatch(fmt::format("joint {} ('{}')", i + 1, printable(c.name, 80)));
    }
    if (chain.joint_elements[i] < 0) throw mismatch("joint element not found in the text");
  }

  std::vector<Edit> edits;
  const int n_joints = nominal.dof();
  auto row = [&](const DeviceModel& m, int i) -> Eigen::RowVectorXd {
    return m.coupled() ? Eigen::RowVectorXd(m.coupling.row(i))
                       : Eigen::RowVectorXd::Unit(n_joints, i);
  };
  for (int i = 0; i < nominal.dof(); ++i) {
    const Link& c = calibrated.links[i];
    const Link& n = nominal.links[i];
    const bool recoupled = row(calibrated, i) != row(nominal, i);
    if (c.origin == n.origin && c.offset == n.offset && !recoupled) continue;  // untouched text
    // A coupled joint's elements go with its origin: a mimic's offset is then
    // folded into the origin (written 0), not counted twice.
    if (recoupled || row(nominal, i) != Eigen::RowVectorXd::Unit(n_joints, i)) {
      set_coupling(urdf_text, chain.doc, chain.doc.elements[chain.joint_elements[i]], calibrated, i,
                   edits);
    }
    // origin_k = F_k^-1 * O_k * motion(axis, offset_k)
    const Frame<double> unfolded =
        chain.folded[i].inverse() * pose_frame(c.origin) * motion(c.axis, c.prismatic(), c.offset);
    set_origin(urdf_text, chain.doc, chain.doc.elements[chain.joint_elements[i]], pose_of(unfolded),
               edits);
  }

  if (calibrated.tool != nominal.tool) {
    const Frame<double> T_tool = pose_frame(calibrated.tool);
    const size_t m = chain.tool_elements.size();
    if (m > 0 && chain.tool_elements.back() >= 0) {
      // G_1 ... G_m' = T_tool
      Frame<double> before = Frame<double>::Identity();
      for (size_t k = 0; k + 1 < m; ++k) before = before * chain.tool_origins[k];
      set_origin(urdf_text, chain.doc, chain.doc.elements[chain.tool_elements.back()],
                 pose_of(before.inverse() * T_tool), edits);
    } else if (m > 0) {
      throw mismatch("tool joint element not found in the text");
    } else if (!is_identity(calibrated.tool)) {
      std::set<std::string> joints, links;
      for (const auto& [name, index] : chain.doc.joints) joints.insert(name);
      for (const auto& [name, index] : chain.doc.links) links.insert(name);
      const std::string link = unique_name("hapticcal_tool", links);
      const std::string joint = unique_name("hapticcal_tool_joint", joints);
      const XmlElement& robot = chain.doc.elements[chain.doc.robot];
      const size_t close = urdf_text.rfind("</", robot.end - 1);
      std::string added = fmt::format(
          "  <!-- hapticcal: the calibrated tool pose, on a link added under the tip '{}': "
          "use the tip '{}' -->\n",
          comment_safe(chain.tip), comment_safe(link));
      added += fmt::format("  <link name=\"{}\"/>\n", markup_escaped(link));
      write_joint(added, joint, "fixed", chain.tip, link, T_tool, nullptr);
      edits.push_back({close, close, added});
      if (notes) {
        notes->push_back(fmt::format(
            "the calibrated tool pose is on link '{}' (fixed joint '{}'), added under the tip "
            "'{}': use --tip {} with calibrated.urdf",
            link, joint, chain.tip, link));
      }
    }
  }

  const std::string frame_comment =
      write_measurement_frame(urdf_text, chain, nominal, calibrated, edits, notes, mismatch);
  const XmlElement& robot = chain.doc.elements[chain.doc.robot];
  // What URDF cannot hold is said in the file (evaluate reads it) and the notes.
  const std::string left_out = not_in_urdf(calibrated);
  if (!left_out.empty() && notes) {
    notes->push_back("calibrated.urdf leaves out " + left_out +
                     " (URDF cannot express it): calibrated.yaml holds the whole model");
  }
  edits.push_back(
      {robot.tag_end, robot.tag_end,
       fmt::format("\n{}<!-- hapticcal: calibrated joint origins of the chain {} -> {} "
                   "(joint offsets folded into them); {}{} -->",
                   indentation_at(urdf_text, robot.begin) + "  ", comment_safe(chain.root),
                   comment_safe(chain.tip), frame_comment,
                   left_out.empty() ? "" : "; " + std::string(kLeftOut) + comment_safe(left_out))});
  return apply_edits(urdf_text, std::move(edits));
}

}  // namespace hapticcal
