// ROS message definitions: the built-in texts of the standard types hapticcal
// imports, and the parser that compiles a definition into a MessageType.
//
// Format: http://wiki.ros.org/msg (ROS 1: fields, constants, "Header", the
// "====\nMSG: package/Type" sections of a full definition as rosbag stores it)
// and https://docs.ros.org/en/rolling/Concepts/Basic/About-Interfaces.html
// (ROS 2: bounded strings and sequences, default values, byte and char as
// uint8, builtin_interfaces/Time {int32 sec, uint32 nanosec}). The built-in
// texts are the published definitions: ROS 1's common_msgs (std_msgs/Header,
// geometry_msgs, sensor_msgs/JointState; http://docs.ros.org/en/noetic/api/)
// and tf2_msgs/TFMessage; ROS 2's common_interfaces
// (https://docs.ros.org/en/rolling/p/sensor_msgs/, .../p/geometry_msgs/,
// .../p/std_msgs/, .../p/builtin_interfaces/, .../p/tf2_msgs/).
#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <map>
#include <optional>
#include <unordered_map>
#include <unordered_set>

#include "hapticcal/core/error.hpp"
#include "recording/ros_message_internal.hpp"

namespace hapticcal::recording {

namespace {

using detail::ArrayKind;
using detail::CompiledField;
using detail::CompiledStruct;
using detail::CompiledType;
using detail::Kind;

struct BuiltinType {
  const char* name;
  const char* ros1;  // the fields as ROS 1 writes them
  const char* ros2;  // as ROS 2 writes them (nullptr: the ROS 1 text)
  std::vector<const char*> uses;
};

const std::vector<BuiltinType>& builtin_types() {
  static const std::vector<BuiltinType> types = {
      {"sensor_msgs/JointState",
       "# The state of a set of joints: each joint's name, position (rad or m),\n"
       "# velocity (rad/s or m/s) and effort (Nm or N); an array may be empty.\n"
       "Header header\n\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n",
       "std_msgs/Header header\n\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] "
       "effort\n",
       {"std_msgs/Header"}},
      {"geometry_msgs/PoseStamped",
       "# A Pose with reference coordinate frame and timestamp\nHeader header\nPose pose\n",
       "# A Pose with reference coordinate frame and timestamp\nstd_msgs/Header header\nPose "
       "pose\n",
       {"std_msgs/Header", "geometry_msgs/Pose"}},
      {"geometry_msgs/PointStamped",
       "# This represents a Point with reference coordinate frame and timestamp\n"
       "Header header\nPoint point\n",
       "# This represents a Point with reference coordinate frame and timestamp\n"
       "std_msgs/Header header\nPoint point\n",
       {"std_msgs/Header", "geometry_msgs/Point"}},
      {"geometry_msgs/TransformStamped",
       "# A transform from coordinate frame header.frame_id to the coordinate frame "
       "child_frame_id\n"
       "Header header\nstring child_frame_id # the frame id of the child frame\nTransform "
       "transform\n",
       "# A transform from coordinate frame header.frame_id to the coordinate frame "
       "child_frame_id\n"
       "std_msgs/Header header\nstring child_frame_id # the frame id of the child frame\nTransform "
       "transform\n",
       {"std_msgs/Header", "geometry_msgs/Transform"}},
      {"tf2_msgs/TFMessage",
       "geometry_msgs/TransformStamped[] transforms\n",
       nullptr,
       {"geometry_msgs/TransformStamped"}},
      {"std_msgs/Header",
       "# Standard metadata for higher-level stamped data types.\n"
       "# sequence ID: consecutively increasing ID\nuint32 seq\n"
       "# Two-integer timestamp: stamp.sec seconds since the epoch, stamp.nsec nanoseconds\ntime "
       "stamp\n"
       "# Frame this data is associated with\nstring frame_id\n",
       "# Standard metadata for higher-level stamped data types.\n"
       "# Two-integer timestamp that is expressed as seconds and "
       "nanoseconds.\nbuiltin_interfaces/Time stamp\n"
       "# Transform frame with which this data is associated.\nstring frame_id\n",
       {}},
      {"geometry_msgs/Pose",
       "# A representation of pose in free space, composed of position and orientation.\n"
       "Point position\nQuaternion orientation\n",
       nullptr,
       {"geometry_msgs/Point", "geometry_msgs/Quaternion"}},
      {"geometry_msgs/Point",
       "# This contains the position of a point in free space\nfloat64 x\nfloat64 y\nfloat64 z\n",
       nullptr,
       {}},
      {"geometry_msgs/Quaternion",
       "# This represents an orientation in free space in quaternion form.\n\n"
       "float64 x\nfloat64 y\nfloat64 z\nfloat64 w\n",
       "# This represents an orientation in free space in quaternion form.\n\n"
       "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n",
       {}},
      {"geometry_msgs/Transform",
       "# This represents the transform between two coordinate frames in free space.\n\n"
       "Vector3 translation\nQuaternion rotation\n",
       nullptr,
       {"geometry_msgs/Vector3", "geometry_msgs/Quaternion"}},
      {"geometry_msgs/Vector3",
       "# This represents a vector in free space.\n\nfloat64 x\nfloat64 y\nfloat64 z\n",
       nullptr,
       {}},
  };
  return types;
}

const BuiltinType* find_builtin(const std::string& name) {
  for (const BuiltinType& t : builtin_types())
    if (name == t.name) return &t;
  return nullptr;
}

// Every type `type` uses, depth first, each once.
void collect_uses(const BuiltinType& type, Encoding encoding, std::vector<std::string>& out) {
  std::vector<const char*> uses = type.uses;
  if (encoding == Encoding::kCdr && std::string(type.name) == "std_msgs/Header")
    uses.push_back("builtin_interfaces/Time");
  for (const char* use : uses) {
    if (std::find(out.begin(), out.end(), use) != out.end()) continue;
    out.emplace_back(use);
    if (const BuiltinType* t = find_builtin(use)) collect_uses(*t, encoding, out);
  }
}

std::string_view trim(std::string_view s) {
  const auto blank = [](char c) { return c == ' ' || c == '\t' || c == '\r'; };
  while (!s.empty() && blank(s.front())) s.remove_prefix(1);
  while (!s.empty() && blank(s.back())) s.remove_suffix(1);
  return s;
}

bool is_identifier(std::string_view s) {
  if (s.empty() || !std::isalpha(static_cast<unsigned char>(s[0]))) return false;
  return std::all_of(s.begin(), s.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
  });
}

// "package/Type" from "package/Type" or "package/msg/Type"; nullopt otherwise.
std::optional<std::string> normalise_type_name(std::string_view name) {
  const std::size_t slash = name.find('/');
  if (slash == std::string_view::npos) return std::nullopt;
  const std::string_view package = name.substr(0, slash);
  std::string_view rest = name.substr(slash + 1);
  if (rest.substr(0, 4) == "msg/") rest.remove_prefix(4);
  if (!is_identifier(package) || !is_identifier(rest)) return std::nullopt;
  return std::string(package) + "/" + std::string(rest);
}

struct RawField {
  std::string type;
  std::string name;
  int line = 0;
};

struct RawSection {
  std::string name;
  int line = 0;  // of its MSG: line (0 for the message itself)
  std::vector<RawField> fields;
};

struct Primitive {
  const char* name;
  Kind kind;
  std::uint64_t bytes;
};

constexpr Primitive kPrimitives[] = {
    {"bool", Kind::kBool, 1},       {"int8", Kind::kInt8, 1},       {"uint8", Kind::kUint8, 1},
    {"int16", Kind::kInt16, 2},     {"uint16", Kind::kUint16, 2},   {"int32", Kind::kInt32, 4},
    {"uint32", Kind::kUint32, 4},   {"int64", Kind::kInt64, 8},     {"uint64", Kind::kUint64, 8},
    {"float32", Kind::kFloat32, 4}, {"float64", Kind::kFloat64, 8}, {"string", Kind::kString, 4},
};

// A field's type token: base, optional string bound and array suffix.
struct TypeSpec {
  std::string base;
  std::int64_t string_bound = -1;
  ArrayKind array = ArrayKind::kNone;
  std::int64_t count_or_bound = -1;  // kFixed: N; kSequence: the bound or -1
};

std::optional<std::int64_t> parse_count(std::string_view digits) {
  std::uint32_t value = 0;
  if (digits.empty() || digits.size() > 10) return std::nullopt;
  const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  if (ec != std::errc() || end != digits.data() + digits.size()) return std::nullopt;
  return value;
}

class DefinitionParser {
 public:
  DefinitionParser(const std::string& type, const std::string& text, Encoding encoding,
                   const std::string& origin)
      : type_(type), text_(text), encoding_(encoding), origin_(origin) {}

  std::shared_ptr<const CompiledType> run() {
    const auto root = normalise_type_name(type_);
    if (!root)
      throw InputError(
          fmt::format("{}: message type '{}' is not package/Type", origin_, printable(type_)));
    split_sections(*root);
    add_implicit_sections();
    auto compiled = std::make_shared<CompiledType>(*root, encoding_);
    std::vector<std::string> stack;
    compile(*root, stack);
    // The message itself was compiled last: move it to index 0.
    const int n = static_cast<int>(structs_.size());
    std::rotate(structs_.begin(), structs_.end() - 1, structs_.end());
    for (CompiledStruct& s : structs_)
      for (CompiledField& f : s.fields)
        if (f.kind == Kind::kMessage) f.type = (f.type + 1) % n;
    compiled->structs = std::move(structs_);
    return compiled;
  }

 private:
  [[noreturn]] void fail(int line, const std::string& what) const {
    throw InputError(fmt::format("{}: definition of {}, line {}: {}", origin_, printable(type_, 80),
                                 line, what));
  }

  // A section defined again must be the same (a full definition repeats the
  // types two fields use); found by name in constant time.
  void add_section(RawSection section) {
    if (const RawSection* s = find_section(section.name)) {
      const bool same = std::equal(s->fields.begin(), s->fields.end(), section.fields.begin(),
                                   section.fields.end(), [](const RawField& a, const RawField& b) {
                                     return a.type == b.type && a.name == b.name;
                                   });
      if (!same)
        fail(section.line,
             fmt::format("{} is defined twice, differently (first at line {})", s->name, s->line));
      return;
    }
    section_index_.emplace(section.name, sections_.size());
    sections_.push_back(std::move(section));
  }

  void split_sections(const std::string& root) {
    RawSection current{root, 0, {}};
    bool expect_msg = false;  // after a line of '='
    int line_no = 0;
    std::string_view rest(text_);
    while (!rest.empty()) {
      const std::size_t eol = rest.find('\n');
      const std::string_view raw = rest.substr(0, eol);
      rest = eol == std::string_view::npos ? std::string_view() : rest.substr(eol + 1);
      ++line_no;
      const std::string_view line = trim(raw);
      if (line.empty() || line[0] == '#') continue;
      if (line.find_first_not_of('=') == std::string_view::npos) {
        expect_msg = true;
        continue;
      }
      if (line.substr(0, 4) == "MSG:") {
        std::string_view name = trim(line.substr(4));
        name = trim(name.substr(0, name.find('#')));
        const auto normalised = normalise_type_name(name);
        if (!normalised)
          fail(line_no,
               fmt::format("'{}' after MSG: is not package/Type", printable(std::string(name))));
        add_section(std::move(current));
        current = RawSection{*normalised, line_no, {}};
        // A fresh table, not clear(): clear() costs the buckets the largest section grew.
        std::unordered_set<std::string>().swap(field_names_);
        expect_msg = false;
        continue;
      }
      if (line.substr(0, 4) == "IDL:")
        fail(line_no, "an IDL definition (ros2idl) cannot be read: only .msg definitions");
      if (expect_msg) fail(line_no, "a line of '=' must be followed by 'MSG: package/Type'");
      parse_line(line, line_no, current);
    }
    add_section(std::move(current));
  }

  // One line of a section: a field, a constant (validated, not kept) or, in
  // ROS 2, a field with its default value (the value is not kept).
  void parse_line(std::string_view line, int line_no, RawSection& section) {
    const std::size_t type_end = line.find_first_of(" \t");
    if (type_end == std::string_view::npos)
      fail(line_no, fmt::format("'{}' is not 'TYPE NAME'", printable(std::string(line))));
    const std::string type(line.substr(0, type_end));
    const std::string_view after_type = trim(line.substr(type_end));
    const std::size_t name_end = std::min(after_type.find_first_of(" \t=#"), after_type.size());
    const std::string name(after_type.substr(0, name_end));
    const std::string_view after_name = trim(after_type.substr(name_end));
    if (!is_identifier(name))
      fail(line_no, fmt::format("'{}' is not a field name", printable(name)));
    if (!after_name.empty() && after_name[0] == '=') {
      check_constant(type, name, after_name.substr(1), line_no);
      return;
    }
    if (!after_name.empty() && after_name[0] != '#' && encoding_ == Encoding::kRos1)
      fail(line_no, fmt::format("'{}' after the field {}: ROS 1 fields have no default value",
                                printable(std::string(after_name)), name));
    if (!field_names_.insert(name).second)
      fail(line_no, fmt::format("field {} is defined twice in {}", name, section.name));
    section.fields.push_back({type, name, line_no});
  }

  void check_constant(const std::string& type, const std::string& name, std::string_view value,
                      int line_no) {
    const bool primitive = std::any_of(std::begin(kPrimitives), std::end(kPrimitives),
                                       [&](const Primitive& p) { return type == p.name; }) ||
                           type == "byte" || type == "char";
    if (!primitive)
      fail(line_no, fmt::format("constant {} has type '{}': constants are primitives", name,
                                printable(type)));
    if (type != "string" && trim(value.substr(0, value.find('#'))).empty())
      fail(line_no, fmt::format("constant {} has no value", name));
  }

  // builtin_interfaces/Time and Duration are ROS 2's own and fixed: a ROS 2
  // definition that uses them without their section still means them. ROS 1's
  // time and duration are primitives, compiled as two-field structs.
  void add_implicit_sections() {
    const auto add = [&](RawSection section) {
      if (find_section(section.name) != nullptr) return;
      section_index_.emplace(section.name, sections_.size());
      sections_.push_back(std::move(section));
    };
    if (encoding_ == Encoding::kCdr) {
      for (const char* name : {"builtin_interfaces/Time", "builtin_interfaces/Duration"})
        add({name, 0, {{"int32", "sec", 0}, {"uint32", "nanosec", 0}}});
    } else {
      add({"time", 0, {{"uint32", "sec", 0}, {"uint32", "nsec", 0}}});
      add({"duration", 0, {{"int32", "sec", 0}, {"int32", "nsec", 0}}});
    }
  }

  TypeSpec parse_type(const std::string& token, int line) const {
    TypeSpec spec;
    std::string_view base(token);
    const std::size_t bracket = base.find('[');
    if (bracket != std::string_view::npos) {
      const std::string_view suffix = base.substr(bracket);
      base = base.substr(0, bracket);
      if (suffix.size() < 2 || suffix.back() != ']')
        fail(line, fmt::format("'{}' is not a type", printable(token)));
      const std::string_view inside = suffix.substr(1, suffix.size() - 2);
      if (inside.empty()) {
        spec.array = ArrayKind::kSequence;
      } else if (inside.substr(0, 2) == "<=") {
        spec.array = ArrayKind::kSequence;
        spec.count_or_bound = parse_count(inside.substr(2)).value_or(-1);
        if (spec.count_or_bound < 0)
          fail(line, fmt::format("'{}': bad array bound", printable(token)));
      } else {
        spec.array = ArrayKind::kFixed;
        spec.count_or_bound = parse_count(inside).value_or(-1);
        if (spec.count_or_bound < 0)
          fail(line, fmt::format("'{}': bad array length", printable(token)));
      }
    }
    const std::size_t le = base.find("<=");
    if (le != std::string_view::npos) {
      spec.string_bound = parse_count(base.substr(le + 2)).value_or(-1);
      base = base.substr(0, le);
      if (base != "string" && base != "wstring")
        fail(line, fmt::format("'{}': only strings have a bound", printable(token)));
      if (spec.string_bound < 0)
        fail(line, fmt::format("'{}': bad string bound", printable(token)));
    }
    spec.base = std::string(base);
    return spec;
  }

  // The section name a non-primitive base means, as used in `section`.
  std::string resolve_name(const std::string& base, const std::string& section, int line) const {
    if (base == "time" || base == "duration")
      return encoding_ == Encoding::kRos1
                 ? base
                 : "builtin_interfaces/" + std::string(base == "time" ? "Time" : "Duration");
    if (encoding_ == Encoding::kRos1 && base == "Header") return "std_msgs/Header";
    if (base.find('/') != std::string::npos) {
      const auto name = normalise_type_name(base);
      if (!name) fail(line, fmt::format("'{}' is not a type", printable(base)));
      return *name;
    }
    if (!is_identifier(base)) fail(line, fmt::format("'{}' is not a type", printable(base)));
    const std::size_t slash = section.find('/');
    return section.substr(0, slash) + "/" + base;
  }

  const RawSection* find_section(const std::string& name) const {
    const auto found = section_index_.find(name);
    return found == section_index_.end() ? nullptr : &sections_[found->second];
  }

  CompiledField compile_field(const RawField& raw, const RawSection& section,
                              std::vector<std::string>& stack) {
    const TypeSpec spec = parse_type(raw.type, raw.line);
    CompiledField f;
    f.name = raw.name;
    f.array = spec.array;
    if (spec.array == ArrayKind::kFixed) f.count = static_cast<std::uint32_t>(spec.count_or_bound);
    if (spec.array == ArrayKind::kSequence) f.bound = spec.count_or_bound;
    f.string_bound = spec.string_bound;
    if (spec.base == "wstring")
      fail(raw.line,
           fmt::format("field {}: wstring (UTF-16, implementation-defined in CDR) is not supported",
                       raw.name));
    const std::string& b = spec.base;
    const bool uint8_alias = b == "char" || (b == "byte" && encoding_ == Encoding::kCdr);
    const char* prim_name = uint8_alias ? "uint8" : b == "byte" ? "int8" : b.c_str();
    const auto prim =
        std::find_if(std::begin(kPrimitives), std::end(kPrimitives),
                     [&](const Primitive& p) { return std::string_view(prim_name) == p.name; });
    if (prim != std::end(kPrimitives)) {
      f.kind = prim->kind;
      f.min_element_bytes = prim->bytes;
    } else {
      const std::string name = resolve_name(b, section.name, raw.line);
      const RawSection* used = find_section(name);
      if (used == nullptr) {
        // A bare lowercase name was more likely meant as a primitive.
        std::vector<std::string> primitives{"byte", "char", "time", "duration"};
        for (const Primitive& p : kPrimitives) primitives.emplace_back(p.name);
        const bool bare =
            b.find('/') == std::string::npos && std::islower(static_cast<unsigned char>(b[0]));
        if (bare)
          fail(raw.line,
               fmt::format("field {}: '{}' is neither a primitive nor a type defined here ({}){}",
                           raw.name, printable(b), name, did_you_mean(b, primitives)));
        fail(raw.line, fmt::format("field {}: type {} is not defined", raw.name, name));
      }
      f.kind = Kind::kMessage;
      f.type = compile(name, stack);
      const CompiledStruct& s = structs_[static_cast<std::size_t>(f.type)];
      f.min_element_bytes = s.min_bytes;
      f.element_weight = detail::saturating_add(1, s.weight);
    }
    return f;
  }

  int compile(const std::string& name, std::vector<std::string>& stack) {
    if (const auto it = index_.find(name); it != index_.end()) return it->second;
    const auto chain = [&] {
      std::string out;
      for (const std::string& s : stack) out += s + " -> ";
      return out + name;
    };
    const RawSection& section = *find_section(name);
    if (std::find(stack.begin(), stack.end(), name) != stack.end())
      fail(section.line, fmt::format("recursive definition: {}", chain()));
    if (static_cast<int>(stack.size()) >= detail::kMaxNesting)
      fail(section.line, fmt::format("more than {} levels of nesting: {} -> ... -> {}",
                                     detail::kMaxNesting, stack.front(), name));
    stack.push_back(name);
    CompiledStruct s;
    s.name = name;
    for (const RawField& raw : section.fields) {
      CompiledField f = compile_field(raw, section, stack);
      const std::uint64_t one = f.kind == Kind::kMessage
                                    ? structs_[static_cast<std::size_t>(f.type)].min_bytes
                                    : f.min_element_bytes;
      if (f.kind == Kind::kMessage)
        s.height = std::max(s.height, 1 + structs_[static_cast<std::size_t>(f.type)].height);
      const std::uint64_t bytes = f.array == ArrayKind::kNone ? one
                                  : f.array == ArrayKind::kFixed
                                      ? detail::saturating_mul(f.count, one)
                                      : 4;
      s.min_bytes = detail::saturating_add(s.min_bytes, bytes);
      s.weight =
          detail::saturating_add(s.weight, f.array == ArrayKind::kNone ? f.element_weight : 1);
      s.fields.push_back(std::move(f));
    }
    if (s.height > detail::kMaxNesting)
      fail(section.line,
           fmt::format("more than {} levels of nesting below {}", detail::kMaxNesting, name));
    // ROS 2 gives a message without fields one uint8 (rosidl's
    // structure_needs_at_least_one_member), so that CDR has something to write.
    if (s.fields.empty() && encoding_ == Encoding::kCdr) {
      CompiledField placeholder;
      placeholder.name = "structure_needs_at_least_one_member";
      placeholder.kind = Kind::kUint8;
      placeholder.hidden = true;
      placeholder.min_element_bytes = 1;
      s.fields.push_back(placeholder);
      s.min_bytes = 1;
    }
    stack.pop_back();
    structs_.push_back(std::move(s));
    const int index = static_cast<int>(structs_.size()) - 1;
    index_.emplace(name, index);
    return index;
  }

  const std::string& type_;
  const std::string& text_;
  Encoding encoding_;
  const std::string& origin_;
  std::vector<RawSection> sections_;
  std::unordered_map<std::string, std::size_t> section_index_;  // by name
  std::unordered_set<std::string> field_names_;  // the fields of the section being split
  std::vector<CompiledStruct> structs_;
  std::map<std::string, int> index_;
};

}  // namespace

std::string builtin_definition(const std::string& type, Encoding encoding) {
  const auto name = normalise_type_name(type);
  const BuiltinType* builtin = name ? find_builtin(*name) : nullptr;
  if (builtin == nullptr) return {};
  const auto text = [&](const BuiltinType& t) {
    return std::string(encoding == Encoding::kCdr && t.ros2 != nullptr ? t.ros2 : t.ros1);
  };
  std::string out = text(*builtin);
  std::vector<std::string> uses;
  collect_uses(*builtin, encoding, uses);
  for (const std::string& use : uses) {
    out += "\n" + std::string(80, '=') + "\nMSG: " + use + "\n";
    if (use == "builtin_interfaces/Time")
      out +=
          "# Time indicates a specific point in time, relative to a clock's 0 point.\n"
          "# The seconds component, valid over all int32 values.\nint32 sec\n"
          "# The nanoseconds component, valid in the range [0, 1e9).\nuint32 nanosec\n";
    else
      out += text(*find_builtin(use));
  }
  return out;
}

std::shared_ptr<const MessageType> MessageType::parse(const std::string& type,
                                                      const std::string& definition,
                                                      Encoding encoding,
                                                      const std::string& origin) {
  return DefinitionParser(type, definition, encoding, origin).run();
}

}  // namespace hapticcal::recording
