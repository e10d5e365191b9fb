// Fixture files (calibrate and evaluate --fixture): known facts about the
// labelled points of a fixture log, in metres in the measurement frame.
//   points:     {LABEL: [x, y, z], ...}   known positions (optional)
//   distances:  [[A, B, METRES], ...]     known distances (optional)
// Every problem is an InputError naming the file, the line and the key.
#pragma once

#include <string>
#include <vector>

#include "hapticcal/identification/measurement.hpp"

namespace hapticcal {

struct Fixture {
  std::vector<KnownPoint> points;
  std::vector<PointDistance> distances;
};

// origin names the text in error messages (a file name). Checks the file on
// its own (keys, numbers, labels, sizes); whether its labels are a log's is
// fixture_labels' to say.
Fixture parse_fixture(const std::string& yaml_text, const std::string& origin);
Fixture load_fixture(const std::string& path);

// One --point-distance A:B=METRES (a known distance between two fixture
// points); InputError naming the option otherwise.
PointDistance parse_point_distance(const std::string& spec);
// The facts of a fixture file (none if `file` is empty) and of --point-distance
// specs together, the file's first (fixture_labels refuses a distance given
// twice or two for one pair).
Fixture fixture_facts(const std::string& file, const std::vector<std::string>& point_distances);

}  // namespace hapticcal
