#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <filesystem>
#include <set>

#include "core/yaml_reader.hpp"
#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/data_io/fixture.hpp"

namespace hapticcal {
namespace {

// A fixture file states a few facts, not a data set: its size is bounded
// before YAML sees it, and so are its entries.
constexpr size_t kMaxFixtureEntries = 10000;
constexpr size_t kMaxFixtureLabel = 64;  // as a log's point label

class FixtureReader : public detail::YamlReader {
 public:
  using YamlReader::YamlReader;

  // A label as a log's point column holds it: non-empty, short, printable.
  std::string label(const YAML::Node& node, const std::string& key) const {
    const std::string text = string(node, key);
    if (text.empty()) fail(node, key, "empty label");
    if (text.size() > kMaxFixtureLabel)
      fail(node, key,
           fmt::format("a label of {} characters: at most {}", text.size(), kMaxFixtureLabel));
    if (const std::string problem = text_problem(text); !problem.empty())
      fail(node, key, "label " + problem);
    return text;
  }

  FixtureSource source(const YAML::Node& node, const std::string& key) const {
    const YAML::Mark mark = node.Mark();
    return {origin_, mark.is_null() ? 0 : mark.line + 1, key};
  }
};

}  // namespace

Fixture parse_fixture(const std::string& text, const std::string& origin) {
  if (text.size() > max_file_bytes(FileKind::kFixture)) {
    throw InputError(origin, 0, "",
                     fmt::format("{} bytes: a fixture file is at most {}", text.size(),
                                 max_file_bytes(FileKind::kFixture)));
  }
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(origin, e.mark.is_null() ? 0 : e.mark.line + 1, "", "YAML: " + e.msg);
  }
  if (!root || root.IsNull()) throw InputError(origin, 0, "", "empty fixture file");
  const FixtureReader r(origin);
  r.check_keys(root, "", {"points", "distances"});
  Fixture out;
  if (const YAML::Node points = root["points"]) {
    r.expect_map(points, "points");
    if (points.size() > kMaxFixtureEntries)
      r.fail(points, "points", fmt::format("at most {} points", kMaxFixtureEntries));
    std::set<std::string> seen;
    for (const auto& kv : points) {
      const std::string name = r.label(kv.first, "points");
      const std::string key = detail::join("points", printable(name));
      if (!seen.insert(name).second) r.fail(kv.first, key, "repeated label");
      const std::vector<double> xyz = r.numbers(kv.second, key, 3);
      out.points.push_back(
          {name, Eigen::Vector3d(xyz[0], xyz[1], xyz[2]), r.source(kv.first, key)});
    }
  }
  if (const YAML::Node distances = root["distances"]) {
    if (!distances.IsSequence())
      r.fail(distances, "distances", "expected a list of [A, B, METRES]");
    if (distances.size() > kMaxFixtureEntries)
      r.fail(distances, "distances", fmt::format("at most {} distances", kMaxFixtureEntries));
    for (size_t i = 0; i < distances.size(); ++i) {
      const YAML::Node d = distances[i];
      const std::string key = fmt::format("distances[{}]", i);
      if (!d.IsSequence() || d.size() != 3) r.fail(d, key, "expected [A, B, METRES]");
      PointDistance known;
      known.a = r.label(d[0], key + "[0]");
      known.b = r.label(d[1], key + "[1]");
      known.metres = r.number(d[2], key + "[2]");
      if (!(known.metres > 0))
        r.fail(d[2], key + "[2]", fmt::format("{} m: a distance must be positive", known.metres));
      known.source = r.source(d, key);
      out.distances.push_back(known);
    }
  }
  return out;
}

Fixture load_fixture(const std::string& path) {
  return parse_fixture(read_file(path, FileKind::kFixture), path);
}

PointDistance parse_point_distance(const std::string& spec) {
  const size_t colon = spec.find(':'), equals = spec.find('=');
  PointDistance d;
  bool ok = colon != std::string::npos && equals != std::string::npos && colon > 0 &&
            equals > colon + 1 && equals + 1 < spec.size();
  if (ok) {
    d.a = spec.substr(0, colon);
    d.b = spec.substr(colon + 1, equals - colon - 1);
    size_t used = 0;
    try {
      d.metres = std::stod(spec.substr(equals + 1), &used);
    } catch (const std::exception&) {
      used = 0;
    }
    ok = used == spec.size() - equals - 1 && d.metres > 0 && std::isfinite(d.metres);
  }
  if (!ok) {
    throw InputError(fmt::format(
        "--point-distance '{}': expected A:B=METRES (two point labels and a positive distance)",
        printable(spec, 200)));
  }
  return d;
}

Fixture fixture_facts(const std::string& file, const std::vector<std::string>& point_distances) {
  Fixture fixture = file.empty() ? Fixture{} : load_fixture(file);
  for (const std::string& spec : point_distances)
    fixture.distances.push_back(parse_point_distance(spec));
  return fixture;
}

}  // namespace hapticcal
