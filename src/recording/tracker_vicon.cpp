// The layout of a Vicon export; its rows are read by read_samples (tracker_export.cpp).
//
// Vicon Nexus's CSV export (the layout the Vicon Nexus Reference Guide's export
// describes, https://usermanual.wiki/Document/Vicon20Nexus20Reference20Guide.1696009346/html,
// and a Vicon Tracker trajectory export shown line by line at
// https://ccu.uni-konstanz.de/wiki/Vicon:Data_format_documentation): sections
// ("Devices", "Joints", "Model Outputs", "Segments", "Trajectories"), each a line
// with its title alone, a line with its frame rate in Hz, a line of names
// ("Subject:Marker", each at the first of its columns), the line "Frame,Sub
// Frame,X,Y,Z,..." (segments: RX,RY,RZ, the helical angle (rotation vector), and
// TX,TY,TZ), a line of units ("mm", "deg"), then one row a frame, up to a blank
// line. A row's time is its frame number / the section's frame rate (the line
// under its title). Rows between frames (sub frame not 0: devices sampled
// faster) are refused; the Devices section is never read. Tracker's object
// export is read when it has this sectioned layout (its own is not documented).
#include <fmt/format.h>

#include <algorithm>
#include <initializer_list>
#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

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

namespace {

// ---- Vicon ----

// A named quantity of a Vicon section: its columns by label ("X", "RX", ...) and
// their units.
struct ViconGroup {
  std::string name;
  std::map<std::string, std::pair<std::size_t, std::string>> columns;  // label -> column, unit
  bool has(std::initializer_list<const char*> labels) const {
    return std::all_of(labels.begin(), labels.end(),
                       [&](const char* l) { return columns.count(l) > 0; });
  }
};

struct ViconSection {
  std::string title;
  int title_line = 0;
  int rate_line = 0;
  double rate_hz = 0;
  std::size_t width = 0;  // of its "Frame,Sub Frame,..." row
  int units_line = 0;     // 0 without a units row
  int data_line = 0;      // the first line after its header rows, and where it starts
  std::size_t data_offset = 0;
  std::vector<ViconGroup> groups;
};

// The next line, or InputError: the file ends inside section `title`'s header.
void header_line(CsvLines& lines, const std::string& title) {
  if (!lines.next()) {
    fail(lines.name(), lines.number() + 1, 1,
         fmt::format("the file ends in the header of section '{}'", printable(title)));
  }
}

// A section's header rows, from its title line (the current line) on; leaves
// `lines` on its last header row.
ViconSection read_section_header(CsvLines& lines) {
  ViconSection s;
  s.title = std::string(lines.field(0));
  s.title_line = lines.number();
  header_line(lines, s.title);
  s.rate_line = lines.number();
  if (!detail::parse_number(lines.field(0), s.rate_hz)) {
    fail(lines.name(), lines.number(), 1,
         fmt::format("no frame rate (Hz) under the section title '{}' (line {})",
                     printable(s.title), s.title_line));
  }
  if (!(s.rate_hz > detail::kMinRateHz && s.rate_hz <= detail::kMaxRateHz)) {
    fail(lines.name(), lines.number(), 1,
         fmt::format("a frame rate of {:.6g} Hz (section '{}'): a tracker's lies in ({:g}, {:g}] "
                     "Hz",
                     s.rate_hz, printable(s.title), detail::kMinRateHz, detail::kMaxRateHz));
  }
  header_line(lines, s.title);
  const std::vector<std::string> names = copy(lines.fields());
  header_line(lines, s.title);
  if (lines.field(0) != "Frame" || lines.field(1) != "Sub Frame") {
    fail(lines.name(), lines.number(), lines.field(0) != "Frame" ? 1 : 2,
         "not the row \"Frame,Sub Frame,...\" of the section's column labels");
  }
  const std::vector<std::string> labels = copy(lines.fields());
  s.width = labels.size();
  s.data_offset = lines.next_offset();
  s.data_line = lines.number() + 1;
  std::vector<std::string> units;
  if (lines.next()) {
    if (lines.field(0).empty() && !lines.blank()) {  // ",,mm,mm,mm,..."
      units = copy(lines.fields());
      s.units_line = lines.number();
      s.data_offset = lines.next_offset();
      s.data_line = lines.number() + 1;
    } else {
      lines.seek(s.data_offset, s.data_line);  // no units row: read that line again
    }
  }
  for (std::size_t c = 2; c < labels.size(); ++c) {
    if (c < names.size() && !names[c].empty()) s.groups.push_back({names[c], {}});
    if (s.groups.empty() || labels[c].empty()) continue;
    if (!s.groups.back().columns.emplace(labels[c], std::make_pair(c, at(units, c))).second) {
      fail(lines.name(), s.data_line - (s.units_line > 0 ? 2 : 1), c + 1,
           fmt::format("'{}' has two {} columns", printable(s.groups.back().name),
                       printable(labels[c])));
    }
  }
  return s;
}

// Every section's header; the data rows are passed over.
std::vector<ViconSection> read_sections(CsvLines& lines) {
  std::vector<ViconSection> sections;
  bool in_data = false;
  while (lines.next()) {
    if (lines.blank()) {
      in_data = false;
      continue;
    }
    if (!detail::is_title(lines)) {
      if (!in_data) fail(lines.name(), lines.number(), 1, "a data row outside a section");
      detail::number_at(lines, 0, "frame");
      continue;
    }
    sections.push_back(read_section_header(lines));
    in_data = true;
  }
  if (sections.empty()) fail(lines.name(), lines.number() + 1, 1, "no section");
  return sections;
}

bool is_pose(const ViconGroup& g) { return g.has({"RX", "RY", "RZ", "TX", "TY", "TZ"}); }
bool is_marker(const ViconGroup& g) { return g.has({"X", "Y", "Z"}); }

struct ViconChoice {
  const ViconSection* section = nullptr;
  std::vector<const ViconGroup*> groups;
};

// The pose `body` (or the only one, with `body` empty): Segments before other
// sections (Model Outputs, Joints). Null if there is none.
const ViconGroup* vicon_pose(const std::vector<ViconSection>& sections, const std::string& body,
                             const std::string& file, const ViconSection*& section) {
  for (const bool segments : {true, false}) {
    std::vector<std::string> names;
    int line = 0;  // the title of the first section with a pose
    for (const ViconSection& s : sections) {
      if ((s.title == "Segments") != segments || s.title == "Trajectories" ||
          s.title == "Devices") {
        continue;
      }
      for (const ViconGroup& g : s.groups) {
        if (!is_pose(g)) continue;
        names.push_back(g.name);
        if (line == 0) line = s.title_line;
      }
    }
    names = unique(names);
    std::string found = body.empty() && names.size() == 1 ? names[0] : std::string();
    if (body.empty() && names.size() > 1) {
      fail(
          file, line, 1,
          fmt::format("{} segments: {}: give --body NAME", names.size(), detail::name_list(names)));
    }
    if (!body.empty()) found = match_one(names, body, file, line, "segment");
    if (found.empty()) continue;
    for (const ViconSection& s : sections) {
      if ((s.title == "Segments") != segments) continue;
      for (const ViconGroup& g : s.groups) {
        if (g.name == found && is_pose(g)) {
          section = &s;
          return &g;
        }
      }
    }
  }
  return nullptr;
}

// The markers `wanted` (or the only one) of the Trajectories section.
ViconChoice vicon_markers(const std::vector<ViconSection>& sections,
                          const std::vector<std::string>& wanted, const std::string& body,
                          const std::string& file) {
  const auto it = std::find_if(sections.begin(), sections.end(),
                               [](const ViconSection& s) { return s.title == "Trajectories"; });
  std::vector<std::string> names;
  if (it != sections.end()) {
    for (const ViconGroup& g : it->groups) {
      if (is_marker(g)) names.push_back(g.name);
    }
  }
  const int line = it != sections.end() ? it->title_line : sections[0].title_line;
  if (wanted.empty() && names.size() != 1) {
    fail(file, line, 1,
         names.empty() ? std::string("no segment and no marker trajectory")
                       : fmt::format("no segment and {} markers: {}: give --marker NAME",
                                     names.size(), detail::name_list(names)));
  }
  ViconChoice choice;
  choice.section = it != sections.end() ? &*it : nullptr;
  for (const std::string& w : wanted.empty() ? names : wanted) {
    const std::string found = match_one(names, w, file, line, "marker", body);
    if (found.empty()) {
      throw InputError(
          file, line, fmt::format("marker '{}'", printable(w)),
          fmt::format("no such marker trajectory (the file has {}){}",
                      names.empty() ? "none" : detail::name_list(names), did_you_mean(w, names)));
    }
    for (const ViconGroup& g : it->groups) {
      if (g.name == found && is_marker(g)) {
        choice.groups.push_back(&g);
        break;
      }
    }
  }
  return choice;
}

// Column `label` of `g` and its scale to SI.
std::size_t vicon_column(const ViconSection& s, const ViconGroup& g, const char* label,
                         std::string_view kind, const std::string& option, std::string_view flag,
                         const std::string& file, double& scale) {
  const auto& [column, unit] = g.columns.at(label);
  const int line = s.units_line > 0 ? s.units_line : s.data_line - 1;
  scale = detail::resolve_unit(file, line, column + 1, kind, unit, option, flag);
  return column;
}

}  // namespace

TrackerStream read_vicon_csv(const std::string& text, const std::string& name,
                             const TrackerExportOptions& options) {
  CsvLines lines(text, name);
  const std::vector<ViconSection> sections = read_sections(lines);
  TrackerStream stream;
  SamplePlan plan;
  const ViconSection* section = nullptr;
  const ViconGroup* pose = nullptr;
  if (options.markers.empty()) pose = vicon_pose(sections, options.body, name, section);
  if (pose == nullptr && !options.body.empty() && options.markers.empty()) {
    std::vector<std::string> names;
    for (const ViconSection& s : sections) {
      for (const ViconGroup& g : s.groups) {
        if (is_pose(g)) names.push_back(g.name);
      }
    }
    throw InputError(name, sections[0].title_line,
                     fmt::format("segment '{}'", printable(options.body)),
                     fmt::format("no such segment (the file has {}){}",
                                 names.empty() ? "none" : detail::name_list(unique(names)),
                                 did_you_mean(options.body, names)));
  }
  if (pose != nullptr) {
    plan.reads_position = true;
    plan.rotation = Rotation::kRotationVector;
    for (std::size_t k = 0; k < 3; ++k) {
      const char* t[] = {"TX", "TY", "TZ"};
      const char* r[] = {"RX", "RY", "RZ"};
      plan.position[k] = vicon_column(*section, *pose, t[k], "length", options.length_unit,
                                      "--length-unit", name, plan.position_scale[k]);
      double scale = 0;
      plan.rotation_columns[k] = vicon_column(*section, *pose, r[k], "angle", "",
                                              "deg or rad in the units row", name, scale);
      if (k > 0 && scale != plan.angle_scale) {
        fail(name, section->units_line, plan.rotation_columns[k] + 1,
             "the rotation's columns are in different units");
      }
      plan.angle_scale = scale;
    }
    stream.source =
        fmt::format("Vicon CSV, {} '{}'", printable(section->title), printable(pose->name));
  } else {
    const ViconChoice choice = vicon_markers(sections, options.markers, options.body, name);
    section = choice.section;
    for (const ViconGroup* g : choice.groups) {
      plan.markers.emplace_back();
      plan.marker_scale.emplace_back();
      for (std::size_t k = 0; k < 3; ++k) {
        const char* xyz[] = {"X", "Y", "Z"};
        plan.markers.back()[k] = vicon_column(*section, *g, xyz[k], "length", options.length_unit,
                                              "--length-unit", name, plan.marker_scale.back()[k]);
      }
      stream.marker_names.push_back(g->name);
    }
    if (!options.markers.empty())
      detail::check_markers_once(options.markers, stream.marker_names, name);
    stream.source =
        fmt::format("Vicon CSV, Trajectories {}", detail::name_list(stream.marker_names));
  }
  // Times are frame / rate: seconds, whatever --time-unit says.
  detail::resolve_unit(name, section->rate_line, 1, "time", "s", options.time_unit, "--time-unit");
  plan.width = section->width;
  plan.time_column = 0;
  plan.frame_rate = section->rate_hz;
  plan.sub_frame_column = 1;
  lines.seek(section->data_offset, section->data_line);
  detail::read_samples(lines, plan, true, stream);
  if (stream.t.empty() && stream.lost == 0) {
    fail(name, section->data_line, 1,
         fmt::format("no data rows in section '{}'", printable(section->title)));
  }
  return stream;
}

}  // namespace hapticcal::recording
