// Strict reading of YAML documents (device and scenario files): every failure
// is an InputError naming the origin, the line and the key path. Internal.
#pragma once

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "hapticcal/core/error.hpp"

namespace hapticcal::detail {

inline std::string join(const std::string& path, const std::string& key) {
  return path.empty() ? key : path + "." + key;
}

// YAML 1.2's non-finite numbers: [-+]?.(inf|Inf|INF|nan|NaN|NAN).
inline bool yaml_non_finite(const std::string& text) {
  std::string_view t = text;
  if (!t.empty() && (t[0] == '-' || t[0] == '+')) t.remove_prefix(1);
  for (const char* word : {".inf", ".Inf", ".INF", ".nan", ".NaN", ".NAN"}) {
    if (t == word) return true;
  }
  return false;
}

// Reads YAML nodes strictly; every failure names the origin, line and key path.
class YamlReader {
 public:
  explicit YamlReader(std::string origin) : origin_(std::move(origin)) {}

  [[noreturn]] void fail(const YAML::Node& at, const std::string& key,
                         const std::string& message) const {
    const YAML::Mark mark = at.Mark();
    throw InputError(origin_, mark.is_null() ? 0 : mark.line + 1, key, message);
  }

  void expect_map(const YAML::Node& node, const std::string& path) const {
    if (!node.IsMap()) fail(node, path, "expected a mapping");
  }

  // Fails on keys outside `allowed` and on repeated keys.
  void check_keys(const YAML::Node& map, const std::string& path,
                  std::initializer_list<const char*> allowed) const {
    check_keys(map, path, std::vector<std::string>(allowed.begin(), allowed.end()));
  }
  void check_keys(const YAML::Node& map, const std::string& path,
                  const std::vector<std::string>& allowed) const {
    expect_map(map, path);
    std::set<std::string> seen;
    for (const auto& kv : map) {
      const std::string key = kv.first.IsScalar() ? kv.first.Scalar() : "?";
      if (std::find(allowed.begin(), allowed.end(), key) == allowed.end()) {
        std::string list;
        for (const std::string& a : allowed) list += (list.empty() ? "" : ", ") + a;
        fail(kv.first, join(path, printable(key)),
             fmt::format("unknown key (expected one of: {})", list));
      }
      if (!seen.insert(key).second) fail(kv.first, join(path, key), "repeated key");
    }
  }

  YAML::Node require(const YAML::Node& map, const std::string& path, const char* key) const {
    const YAML::Node node = map[key];
    if (!node) fail(map, join(path, key), "missing");
    return node;
  }

  double number(const YAML::Node& node, const std::string& key) const {
    if (!node.IsScalar() || node.Tag() == "!") fail(node, key, "expected a number");
    const std::string& text = node.Scalar();
    if (yaml_non_finite(text)) fail(node, key, fmt::format("'{}' is not finite", text));
    const char* begin = text.data();
    const char* end = text.data() + text.size();
    if (begin != end && *begin == '+') ++begin;
    double value = 0;
    const auto [ptr, ec] = std::from_chars(begin, end, value);
    if (ec == std::errc::result_out_of_range)
      fail(node, key, fmt::format("'{}' is out of range", printable(text)));
    if (ec != std::errc() || ptr != end)
      fail(node, key, fmt::format("'{}' is not a number", printable(text)));
    if (!std::isfinite(value)) fail(node, key, fmt::format("'{}' is not finite", printable(text)));
    return value;
  }

  double number(const YAML::Node& map, const std::string& path, const char* key) const {
    return number(require(map, path, key), join(path, key));
  }

  std::string string(const YAML::Node& node, const std::string& key) const {
    if (!node.IsScalar()) fail(node, key, "expected a string");
    return node.Scalar();
  }

  std::vector<double> numbers(const YAML::Node& node, const std::string& key, int count) const {
    if (!node.IsSequence()) fail(node, key, "expected a list of numbers");
    if (count >= 0 && static_cast<int>(node.size()) != count) {
      fail(node, key, fmt::format("expected {} numbers, got {}", count, node.size()));
    }
    std::vector<double> values;
    for (size_t i = 0; i < node.size(); ++i) {
      values.push_back(number(node[i], fmt::format("{}[{}]", key, i)));
    }
    return values;
  }

  // A pose {xyz: [x, y, z], rpy: [roll, pitch, yaw]} into `out`.
  void pose(const YAML::Node& node, const std::string& path, std::array<double, 6>& out) const {
    check_keys(node, path, {"xyz", "rpy"});
    const auto xyz = numbers(require(node, path, "xyz"), join(path, "xyz"), 3);
    const auto rpy = numbers(require(node, path, "rpy"), join(path, "rpy"), 3);
    out = {xyz[0], xyz[1], xyz[2], rpy[0], rpy[1], rpy[2]};
  }

 protected:
  std::string origin_;
};

}  // namespace hapticcal::detail
