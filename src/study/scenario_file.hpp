// Internal to the scenario reader (scenario.cpp and scenario_session.cpp): the
// bounds on a scenario file's numbers, its YAML reader, the file as parsed, and
// the readers of the sections that live apart from scenario.cpp.
#pragma once

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <string>

#include "core/yaml_reader.hpp"
#include "hapticcal/study/study.hpp"

namespace hapticcal::detail {

// Bounds on the numbers of a scenario file that both files check (the others
// are each file's own): a typo must not ask for terabytes of samples or a
// deviation that no device has.
constexpr double kMaxSocketCoordinate = 100;   // m
constexpr double kMaxTrajectorySamples = 1e7;  // seconds * rate_hz
constexpr double kMaxSigmaLength = 1;          // m

// The YAML reader's strict values, and the bounded integers of seeds and counts.
class ScenarioReader : public detail::YamlReader {
 public:
  using YamlReader::YamlReader;

  // A whole number in [lo, hi] (written as any number: 2e3 is 2000).
  int integer(const YAML::Node& node, const std::string& key, int lo, int hi) const {
    const double v = number(node, key);
    if (v != std::floor(v) || v < lo || v > hi)
      fail(node, key, fmt::format("expected an integer in [{}, {}]", lo, hi));
    return static_cast<int>(v);
  }
};

// A scenario file as parsed: where it is (its relative paths are resolved
// against its folder), the reader that names it in every error, and its root
// mapping, whose keys and format are checked.
struct ScenarioFile {
  std::string path;
  ScenarioReader r;
  YAML::Node root;
};

// session: a hand-guided session on two clocks (scenario_session.cpp).
void read_session(const ScenarioFile& file, Scenario& sc);
// iso9283: the ISO 9283 cube's study (scenario_session.cpp).
void read_iso9283(const ScenarioFile& file, Scenario& sc);

}  // namespace hapticcal::detail
