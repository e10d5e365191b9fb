// The import's request checked before anything is read (import_request.hpp).
#include "recording/import_request.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "hapticcal/core/error.hpp"

namespace hapticcal::recording {
namespace {

// --list writes nothing and decodes no topic: an option of an import given
// with it would have no effect.
void check_list_request(const ImportRequest& request) {
  if (!request.list) return;
  std::vector<std::string> given;
  const auto option = [&](bool set, const char* name) {
    if (set) given.emplace_back(name);
  };
  option(!request.out.empty(), "--out");
  option(!request.model.empty(), "--model");
  option(!request.convention.empty(), "--convention");
  option(!request.joints_topic.empty(), "--joints");
  option(!request.tracker_topic.empty(), "--tracker-topic");
  option(!request.frames.empty(), "--frames");
  option(!request.fields.empty(), "--field");
  option(!request.tracker_export.empty(), "--tracker-export");
  option(request.still_seconds > 0, "--static");
  if (given.empty()) return;
  throw InputError("", 0, "--list",
                   fmt::format("lists the recording's topics and writes nothing: {} would have no "
                               "effect with it (leave --list out to import)",
                               fmt::join(given, ", ")));
}

}  // namespace

// --frames PARENT,CHILD.
std::pair<std::string, std::string> frames_of(const std::string& frames) {
  const std::size_t comma = frames.find(',');
  if (comma == std::string::npos || comma == 0 || comma + 1 == frames.size())
    throw InputError("", 0, "--frames", "'" + printable(frames) + "': not PARENT,CHILD");
  return {frames.substr(0, comma), frames.substr(comma + 1)};
}

// Options that would have no effect are refused: nothing is silently ignored.
void check_request(const ImportRequest& request, const std::vector<FieldRequest>& fields) {
  if (request.recording.empty() && request.tracker_export.empty())
    throw InputError("", 0, "RECORDING",
                     "give a recording (a bag, .mcap or .db3) or --tracker-export FILE");
  if (request.recording.empty() && request.list)
    throw InputError("", 0, "--list", "lists a recording's topics: give the recording");
  check_list_request(request);
  if (request.still_seconds <= 0 && (request.still_tolerance || request.tracker_still)) {
    throw InputError("", 0, request.still_tolerance ? "--still-tolerance" : "--tracker-still",
                     "applies to the still windows of a static log: give --static SECONDS");
  }
  if (!(std::abs(request.clock_offset) <= 3600))
    throw InputError("", 0, "--clock-offset", "at most 3600 s either way");
  if (request.clock_offset != 0 && request.still_seconds <= 0)
    throw InputError("", 0, "--clock-offset",
                     "shifts the tracker's stamps of a static log: give --static SECONDS");
  const TrackerExportOptions& e = request.export_options;
  const bool export_options = !e.body.empty() || !e.markers.empty() || !e.column_map.empty() ||
                              !e.length_unit.empty() || !e.time_unit.empty();
  if (request.tracker_export.empty() && export_options) {
    throw InputError("", 0, "--tracker-export",
                     "--body, --markers, --column-map, --length-unit and --time-unit read a "
                     "tracker's export: give --tracker-export FILE");
  }
  const bool tracker_field =
      std::any_of(fields.begin(), fields.end(), [](const FieldRequest& f) { return !f.device; });
  if (!request.tracker_export.empty() &&
      (!request.tracker_topic.empty() || !request.frames.empty() || tracker_field)) {
    throw InputError("", 0, "--tracker-export",
                     "the tracker's stream comes from the export: no --tracker-topic, --frames or "
                     "--field of x, y, z or distance with it");
  }
  if (request.recording.empty() &&
      (!request.joints_topic.empty() || !fields.empty() || !request.model.empty() ||
       !request.convention.empty() || request.still_seconds > 0)) {
    throw InputError(
        "", 0, "RECORDING",
        "--joints, --field, --model, --convention and --static read a recording: give it");
  }
}

Wanted wanted_of(const ImportRequest& request, const std::vector<FieldRequest>& fields) {
  Wanted w;
  w.joints_topic = request.joints_topic;
  w.tracker_topic = request.tracker_topic;
  if (!request.frames.empty()) w.frames = frames_of(request.frames);
  w.fields = fields;
  w.stamps = request.stamps;
  w.list = request.list;
  return w;
}

}  // namespace hapticcal::recording
