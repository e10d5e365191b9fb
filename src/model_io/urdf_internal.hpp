// Internal to the URDF reader and writer: the elements located in the text
// (urdf_shape.cpp), the chain root -> tip as read (urdf_io.cpp) with its
// couplings and ranges (urdf_coupling.cpp), and the pose
// conversions both the reading and the writing use. The writing
// (urdf_export.cpp) edits the text by the positions located here.
#pragma once

#include <urdf_model/joint.h>

#include <array>
#include <cstddef>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "hapticcal/model/frame.hpp"
#include "hapticcal/model/model.hpp"

namespace hapticcal::detail {

// ---------------------------------------------------------------------------
// Where the elements are in the text.

struct XmlAttribute {
  std::string name, value;                // value with its entities decoded
  size_t value_begin = 0, value_end = 0;  // the raw value, between the quotes
};

struct XmlElement {
  std::string name;
  int parent = -1;  // index of the enclosing element
  int line = 0;
  size_t begin = 0;           // its '<'
  size_t attributes_end = 0;  // after the name or the last attribute's closing quote
  size_t tag_end = 0;         // after the start tag's '>'
  size_t end = 0;             // after the whole element
  bool empty = false;         // <name ... />
  std::vector<XmlAttribute> attributes;

  const XmlAttribute* attribute(std::string_view key) const {
    for (const XmlAttribute& a : attributes) {
      if (a.name == key) return &a;
    }
    return nullptr;
  }
};

inline bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

// The elements of a URDF by what they are: the <robot> element and its <joint>
// and <link> children by name (as urdfdom reads them: the first of a name).
struct Document {
  std::vector<XmlElement> elements;
  int robot = -1;
  std::map<std::string, int> joints, links;

  const XmlElement* joint(const std::string& name) const { return find(joints, name); }
  int joint_index(const std::string& name) const {
    const auto it = joints.find(name);
    return it == joints.end() ? -1 : it->second;
  }
  int joint_line(const std::string& name) const {
    const XmlElement* e = joint(name);
    return e ? e->line : 0;
  }
  int link_line(const std::string& name) const {
    const XmlElement* e = find(links, name);
    return e ? e->line : 0;
  }
  // The first child of `parent` named `name`, or null.
  const XmlElement* child(const XmlElement& parent, std::string_view name) const {
    const int index = static_cast<int>(&parent - elements.data());
    for (size_t k = index + 1; k < elements.size() && elements[k].begin < parent.end; ++k) {
      if (elements[k].parent == index && elements[k].name == name) return &elements[k];
    }
    return nullptr;
  }
  // Every child of `parent` named `name`, in document order.
  std::vector<const XmlElement*> children(const XmlElement& parent, std::string_view name) const {
    std::vector<const XmlElement*> out;
    const int index = static_cast<int>(&parent - elements.data());
    for (size_t k = index + 1; k < elements.size() && elements[k].begin < parent.end; ++k) {
      if (elements[k].parent == index && elements[k].name == name) out.push_back(&elements[k]);
    }
    return out;
  }

 private:
  const XmlElement* find(const std::map<std::string, int>& by_name, const std::string& name) const {
    const auto it = by_name.find(name);
    return it == by_name.end() ? nullptr : &elements[it->second];
  }
};

// The elements of a well-formed document (check_xml has accepted it).
Document locate(const std::string& text, const std::string& origin);

// NUL bytes, nesting and attributes beyond the bounds, and malformed XML, with
// tinyxml's line (urdfdom gives none).
void check_xml(const std::string& text, const std::string& origin);

// ---------------------------------------------------------------------------
// Frames.

// x, y, z, roll, pitch, yaw of a frame (a negative zero written as 0).
std::array<double, 6> pose_of(const Frame<double>& f);

// ---------------------------------------------------------------------------
// Couplings and ranges (urdf_coupling.cpp).

// "joint 'NAME'": the key an error about a joint names.
std::string joint_key(const std::string& name);

// A mimic joint of the chain: its link index, its line and name, and what it mimics.
struct ChainMimic {
  int link;
  int line;
  std::string name;
  urdf::JointMimic mimic;
};

void couple_mimics(const std::vector<ChainMimic>& mimics, const std::string& origin,
                   DeviceModel& model);

// A joint whose value is a combination of several readings, which <mimic>
// (one joint) cannot say: under the <joint>, one element a reading,
//   <hapticcal_coupling joint="torso_2" multiplier="-1"/>,
// theta = sum multiplier_k q_k (+ the joint's offset); the joint's own reading
// counts only where it names itself. Other programs ignore the element (a ROS
// tool reads the joint as independent: its value is then the driver's to
// publish). DeviceModel::coupling's row of the joint.
constexpr std::string_view kCouplingElement = "hapticcal_coupling";

// A joint whose value several readings give: its <hapticcal_coupling> elements.
struct ChainCoupling {
  int link;
  std::string name;
  std::vector<const XmlElement*> terms;
};

// A joint's <hapticcal_coupling> elements (none if its element is not in the text).
std::vector<const XmlElement*> coupling_terms(const Document& doc, const std::string& joint);
// hapticcal's elements anywhere but under a <joint> of the robot, or with
// attributes of another's, refused wherever they are.
void check_coupling_elements(const Document& doc, const std::string& origin);
// A <mimic> of a joint driven by <hapticcal_coupling>: refused.
void refuse_mimics_of_coupled(const std::vector<ChainMimic>& mimics,
                              const std::vector<ChainCoupling>& couplings,
                              const std::string& origin);
void couple_readings(const std::vector<ChainCoupling>& couplings, const std::string& origin,
                     DeviceModel& model);
// The joints' <hapticcal_range> into their links' ranges.
void read_ranges(const Document& doc, const std::string& origin, DeviceModel& model);
// The joints' <hapticcal_effect name="" value=""/> into their links' effects
// (Link::effects: a joint effect a program registered, model/joint_effect.hpp).
constexpr std::string_view kEffectElement = "hapticcal_effect";
void read_effects(const Document& doc, const std::string& origin, DeviceModel& model);

// ---------------------------------------------------------------------------
// The chain root -> tip.

struct UrdfChain {
  DeviceModel model;
  Document doc;
  std::string root, tip;
  // Per movable joint: F_k, the fixed joints folded into it, and its element.
  std::vector<Frame<double>> folded;
  std::vector<int> joint_elements;  // -1: not found
  // The fixed joints after the last movable joint (their product is the tool).
  std::vector<Frame<double>> tool_origins;
  std::vector<int> tool_elements;
  // A root that is not above the tip: the fixed joints from the root up to the
  // first link above the tip, in that order (each origin is parent <- child).
  // The root's frame is then the measurement frame: base = o_1^-1 o_2^-1 ...
  // (the link hapticcal adds for a calibrated base, see calibrated_urdf).
  std::vector<Frame<double>> up_origins;
  std::vector<int> up_elements;
  // The fixed joints from the root down to the first movable joint (folded
  // into its origin), in that order.
  std::vector<Frame<double>> root_origins;
  std::vector<int> root_elements;
};

// The chain root -> tip of the URDF `text`, as parse_urdf documents it, with
// where its joints are in the text.
UrdfChain read_chain(const std::string& text, const std::string& origin, const std::string& tip,
                     const std::string& root);

}  // namespace hapticcal::detail
