// The layout of a Motive export, and the matching of names that Motive's and
// Vicon's layouts share (Vicon's is tracker_vicon.cpp's); their rows are read by
// read_samples (tracker_export.cpp).
//
// OptiTrack Motive (https://docs.optitrack.com/motive/data-export/data-export-csv):
// a first line of key,value pairs ("Format Version", "Take Name", "Capture Frame
// Rate", ..., "Rotation Type", "Length Units", "Coordinate Space"), then header
// rows labelled "Type" (Rigid Body, Rigid Body Marker, Marker, Bone, ...), "Name"
// and "ID", a row naming each column's quantity ("Rotation", "Position", "Mean
// Marker Error", ...) and the row "Frame,Time (Seconds),X,Y,Z,W,...", then one
// row a frame; an occluded marker leaves its cells blank. Rotation Type is
// "Quaternion" or an order of Euler angles in degrees (XYZ, XZY, YXZ, YZX, ZXY,
// ZYX: https://v21.wiki.optitrack.com/index.php?title=Data_Export:_CSV), each
// order relative (intrinsic: "XYZ" rotates about X, then the new Y, then the new
// Z, https://help.naturalpoint.com/kb/articles/changes-in-motive-s-reported-euler-angles),
// the angles in the columns labelled X, Y, Z. Coordinate Space Local (relative to
// a parent bone) is refused: a calibration needs the capture volume's frame.
#include <fmt/format.h>

#include <algorithm>
#include <initializer_list>
#include <map>
#include <set>
#include <string_view>

#include "hapticcal/core/error.hpp"
#include "hapticcal/recording/tracker_export.hpp"
#include "recording/tracker_csv.hpp"

namespace hapticcal::recording {

using detail::at;
using detail::copy;
using detail::CsvLines;
using detail::fail;
using detail::match_one;
using detail::Rotation;
using detail::SamplePlan;
using detail::unique;

namespace detail {

std::vector<std::string> unique(const std::vector<std::string>& names) {
  std::vector<std::string> out;
  std::set<std::string_view> seen;
  for (const std::string& n : names) {
    if (seen.insert(n).second) out.push_back(n);
  }
  return out;
}

std::string match_one(const std::vector<std::string>& names, const std::string& wanted,
                      const std::string& file, int line, const char* what,
                      const std::string& prefix) {
  if (std::find(names.begin(), names.end(), wanted) != names.end()) return wanted;
  if (!prefix.empty()) {
    const std::string full = prefix + ":" + wanted;
    if (std::find(names.begin(), names.end(), full) != names.end()) return full;
  }
  std::vector<std::string> found;
  for (const std::string& n : names) {
    if (detail::names_match(n, wanted)) found.push_back(n);
  }
  if (found.size() > 1) {
    fail(
        file, line, 1,
        fmt::format("{} '{}' is ambiguous: {}", what, printable(wanted), detail::name_list(found)));
  }
  return found.empty() ? std::string() : found[0];
}

std::vector<std::string> copy(const std::vector<std::string_view>& fields) {
  return std::vector<std::string>(fields.begin(), fields.end());
}

std::string at(const std::vector<std::string>& row, std::size_t k) {
  return k < row.size() ? row[k] : std::string();
}

}  // namespace detail

namespace {

// ---- Motive ----

// A Motive export's header: its first line's pairs and the rows above the data.
struct MotiveHeader {
  std::map<std::string, std::pair<std::string, std::size_t>> info;  // key -> value, its column
  std::vector<std::string> type, name, kind, component;             // per column
  int line = 0;                                                     // of the "Frame" row
};

MotiveHeader read_motive_header(CsvLines& lines) {
  MotiveHeader h;
  const std::string& file = lines.name();
  if (!lines.next() || lines.field(0) != "Format Version") {
    fail(file, 1, 1, "not a Motive export: its first line does not begin \"Format Version,\"");
  }
  // A key given twice must say the same (which of two length units is meant?).
  for (std::size_t k = 0; k + 1 < lines.fields().size(); k += 2) {
    if (lines.field(k).empty()) continue;
    const std::string key(lines.field(k)), value(lines.field(k + 1));
    const auto [it, added] = h.info.emplace(key, std::make_pair(value, k + 2));
    if (!added && it->second.first != value) {
      fail(file, 1, k + 2,
           fmt::format("'{}' is given twice: '{}' (column {}) and '{}': the header contradicts "
                       "itself",
                       printable(key), printable(it->second.first), it->second.second,
                       printable(value)));
    }
  }
  bool frame_row = false;
  std::map<std::string_view, int> row_lines;  // a header row's line, to refuse a second
  while (!frame_row && lines.next()) {
    if (lines.blank()) continue;
    double number = 0;
    if (detail::parse_number(lines.field(0), number)) {
      fail(file, lines.number(), 1, "a data row before the header's \"Frame,Time\" row");
    }
    const std::string_view label = lines.field(0).empty() ? lines.field(1) : lines.field(0);
    std::vector<std::string>* row = lines.field(0) == "Frame" ? &h.component
                                    : label == "Type"         ? &h.type
                                    : label == "Name"         ? &h.name
                                    : label.empty()           ? &h.kind  // "Rotation", ...
                                                              : nullptr;
    if (row == nullptr) continue;  // other rows ("ID", newer exports' additions) name nothing read
    const std::string_view key = row == &h.kind ? "Rotation/Position" : label;
    if (const auto [it, added] = row_lines.emplace(key, lines.number());
        !added && *row != copy(lines.fields())) {
      fail(file, lines.number(), 1,
           fmt::format("a second \"{}\" header row, unlike line {}'s: the header contradicts "
                       "itself",
                       key, it->second));
    }
    *row = copy(lines.fields());
    if (row == &h.component) h.line = lines.number(), frame_row = true;
  }
  if (!frame_row) {
    fail(file, lines.number() + 1, 1,
         "the file ends in its header: no \"Frame,Time (Seconds),...\" row");
  }
  const char* missing = h.type.empty()   ? "Type"
                        : h.name.empty() ? "Name"
                        : h.kind.empty() ? "Rotation/Position"
                                         : nullptr;
  if (missing != nullptr) {
    fail(file, h.line, 1, fmt::format("no \"{}\" header row above the \"Frame\" row", missing));
  }
  return h;
}

bool is_pose_type(const std::string& type) { return type == "Rigid Body" || type == "Bone"; }

// The columns of body `body`'s pose into `plan`.
void motive_pose(const MotiveHeader& h, const std::string& body, const std::string& file,
                 SamplePlan& plan) {
  std::map<std::string, std::size_t> rotation, position;
  for (std::size_t c = 2; c < h.component.size(); ++c) {
    if (!is_pose_type(at(h.type, c)) || at(h.name, c) != body) continue;
    const std::string kind = at(h.kind, c), comp = at(h.component, c);
    auto* into = kind == "Rotation" ? &rotation : kind == "Position" ? &position : nullptr;
    if (into != nullptr && !into->emplace(comp, c).second) {
      fail(file, h.line, c + 1,
           fmt::format("'{}' has two {} {} columns", printable(body), kind, printable(comp)));
    }
  }
  const auto need = [&](const std::map<std::string, std::size_t>& cols, char comp,
                        const char* kind) {
    const auto it = cols.find(std::string(1, comp));
    if (it == cols.end()) {
      throw InputError(
          file, h.line, fmt::format("column '{} {}'", kind, comp),
          fmt::format("rigid body '{}' has no {} {} column", printable(body), kind, comp));
    }
    return it->second;
  };
  plan.reads_position = true;
  for (std::size_t k = 0; k < 3; ++k) plan.position[k] = need(position, "XYZ"[k], "Position");
  const auto type = h.info.find("Rotation Type");
  if (type == h.info.end()) {
    fail(file, 1, 1, "no \"Rotation Type\" in the first line: the orientation's form is unknown");
  }
  const std::string& form = type->second.first;
  static const std::string_view kOrders[] = {"XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"};
  if (form == "Quaternion") {
    plan.rotation = Rotation::kQuaternion;
    for (std::size_t k = 0; k < 4; ++k) {
      plan.rotation_columns[k] = need(rotation, "WXYZ"[k], "Rotation");
    }
  } else if (std::find(std::begin(kOrders), std::end(kOrders), form) != std::end(kOrders)) {
    // Euler angles have no W: X, Y, Z beside a W are a quaternion's.
    if (const auto w = rotation.find("W"); w != rotation.end()) {
      fail(file, h.line, w->second + 1,
           fmt::format("rigid body '{}' has a Rotation W column, a quaternion's, but the first "
                       "line states Rotation Type '{}' (Euler angles; column {}): the header "
                       "contradicts itself",
                       printable(body), printable(form), type->second.second));
    }
    plan.rotation = Rotation::kEuler;
    plan.euler_order = form;
    plan.angle_scale = M_PI / 180;  // Motive writes Euler angles in degrees
    for (std::size_t k = 0; k < 3; ++k) {
      plan.rotation_columns[k] = need(rotation, "XYZ"[k], "Rotation");
    }
  } else {
    fail(file, 1, type->second.second,
         fmt::format("Rotation Type '{}' is not read (Quaternion, or Euler XYZ, XZY, YXZ, YZX, "
                     "ZXY, ZYX)",
                     printable(form)));
  }
}

// The names of the markers, measured ones ("Marker") before a rigid body's or
// bone's expected positions ("Rigid Body Marker", "Bone Marker").
const char* const kMarkerTypes[] = {"Marker", "Rigid Body Marker", "Bone Marker"};

std::vector<std::string> motive_names(const MotiveHeader& h, const std::string& type) {
  std::vector<std::string> names;
  for (std::size_t c = 2; c < h.component.size(); ++c) {
    if (at(h.type, c) == type && at(h.kind, c) == "Position") names.push_back(at(h.name, c));
  }
  return unique(names);
}

// The columns of marker `wanted` into `plan`; its full name.
std::string motive_marker(const MotiveHeader& h, const std::string& wanted, const std::string& body,
                          const std::string& file, SamplePlan& plan) {
  for (const char* type : kMarkerTypes) {
    const std::string found =
        match_one(motive_names(h, type), wanted, file, h.line, "marker", body);
    if (found.empty()) continue;
    std::array<std::size_t, 3> cols{};
    std::array<bool, 3> seen{};
    for (std::size_t c = 2; c < h.component.size(); ++c) {
      if (at(h.type, c) != type || at(h.name, c) != found || at(h.kind, c) != "Position") continue;
      const std::string comp = at(h.component, c);
      const std::size_t k = comp == "X" ? 0 : comp == "Y" ? 1 : comp == "Z" ? 2 : 3;
      if (k < 3 && !seen[k]) cols[k] = c, seen[k] = true;
    }
    if (!(seen[0] && seen[1] && seen[2])) {
      fail(file, h.line, 1,
           fmt::format("marker '{}' lacks a Position X, Y or Z column", printable(found)));
    }
    plan.markers.push_back(cols);
    return found;
  }
  std::vector<std::string> all;
  for (const char* type : kMarkerTypes) {
    for (const std::string& n : motive_names(h, type)) all.push_back(n);
  }
  throw InputError(file, h.line, fmt::format("marker '{}'", printable(wanted)),
                   fmt::format("no such marker (the file has {}){}",
                               all.empty() ? std::string("none") : detail::name_list(unique(all)),
                               did_you_mean(wanted, all)));
}

}  // namespace

TrackerStream read_motive_csv(const std::string& text, const std::string& name,
                              const TrackerExportOptions& options) {
  CsvLines lines(text, name);
  const MotiveHeader h = read_motive_header(lines);
  if (const auto space = h.info.find("Coordinate Space");
      space != h.info.end() && space->second.first != "Global") {
    fail(name, 1, space->second.second,
         fmt::format("Coordinate Space '{}': only Global (the capture volume's frame) is read; "
                     "export with Coordinate Space Global",
                     printable(space->second.first)));
  }
  SamplePlan plan;
  plan.width = h.component.size();
  const std::string time_label = at(h.component, 1);
  if (time_label.rfind("Time (", 0) != 0 || time_label.back() != ')') {
    fail(name, h.line, 2, fmt::format("'{}' is not \"Time (Seconds)\"", printable(time_label)));
  }
  plan.time_column = 1;
  plan.time_scale = detail::resolve_unit(
      name, h.line, 2, "time", std::string_view(time_label).substr(6, time_label.size() - 7),
      options.time_unit, "--time-unit");
  TrackerStream stream;
  const auto version = h.info.find("Format Version");
  stream.source = fmt::format("Motive CSV {}", printable(version->second.first));
  const std::vector<std::string> bodies = [&] {
    std::vector<std::string> names;
    for (std::size_t c = 2; c < h.component.size(); ++c) {
      if (is_pose_type(at(h.type, c))) names.push_back(at(h.name, c));
    }
    return unique(names);
  }();
  std::vector<std::string> wanted_markers = options.markers;
  if (wanted_markers.empty()) {
    std::string body = options.body;
    if (body.empty() && bodies.size() > 1) {
      fail(name, h.line, 1,
           fmt::format("{} rigid bodies: {}: give --body NAME", bodies.size(),
                       detail::name_list(bodies)));
    }
    if (body.empty() && bodies.size() == 1) body = bodies[0];
    if (!body.empty()) {
      const std::string found = match_one(bodies, body, name, h.line, "rigid body");
      if (found.empty()) {
        throw InputError(name, h.line, fmt::format("rigid body '{}'", printable(body)),
                         fmt::format("no such rigid body (the file has {}){}",
                                     bodies.empty() ? "none" : detail::name_list(bodies),
                                     did_you_mean(body, bodies)));
      }
      motive_pose(h, found, name, plan);
      stream.source += fmt::format(", rigid body '{}'", printable(found));
    } else {
      const std::vector<std::string> markers = motive_names(h, "Marker");
      if (markers.size() != 1) {
        fail(name, h.line, 1,
             markers.empty() ? std::string("no rigid body and no marker")
                             : fmt::format("no rigid body and {} markers: {}: give --marker NAME",
                                           markers.size(), detail::name_list(markers)));
      }
      wanted_markers = markers;
    }
  }
  for (const std::string& wanted : wanted_markers) {
    stream.marker_names.push_back(motive_marker(h, wanted, options.body, name, plan));
  }
  detail::check_markers_once(wanted_markers, stream.marker_names, name);
  if (!wanted_markers.empty()) {
    stream.source += fmt::format(", markers {}", detail::name_list(stream.marker_names));
  }
  const auto units = h.info.find("Length Units");
  const double length = detail::resolve_unit(
      name, 1, units == h.info.end() ? 1 : units->second.second, "length",
      units == h.info.end() ? std::string_view() : std::string_view(units->second.first),
      options.length_unit, "--length-unit");
  plan.position_scale = {length, length, length};
  plan.marker_scale.assign(plan.markers.size(), {length, length, length});
  detail::read_samples(lines, plan, false, stream);
  if (stream.t.empty() && stream.lost == 0) fail(name, lines.number() + 1, 1, "no data rows");
  return stream;
}

}  // namespace hapticcal::recording
