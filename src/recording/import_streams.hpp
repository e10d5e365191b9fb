// Internal to the import (import.cpp, still_poses.cpp): the streams chosen from
// a recording's topics, and the static log made of their still windows.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "hapticcal/model/model.hpp"
#include "hapticcal/recording/import.hpp"
#include "recording/conventions.hpp"
#include "recording/import_topics.hpp"

namespace hapticcal::recording {

// A stream chosen for a file: its samples, the columns it gives and where it
// came from (the topic, and a TF topic's frames).
struct Stream {
  const TopicBuffer* topic = nullptr;
  const Samples* samples = nullptr;
  std::string what;                  // "/joint_states (sensor_msgs/JointState)"
  std::vector<std::string> columns;  // without t
  std::vector<int> take;             // the value index of each column (device: joint matching)
  int width = 0;                     // values a sample
  std::optional<Convention> convention;
  std::vector<std::string> field_paths;  // --field streams: each value's path
};

// One sample's values as written: the columns taken, or a convention's readings.
inline void row_values(const Stream& s, std::size_t i, std::vector<double>& out) {
  const double* row = s.samples->values.data() + static_cast<std::size_t>(s.width) * i;
  if (s.convention) return s.convention->readings_of(row, out);
  out.clear();
  for (const int k : s.take) out.push_back(row[k]);
}

// The static log (--static): one row a window of at least request.still_seconds
// in which no reading moves by more than request.still_tolerance, the readings
// and the tracker's samples in it averaged; windows whose tracker samples belong
// to another time (the tracker moved in them, or its clock is found ahead or
// behind the readings') are left out with a note. `model` (may be null): the
// device's, whose tool point's speed is set against the tracker's.
std::string static_csv(const Stream& device, const Stream& tracker, const ImportRequest& request,
                       const DeviceModel* model, std::int64_t origin, const std::string& comment,
                       ImportResult& result);

}  // namespace hapticcal::recording
