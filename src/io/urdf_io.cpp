// URDF models (SPEC section 8). urdfdom reads and checks the document; a small
// scanner of our own locates the elements in the text, for line numbers, for the
// origins exactly as written, and for the textual edit of calibrated_urdf.
#include <console_bridge/console.h>
#include <fmt/format.h>
#include <tinyxml.h>
#include <urdf_parser/urdf_parser.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <map>
#include <mutex>
#include <numbers>
#include <optional>
#include <set>
#include <string_view>

#include "hapticcal/io/error.hpp"
#include "hapticcal/io/io.hpp"
#include "hapticcal/io/urdf.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model/frame.hpp"

namespace hapticcal {
namespace {

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

void append_utf8(std::string& out, unsigned long cp) {
  if (cp < 0x80) {
    out += static_cast<char>(cp);
  } else if (cp < 0x800) {
    out += static_cast<char>(0xc0 | (cp >> 6));
    out += static_cast<char>(0x80 | (cp & 0x3f));
  } else if (cp < 0x10000) {
    out += static_cast<char>(0xe0 | (cp >> 12));
    out += static_cast<char>(0x80 | ((cp >> 6) & 0x3f));
    out += static_cast<char>(0x80 | (cp & 0x3f));
  } else {
    out += static_cast<char>(0xf0 | (cp >> 18));
    out += static_cast<char>(0x80 | ((cp >> 12) & 0x3f));
    out += static_cast<char>(0x80 | ((cp >> 6) & 0x3f));
    out += static_cast<char>(0x80 | (cp & 0x3f));
  }
}

// The five predefined entities and character references; anything else as is.
// The longest reference is "&#x10FFFF;": its ';' is looked for that far only,
// so that a text of '&' without ';' is decoded in linear time.
constexpr size_t kLongestEntity = 10;

std::string decode_entities(std::string_view raw) {
  std::string out;
  for (size_t i = 0; i < raw.size();) {
    const size_t semi = raw[i] == '&'
                            ? raw.substr(0, std::min(raw.size(), i + kLongestEntity)).find(';', i)
                            : std::string_view::npos;
    if (semi == std::string_view::npos) {
      out += raw[i++];
      continue;
    }
    const std::string_view entity = raw.substr(i + 1, semi - i - 1);
    static const std::pair<std::string_view, char> kNamed[] = {
        {"lt", '<'}, {"gt", '>'}, {"amp", '&'}, {"quot", '"'}, {"apos", '\''}};
    bool done = false;
    for (const auto& [name, ch] : kNamed) {
      if (entity == name) {
        out += ch;
        done = true;
      }
    }
    if (!done && entity.size() > 1 && entity[0] == '#') {
      const bool hex = entity[1] == 'x' || entity[1] == 'X';
      const std::string_view digits = entity.substr(hex ? 2 : 1);
      unsigned long cp = 0;
      const auto [end, ec] =
          std::from_chars(digits.data(), digits.data() + digits.size(), cp, hex ? 16 : 10);
      if (ec == std::errc() && end == digits.data() + digits.size() && cp > 0 && cp <= 0x10ffff) {
        append_utf8(out, cp);
        done = true;
      }
    }
    if (!done) out.append(raw.substr(i, semi - i + 1));
    i = semi + 1;
  }
  return out;
}

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

// How a processing instruction or declaration ends: as XML says (`?>`; a
// DOCTYPE's `>` outside its brackets and quotes), or at its first `>`, as
// tinyxml 2.6 reads both: the shape check must never skip more of the text
// than the parser reads (a DOCTYPE "[>" then 100,000 nested elements would
// reach tinyxml's recursion unchecked).
enum class MarkupEnd { kXml, kFirstGreaterThan };

// Markup that is not an element, at t[i] == '<': a comment, a CDATA section, a
// processing instruction or a declaration. Returns the position just past it
// (npos if it does not end), or nothing if t[i] starts an element or an end tag.
std::optional<size_t> past_markup(const std::string& t, size_t i, MarkupEnd end_at) {
  auto past = [&](size_t from, std::string_view end) {
    const size_t k = t.find(end, from);
    return k == std::string::npos ? k : k + end.size();
  };
  if (t.compare(i, 4, "<!--") == 0) return past(i + 4, "-->");
  if (t.compare(i, 9, "<![CDATA[") == 0) return past(i + 9, "]]>");
  const bool instruction = t.compare(i, 2, "<?") == 0;
  if (!instruction && t.compare(i, 2, "<!") != 0) return std::nullopt;
  if (end_at == MarkupEnd::kFirstGreaterThan) return past(i + 2, ">");
  if (instruction) return past(i + 2, "?>");
  int brackets = 0;
  char quote = 0;
  for (size_t k = i + 2; k < t.size(); ++k) {
    const char c = t[k];
    if (quote) {
      if (c == quote) quote = 0;
    } else if (c == '"' || c == '\'') {
      quote = c;
    } else if (c == '[') {
      ++brackets;
    } else if (c == ']') {
      --brackets;
    } else if (c == '>' && brackets <= 0) {
      return k + 1;
    }
  }
  return std::string::npos;
}

// Every element of a well-formed document (tinyxml has accepted it), in document
// order. InputError in the unlikely case that this reading of the text fails.
std::vector<XmlElement> scan_elements(const std::string& t, const std::string& origin) {
  std::vector<XmlElement> out;
  std::vector<int> open;
  size_t counted = 0;
  int line = 1;
  auto line_at = [&](size_t pos) {
    line += static_cast<int>(std::count(t.begin() + counted, t.begin() + pos, '\n'));
    counted = pos;
    return line;
  };
  auto fail = [&](size_t pos) {
    throw InputError(origin, line_at(std::min(pos, t.size())), "",
                     "cannot locate the XML elements of the text");
  };
  const size_t n = t.size();
  size_t i = 0;
  while ((i = t.find('<', i)) != std::string::npos) {
    if (const std::optional<size_t> end = past_markup(t, i, MarkupEnd::kXml)) {
      if (*end == std::string::npos) fail(i);
      i = *end;
    } else if (t.compare(i, 2, "</") == 0) {
      const size_t close = t.find('>', i);
      if (close == std::string::npos || open.empty()) fail(i);
      out[open.back()].end = close + 1;
      open.pop_back();
      i = close + 1;
    } else {
      XmlElement e;
      e.begin = i;
      e.line = line_at(i);
      e.parent = open.empty() ? -1 : open.back();
      size_t k = i + 1;
      while (k < n && !is_blank(t[k]) && t[k] != '/' && t[k] != '>') ++k;
      e.name = t.substr(i + 1, k - i - 1);
      e.attributes_end = k;
      for (;;) {
        while (k < n && is_blank(t[k])) ++k;
        if (k >= n) fail(i);
        if (t[k] == '/') {
          if (k + 1 >= n || t[k + 1] != '>') fail(k);
          e.empty = true;
          e.tag_end = e.end = k + 2;
          break;
        }
        if (t[k] == '>') {
          e.tag_end = k + 1;
          break;
        }
        const size_t a = k;
        while (k < n && !is_blank(t[k]) && t[k] != '=' && t[k] != '>' && t[k] != '/') ++k;
        XmlAttribute attr;
        attr.name = t.substr(a, k - a);
        while (k < n && is_blank(t[k])) ++k;
        if (k >= n || t[k] != '=') fail(k);
        ++k;
        while (k < n && is_blank(t[k])) ++k;
        if (k >= n || (t[k] != '"' && t[k] != '\'')) fail(k);
        const size_t close = t.find(t[k], k + 1);
        if (close == std::string::npos) fail(k);
        attr.value_begin = k + 1;
        attr.value_end = close;
        attr.value = decode_entities(std::string_view(t).substr(k + 1, close - k - 1));
        e.attributes.push_back(std::move(attr));
        k = close + 1;
        e.attributes_end = k;
      }
      i = e.tag_end;
      out.push_back(std::move(e));
      if (!out.back().empty) open.push_back(static_cast<int>(out.size()) - 1);
    }
  }
  if (!open.empty()) fail(n);
  return out;
}

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

 private:
  const XmlElement* find(const std::map<std::string, int>& by_name, const std::string& name) const {
    const auto it = by_name.find(name);
    return it == by_name.end() ? nullptr : &elements[it->second];
  }
};

Document locate(const std::string& text, const std::string& origin) {
  Document doc;
  doc.elements = scan_elements(text, origin);
  for (size_t k = 0; k < doc.elements.size(); ++k) {
    const XmlElement& e = doc.elements[k];
    if (doc.robot < 0 && e.parent < 0 && e.name == "robot") doc.robot = static_cast<int>(k);
    if (doc.robot < 0 || e.parent != doc.robot) continue;
    const XmlAttribute* name = e.attribute("name");
    if (!name) continue;
    if (e.name == "joint") doc.joints.emplace(name->value, static_cast<int>(k));
    if (e.name == "link") doc.links.emplace(name->value, static_cast<int>(k));
  }
  return doc;
}

// ---------------------------------------------------------------------------
// Reading with urdfdom.

// urdfdom reports through console_bridge: keep its first error for the message
// and keep everything off the terminal.
class CapturedLog : public console_bridge::OutputHandler {
 public:
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_ERROR && first_error.empty()) {
      first_error = text;
    }
  }
  std::string first_error;
};

// tinyxml parses nested elements by recursion and checks each attribute against
// the element's others: bounds far above any URDF (which nests 4 levels and has
// at most a handful of attributes) keep its stack and time small.
constexpr int kMaxXmlDepth = 200;
constexpr int kMaxXmlAttributes = 100;

// Nesting depth and attributes per element, in one pass before tinyxml sees the
// text; a malformed text is left to tinyxml's message.
void check_xml_shape(const std::string& t, const std::string& origin) {
  const size_t n = t.size();
  int depth = 0;
  size_t i = 0;
  auto line_at = [&](size_t pos) {
    return static_cast<int>(std::count(t.begin(), t.begin() + static_cast<long>(pos), '\n')) + 1;
  };
  while (i < n && (i = t.find('<', i)) != std::string::npos) {
    if (const std::optional<size_t> end = past_markup(t, i, MarkupEnd::kFirstGreaterThan)) {
      i = std::min(*end, n);  // unterminated: tinyxml says so
    } else if (t.compare(i, 2, "</") == 0) {
      --depth;
      const size_t close = t.find('>', i + 2);
      i = close == std::string::npos ? n : close + 1;
    } else {
      const size_t start = i;
      int attributes = 0;
      char quote = 0;
      size_t k = i + 1;
      for (; k < n; ++k) {
        const char c = t[k];
        if (quote) {
          if (c == quote) quote = 0;
        } else if (c == '"' || c == '\'') {
          quote = c;
        } else if (c == '=') {
          ++attributes;
        } else if (c == '>') {
          break;
        }
      }
      if (k >= n) return;  // unterminated: tinyxml says so
      if (attributes > kMaxXmlAttributes) {
        throw InputError(origin, line_at(start), "",
                         fmt::format("XML: an element with {} attributes: at most {}", attributes,
                                     kMaxXmlAttributes));
      }
      if (t[k - 1] != '/' && ++depth > kMaxXmlDepth) {
        throw InputError(origin, line_at(start), "",
                         fmt::format("XML: elements nested more than {} deep", kMaxXmlDepth));
      }
      i = k + 1;
    }
  }
}

// NUL bytes, nesting and attributes beyond the bounds, and malformed XML, with
// tinyxml's line (urdfdom gives none).
void check_xml(const std::string& text, const std::string& origin) {
  if (const size_t nul = text.find('\0'); nul != std::string::npos) {
    const int line = static_cast<int>(std::count(text.begin(), text.begin() + nul, '\n')) + 1;
    throw InputError(origin, line, "", fmt::format("NUL byte at byte {}", nul));
  }
  check_xml_shape(text, origin);
  // tinyxml 2.6 steps over a UTF-8 sequence by its lead byte, past the end of a
  // text that ends in a cut one: NUL bytes after the text stop it there.
  const std::string padded = text + std::string(4, '\0');
  TiXmlDocument xml;
  xml.Parse(padded.c_str(), nullptr, TIXML_ENCODING_UTF8);
  if (xml.Error()) {
    throw InputError(origin, std::max(0, xml.ErrorRow()), "",
                     fmt::format("XML: {}", printable(xml.ErrorDesc(), 120)));
  }
}

// A loop of joints (a link its own ancestor): urdfdom accepts one below the
// root and then leaks the links of the loop (shared_ptr cycles), which a
// controller that loads models repeatedly would feel. Refused before it reads.
void check_no_joint_loop(const Document& doc, const std::string& origin) {
  std::map<std::string, std::string> parent_of, joint_of;  // child link -> parent link, joint
  for (const auto& [name, index] : doc.joints) {
    const XmlElement& joint = doc.elements[index];
    const XmlElement* parent = doc.child(joint, "parent");
    const XmlElement* child = doc.child(joint, "child");
    const XmlAttribute* p = parent ? parent->attribute("link") : nullptr;
    const XmlAttribute* c = child ? child->attribute("link") : nullptr;
    if (!p || !c) continue;
    const auto [at, added] = parent_of.emplace(c->value, p->value);
    if (!added) {  // a second way up: a loop (or two trees joined), never a tree
      throw InputError(origin, doc.link_line(c->value),
                       fmt::format("link '{}'", printable(c->value, 80)),
                       fmt::format("is the child of two joints, '{}' and '{}': the joints form a "
                                   "loop, not a tree",
                                   printable(joint_of[c->value], 80), printable(name, 80)));
    }
    joint_of[c->value] = name;
  }
  std::map<std::string, int> state;  // 1: on the current walk, 2: leads to a root
  for (const auto& [start, unused] : parent_of) {
    std::vector<std::string> walk;
    std::string link = start;
    while (state[link] == 0) {
      state[link] = 1;
      walk.push_back(link);
      const auto up = parent_of.find(link);
      if (up == parent_of.end()) break;
      link = up->second;
      if (state[link] == 1) {
        throw InputError(origin, doc.link_line(link), fmt::format("link '{}'", printable(link, 80)),
                         "is its own ancestor: the joints above it form a loop, not a tree");
      }
    }
    for (const std::string& l : walk) state[l] = 2;
  }
}

// urdfdom's model of a well-formed document. Its messages name a joint or link
// in brackets ("Joint [j2] is of type REVOLUTE but ..."): that element's line.
urdf::ModelInterfaceSharedPtr parse_with_urdfdom(const std::string& text, const std::string& origin,
                                                 const Document& doc) {
  // The output handler is global: one parse at a time.
  static std::mutex mutex;
  const std::lock_guard<std::mutex> lock(mutex);
  check_no_joint_loop(doc, origin);
  CapturedLog log;
  console_bridge::useOutputHandler(&log);
  urdf::ModelInterfaceSharedPtr model;
  std::string thrown;
  try {
    model = urdf::parseURDF(text);
  } catch (const std::exception& e) {
    thrown = e.what();
  }
  console_bridge::restorePreviousOutputHandler();
  if (model) return model;
  const std::string why = !thrown.empty()            ? thrown
                          : !log.first_error.empty() ? log.first_error
                                                     : "not a valid URDF";
  int line = 0;
  const size_t open = why.find('['), close = why.find(']', open + 1);
  if (open != std::string::npos && close != std::string::npos) {
    const std::string name = why.substr(open + 1, close - open - 1);
    line = doc.joint_line(name) > 0 ? doc.joint_line(name) : doc.link_line(name);
  }
  throw InputError(origin, line, "", "URDF: " + printable(why, 200));
}

// ---------------------------------------------------------------------------
// Frames and numbers.

// Roll, pitch, yaw of R = Rz(yaw) Ry(pitch) Rx(roll). Unlike matrix_rpy this
// stays exact near pitch = +-pi/2 (where roll and yaw turn about nearly the same
// axis): yaw first, then pitch and roll from Rz(yaw)^T R = Ry(pitch) Rx(roll).
Eigen::Vector3d rpy_of(const Eigen::Matrix3d& R) {
  const double yaw = std::atan2(R(1, 0), R(0, 0));
  const Eigen::Matrix3d M = rot_z(std::cos(yaw), std::sin(yaw)).transpose() * R;
  const double pitch = std::atan2(-M(2, 0), M(0, 0));
  const double roll = std::atan2(-M(1, 2), M(1, 1));
  return {roll, pitch, yaw};
}

// x, y, z, roll, pitch, yaw of a frame (a negative zero written as 0).
std::array<double, 6> pose_of(const Frame<double>& f) {
  const Eigen::Vector3d rpy = rpy_of(f.R);
  return {f.p[0] + 0.0, f.p[1] + 0.0, f.p[2] + 0.0, rpy[0] + 0.0, rpy[1] + 0.0, rpy[2] + 0.0};
}

Frame<double> frame_of(const std::array<double, 6>& v) {
  return pose_frame(v[0], v[1], v[2], v[3], v[4], v[5]);
}

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

std::string num(double v) { return fmt::format("{}", v); }
std::string triple(double a, double b, double c) {
  return fmt::format("{} {} {}", num(a), num(b), num(c));
}
std::string xyz_text(const std::array<double, 6>& v) { return triple(v[0], v[1], v[2]); }
std::string rpy_text(const std::array<double, 6>& v) { return triple(v[3], v[4], v[5]); }

// Three numbers separated by blanks, as urdfdom reads xyz and rpy.
std::optional<std::array<double, 3>> three_numbers(const std::string& text) {
  std::array<double, 3> out{};
  size_t count = 0, i = 0;
  while (i < text.size()) {
    while (i < text.size() && is_blank(text[i])) ++i;
    if (i >= text.size()) break;
    size_t k = i;
    while (k < text.size() && !is_blank(text[k])) ++k;
    if (count == 3) return std::nullopt;
    double v = 0;
    const auto [end, ec] = std::from_chars(text.data() + i, text.data() + k, v);
    if (ec != std::errc() || end != text.data() + k || !std::isfinite(v)) return std::nullopt;
    out[count++] = v;
    i = k;
  }
  if (count != 3) return std::nullopt;
  return out;
}

std::string xml_escaped(const std::string& s) {
  std::string out;
  for (const char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

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
};

std::string joint_key(const std::string& name) {
  return fmt::format("joint '{}'", printable(name, 80));
}

// The joint's origin as written in the text (exact), else as urdfdom holds it.
std::array<double, 6> joint_origin(const urdf::Joint& joint, const Document& doc) {
  const urdf::Pose& pose = joint.parent_to_joint_origin_transform;
  const Eigen::Quaterniond q(pose.rotation.w, pose.rotation.x, pose.rotation.y, pose.rotation.z);
  const Frame<double> held{q.normalized().toRotationMatrix(),
                           Eigen::Vector3d(pose.position.x, pose.position.y, pose.position.z)};
  if (const XmlElement* e = doc.joint(joint.name)) {
    std::array<double, 6> exact{};
    bool read = true;
    if (const XmlElement* o = doc.child(*e, "origin")) {
      for (const auto& [key, at] : {std::pair{"xyz", 0}, std::pair{"rpy", 3}}) {
        const XmlAttribute* attr = o->attribute(key);
        if (!attr) continue;
        const auto v = three_numbers(attr->value);
        read = read && v.has_value();
        if (v) std::copy(v->begin(), v->end(), exact.begin() + at);
      }
    }
    // Taken only if it is the transform urdfdom read (as it should be).
    const Frame<double> f = frame_of(exact);
    if (read && (f.R - held.R).cwiseAbs().maxCoeff() < 1e-9 &&
        (f.p - held.p).cwiseAbs().maxCoeff() < 1e-9) {
      return exact;
    }
  }
  return pose_of(held);
}

// The leaf links below `link`, depth first (without recursion: a URDF may be deep).
std::vector<std::string> leaves_below(const urdf::Link& link) {
  std::vector<std::string> out;
  std::vector<const urdf::Link*> open{&link};
  std::set<const urdf::Link*> seen;  // urdfdom accepts a loop of joints below the root
  while (!open.empty()) {
    const urdf::Link* l = open.back();
    open.pop_back();
    if (!seen.insert(l).second) continue;
    if (l->child_links.empty()) out.push_back(l->name);
    for (auto it = l->child_links.rbegin(); it != l->child_links.rend(); ++it) {
      open.push_back(it->get());
    }
  }
  return out;
}

std::string name_list(const std::vector<std::string>& names) {
  std::string out;
  for (size_t k = 0; k < names.size() && k < 8; ++k) {
    out += (k ? ", " : "") + printable(names[k], 40);
  }
  if (names.size() > 8) out += fmt::format(", ... ({} in all)", names.size());
  return out;
}

// The links from `link` up to the tree's root, `link` first. InputError on a
// loop of joints (urdfdom accepts one below the root).
std::vector<urdf::LinkConstSharedPtr> ancestry(const urdf::ModelInterface& urdf,
                                               urdf::LinkConstSharedPtr link,
                                               const std::string& origin, const Document& doc,
                                               const char* key) {
  std::vector<urdf::LinkConstSharedPtr> out;
  std::set<std::string> passed;
  while (link) {
    if (!passed.insert(link->name).second) {
      throw InputError(origin, doc.link_line(link->name), key,
                       fmt::format("link '{}' is its own ancestor: the joints above it form a "
                                   "loop, not a tree",
                                   printable(link->name, 80)));
    }
    out.push_back(link);
    if (!link->parent_joint) break;
    link = urdf.getLink(link->parent_joint->parent_link_name);
    if (!link) throw InputError(origin, 0, "", "URDF: broken tree");  // urdfdom checks this
  }
  return out;
}

// The joints from root to tip, urdfdom's. A root that is not above the tip may
// be joined to the tip's branch by fixed joints only (the measurement frame of
// a calibrated URDF hangs below the robot's root): those joints, from the root
// upwards, go to `up`.
std::vector<urdf::JointConstSharedPtr> chain_joints(const urdf::ModelInterface& urdf,
                                                    const std::string& origin, UrdfChain& chain,
                                                    std::vector<urdf::JointConstSharedPtr>& up) {
  urdf::LinkConstSharedPtr root = chain.root.empty() ? urdf.getRoot() : urdf.getLink(chain.root);
  if (!root) {
    throw InputError(origin, 0, "root",
                     fmt::format("link '{}' is not in the URDF", printable(chain.root, 80)));
  }
  chain.root = root->name;
  if (chain.tip.empty()) {
    const std::vector<std::string> leaves = leaves_below(*root);
    if (leaves.size() != 1) {
      throw InputError(origin, 0, "tip",
                       fmt::format("give the tip link: the tree below '{}' has {} leaf links ({})",
                                   printable(root->name, 80), leaves.size(), name_list(leaves)));
    }
    chain.tip = leaves[0];
  }
  urdf::LinkConstSharedPtr tip = urdf.getLink(chain.tip);
  if (!tip) {
    throw InputError(origin, 0, "tip",
                     fmt::format("link '{}' is not in the URDF", printable(chain.tip, 80)));
  }
  const std::vector<urdf::LinkConstSharedPtr> above_tip =
      ancestry(urdf, tip, origin, chain.doc, "tip");
  const std::vector<urdf::LinkConstSharedPtr> above_root =
      ancestry(urdf, root, origin, chain.doc, "root");
  // The first link above the root (itself included) that is above the tip too.
  size_t meet = 0;
  auto on_tip_branch = [&](const urdf::LinkConstSharedPtr& l) {
    return std::find(above_tip.begin(), above_tip.end(), l) != above_tip.end();
  };
  while (meet < above_root.size() && !on_tip_branch(above_root[meet])) ++meet;
  const bool moving_up = meet > 0 && meet < above_root.size() &&
                         std::all_of(above_root.begin(), above_root.begin() + meet, [](auto& l) {
                           return l->parent_joint->type == urdf::Joint::FIXED;
                         });
  if (meet == above_root.size() || (meet > 0 && !moving_up)) {
    throw InputError(origin, chain.doc.link_line(chain.tip), "tip",
                     fmt::format("link '{}' is not below the root link '{}'{}",
                                 printable(chain.tip, 80), printable(root->name, 80),
                                 meet > 0 && meet < above_root.size()
                                     ? " (a root beside the chain must be joined to it by fixed "
                                       "joints only)"
                                     : ""));
  }
  up.clear();
  for (size_t k = 0; k < meet; ++k) up.push_back(above_root[k]->parent_joint);
  std::vector<urdf::JointConstSharedPtr> joints;
  for (auto link = above_tip.begin(); *link != above_root[meet]; ++link) {
    joints.push_back((*link)->parent_joint);
  }
  std::reverse(joints.begin(), joints.end());
  return joints;
}

// Throws the first problem check_device finds, naming the joint or the robot.
void check_chain_model(const UrdfChain& chain, const std::string& origin) {
  const std::string why = check_device(chain.model);
  if (why.empty()) return;
  int index = -1;
  if (why.starts_with("links[")) {
    const size_t close = why.find(']');
    const std::string digits = why.substr(6, close - 6);
    std::from_chars(digits.data(), digits.data() + digits.size(), index);
  }
  if (index >= 0 && index < chain.model.dof()) {
    const std::string& name = chain.model.links[index].name;
    std::string rest = why.substr(why.find(']') + 1);
    if (rest.starts_with(".")) rest.erase(0, 1);
    if (rest.starts_with(": ")) rest.erase(0, 2);
    throw InputError(origin, chain.doc.joint_line(name), joint_key(name), rest);
  }
  const int line = chain.doc.robot >= 0 ? chain.doc.elements[chain.doc.robot].line : 0;
  if (why.starts_with("name: ")) throw InputError(origin, line, "robot name", why.substr(6));
  throw InputError(origin, line, "", why);
}

UrdfChain read_chain(const std::string& text, const std::string& origin, const std::string& tip,
                     const std::string& root) {
  check_xml(text, origin);
  UrdfChain chain;
  chain.doc = locate(text, origin);
  const urdf::ModelInterfaceSharedPtr urdf = parse_with_urdfdom(text, origin, chain.doc);
  chain.root = root;
  chain.tip = tip;
  std::vector<urdf::JointConstSharedPtr> up;
  const std::vector<urdf::JointConstSharedPtr> joints = chain_joints(*urdf, origin, chain, up);

  int movable = 0;
  for (const auto& j : joints) {
    if (j->type == urdf::Joint::REVOLUTE || j->type == urdf::Joint::CONTINUOUS ||
        j->type == urdf::Joint::PRISMATIC) {
      ++movable;
    }
  }
  if (movable == 0) {
    throw InputError(origin, 0, "tip",
                     fmt::format("no movable joint between '{}' and '{}'",
                                 printable(chain.root, 80), printable(chain.tip, 80)));
  }
  if (movable > kMaxDof) {
    throw InputError(
        origin, 0, "tip",
        fmt::format("the chain '{}' -> '{}' has {} movable joints: at most {}",
                    printable(chain.root, 80), printable(chain.tip, 80), movable, kMaxDof));
  }

  DeviceModel& model = chain.model;
  model.name = urdf->getName();
  model.base_kind = BaseKind::kPose;
  Frame<double> base = Frame<double>::Identity();
  for (const auto& j : up) {
    const Frame<double> o = frame_of(joint_origin(*j, chain.doc));
    chain.up_origins.push_back(o);
    chain.up_elements.push_back(chain.doc.joint_index(j->name));
    base = base * o.inverse();
  }
  if (!up.empty()) model.base = pose_of(base);
  Frame<double> fold = Frame<double>::Identity();
  bool folding = false;
  std::vector<Frame<double>> fixed_origins;
  std::vector<int> fixed_elements;
  for (const auto& j : joints) {
    const int line = chain.doc.joint_line(j->name);
    const std::array<double, 6> o = joint_origin(*j, chain.doc);
    if (j->type == urdf::Joint::FIXED) {
      fold = fold * frame_of(o);
      folding = true;
      fixed_origins.push_back(frame_of(o));
      fixed_elements.push_back(chain.doc.joint_index(j->name));
      continue;
    }
    if (j->type == urdf::Joint::FLOATING || j->type == urdf::Joint::PLANAR ||
        j->type == urdf::Joint::UNKNOWN) {
      const char* type = j->type == urdf::Joint::FLOATING ? "floating"
                         : j->type == urdf::Joint::PLANAR ? "planar"
                                                          : "unknown";
      throw InputError(origin, line, joint_key(j->name),
                       fmt::format("a {} joint cannot be in the chain '{}' -> '{}' (only "
                                   "revolute, continuous, prismatic and fixed joints)",
                                   type, printable(chain.root, 80), printable(chain.tip, 80)));
    }
    if (j->mimic) {
      throw InputError(origin, line, joint_key(j->name),
                       fmt::format("a mimic joint (of '{}') cannot be in the chain: its value is "
                                   "not a reading of its own",
                                   printable(j->mimic->joint_name, 80)));
    }
    Link link;
    link.name = j->name;
    link.geometry = Geometry::kOrigin;
    link.type = j->type == urdf::Joint::REVOLUTE     ? JointType::kRevolute
                : j->type == urdf::Joint::CONTINUOUS ? JointType::kContinuous
                                                     : JointType::kPrismatic;
    link.origin = folding ? pose_of(fold * frame_of(o)) : o;
    link.axis = Eigen::Vector3d(j->axis.x, j->axis.y, j->axis.z);
    if (!link.axis.allFinite() || !(link.axis.norm() > 0)) {
      throw InputError(origin, line, joint_key(j->name), "axis: zero or not finite");
    }
    link.axis.normalize();
    if (link.type == JointType::kContinuous) {
      link.lower = -std::numbers::pi;
      link.upper = std::numbers::pi;
    } else if (j->limits) {
      link.lower = j->limits->lower;
      link.upper = j->limits->upper;
    }
    model.links.push_back(std::move(link));
    chain.folded.push_back(fold);
    chain.joint_elements.push_back(chain.doc.joint_index(j->name));
    fold = Frame<double>::Identity();
    folding = false;
    fixed_origins.clear();
    fixed_elements.clear();
  }
  if (folding) model.tool = pose_of(fold);
  chain.tool_origins = std::move(fixed_origins);
  chain.tool_elements = std::move(fixed_elements);
  check_chain_model(chain, origin);
  return chain;
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
      s.pre = frame_of(l.origin) * motion(l.axis, l.prismatic(), l.offset);
      s.axis = l.axis;
      break;
  }
  return s;
}

// The transmission entries of device_to_yaml's text, one per link (empty: none),
// so that the comments hold exactly what a device file would.
std::vector<std::string> transmission_yaml(const DeviceModel& model) {
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
    constexpr std::string_view kKey = "    transmission: ";
    if (in_links && line.starts_with(kKey) && !out.empty()) {
      out.back() = std::string(line.substr(kKey.size()));
    }
    pos = eol + 1;
  }
  out.resize(model.links.size());
  return out;
}

void write_joint(std::string& out, const std::string& name, const std::string& type,
                 const std::string& parent, const std::string& child, const Frame<double>& origin,
                 const Link* link, const Eigen::Vector3d& axis = Eigen::Vector3d::UnitZ()) {
  const std::array<double, 6> pose = pose_of(origin);
  out += fmt::format("  <joint name=\"{}\" type=\"{}\">\n", xml_escaped(name), type);
  out += fmt::format("    <parent link=\"{}\"/>\n", xml_escaped(parent));
  out += fmt::format("    <child link=\"{}\"/>\n", xml_escaped(child));
  out += fmt::format("    <origin xyz=\"{}\" rpy=\"{}\"/>\n", xyz_text(pose), rpy_text(pose));
  if (link) {
    out += fmt::format("    <axis xyz=\"{}\"/>\n", triple(axis[0], axis[1], axis[2]));
    if (link->type != JointType::kContinuous) {
      out += fmt::format("    <limit lower=\"{}\" upper=\"{}\" effort=\"0\" velocity=\"0\"/>\n",
                         num(link->lower), num(link->upper));
    }
  }
  out += "  </joint>\n";
}

}  // namespace

DeviceModel parse_urdf(const std::string& text, const std::string& origin, const std::string& tip,
                       const std::string& root) {
  return read_chain(text, origin, tip, root).model;
}

DeviceModel load_urdf(const std::string& path, const std::string& tip, const std::string& root) {
  return parse_urdf(read_file(path, FileKind::kUrdf), path, tip, root);
}

std::string device_to_urdf(const DeviceModel& model) {
  if (const std::string why = check_device(model); !why.empty()) {
    throw InputError("", 0, "", "cannot write an unusable model as URDF: " + why);
  }
  const ChainStructure s = model.structure();
  const Eigen::VectorXd params = model.kinematic_parameters();
  const Frame<double> base = base_frame(s, params.data());
  const Frame<double> tool = tool_frame(s, params.data());
  const std::vector<std::string> transmissions = transmission_yaml(model);

  std::set<std::string> joint_names;
  for (const Link& l : model.links) joint_names.insert(l.name);
  const std::string base_joint = unique_name("base_joint", joint_names);
  const std::string tool_joint = unique_name("tool_joint", joint_names);

  std::string out = "<?xml version=\"1.0\"?>\n";
  out +=
      "<!-- Written by hapticcal from a device model. The chain for hapticcal is\n"
      "     hapticcal_measurement -> tool (the measurement frame to the tool point);\n"
      "     joint offsets are folded into the joint origins. -->\n";
  out += fmt::format("<robot name=\"{}\">\n", xml_escaped(model.name));
  out += "  <link name=\"hapticcal_measurement\"/>\n";
  out += "  <link name=\"base_link\"/>\n";
  write_joint(out, base_joint, "fixed", "hapticcal_measurement", "base_link", base, nullptr);
  Frame<double> post = Frame<double>::Identity();  // C_0: base_joint carries B
  std::string parent = "base_link";
  for (size_t i = 0; i < model.links.size(); ++i) {
    const Link& l = model.links[i];
    const JointSplit split = split_joint(l);
    const std::string child = l.name + "_link";
    out += fmt::format("  <link name=\"{}\"/>\n", xml_escaped(child));
    if (!transmissions[i].empty()) {
      out += fmt::format(
          "  <!-- hapticcal: joint {} has a transmission, which URDF cannot express (as in a "
          "device file): {} -->\n",
          comment_safe(l.name), comment_safe(transmissions[i]));
    }
    const char* type = l.prismatic()                      ? "prismatic"
                       : l.type == JointType::kContinuous ? "continuous"
                                                          : "revolute";
    write_joint(out, l.name, type, parent, child, post * split.pre, &l, split.axis);
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
// root by a fixed joint with origin B^-1, so that --root hapticcal_measurement
// gives the whole calibration and the robot's own root the robot alone.
// Returns the comment's words on the frame.
template <typename Mismatch>
std::string write_measurement_frame(const std::string& urdf_text, const UrdfChain& chain,
                                    const DeviceModel& nominal, const DeviceModel& calibrated,
                                    std::vector<Edit>& edits, std::vector<std::string>* notes,
                                    const Mismatch& mismatch) {
  const Frame<double> B = frame_of(calibrated.base);
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
  added += fmt::format("  <link name=\"{}\"/>\n", xml_escaped(link));
  write_joint(added, joint, "fixed", chain.root, link, B.inverse(), nullptr);
  edits.push_back({close, close, added});
  if (notes) {
    notes->push_back(fmt::format(
        "calibrated.urdf holds the measurement frame as link '{}' (fixed joint '{}' below the "
        "root '{}'): --root {} reproduces calibrated.yaml, --root {} gives the robot alone",
        link, joint, chain.root, link, chain.root));
  }
  return fmt::format("the measurement frame is the link {}", comment_safe(link));
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
    if (c.name != n.name || c.geometry != Geometry::kOrigin || c.type != n.type ||
        (c.axis - n.axis).norm() > 1e-12) {
      throw mismatch(fmt::format("joint {} ('{}')", i + 1, printable(c.name, 80)));
    }
    if (chain.joint_elements[i] < 0) throw mismatch("joint element not found in the text");
  }

  std::vector<Edit> edits;
  for (int i = 0; i < nominal.dof(); ++i) {
    const Link& c = calibrated.links[i];
    const Link& n = nominal.links[i];
    if (c.origin == n.origin && c.offset == n.offset) continue;  // untouched text
    // origin_k = F_k^-1 * O_k * motion(axis, offset_k)
    const Frame<double> unfolded =
        chain.folded[i].inverse() * frame_of(c.origin) * motion(c.axis, c.prismatic(), c.offset);
    set_origin(urdf_text, chain.doc, chain.doc.elements[chain.joint_elements[i]], pose_of(unfolded),
               edits);
  }

  if (calibrated.tool != nominal.tool) {
    const Frame<double> T_tool = frame_of(calibrated.tool);
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
      added += fmt::format("  <link name=\"{}\"/>\n", xml_escaped(link));
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
  edits.push_back({robot.tag_end, robot.tag_end,
                   fmt::format("\n{}<!-- hapticcal: calibrated joint origins of the chain {} -> {} "
                               "(joint offsets folded into them); {} -->",
                               indentation_at(urdf_text, robot.begin) + "  ",
                               comment_safe(chain.root), comment_safe(chain.tip), frame_comment)});
  return apply_edits(urdf_text, std::move(edits));
}

}  // namespace hapticcal
