// A generic CSV export read with a column map ("t=Time,x=PosX,...", --column-map):
// the columns found by their header names, their units from the header or the map.
#include <fmt/format.h>

#include <algorithm>
#include <charconv>
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

using detail::CsvLines;
using detail::fail;
using detail::SamplePlan;

namespace {

// A generic CSV's column map, "t=Time,x=PosX,...": each key's header name, and
// the unit a key may carry ("rx[deg]=RotX").
struct ColumnMap {
  std::map<std::string, std::string> header;  // key -> header name
  std::map<std::string, std::string> unit;    // key -> unit written with the key
  std::size_t markers = 0;
};

ColumnMap parse_column_map(const std::string& map, const std::string& name) {
  const auto bad = [&](const std::string& message) {
    return InputError(name, 0, "--column-map", message);
  };
  ColumnMap out;
  std::size_t from = 0;
  while (from <= map.size()) {
    std::size_t comma = map.find(',', from);
    if (comma == std::string::npos) comma = map.size();
    const std::string_view entry = detail::trim(std::string_view(map).substr(from, comma - from));
    from = comma + 1;
    const std::size_t eq = entry.find('=');
    if (eq == std::string_view::npos || detail::trim(entry.substr(eq + 1)).empty()) {
      throw bad(fmt::format("'{}' is not KEY=COLUMN", printable(std::string(entry))));
    }
    std::string key(detail::trim(entry.substr(0, eq)));
    std::string unit;
    if (const std::size_t open = key.find('['); open != std::string::npos && key.back() == ']') {
      unit = key.substr(open + 1, key.size() - open - 2);
      key = std::string(detail::trim(key.substr(0, open)));
    }
    static const std::string_view kFixed[] = {"t",  "x",  "y",  "z",  "qw", "qx",
                                              "qy", "qz", "rx", "ry", "rz"};
    bool known = std::find(std::begin(kFixed), std::end(kFixed), key) != std::end(kFixed);
    if (!known && key.size() > 1 && (key[0] == 'x' || key[0] == 'y' || key[0] == 'z')) {
      std::size_t k = 0;
      const auto [end, ec] = std::from_chars(key.data() + 1, key.data() + key.size(), k);
      known = ec == std::errc() && end == key.data() + key.size() && k >= 1 && k <= 1000 &&
              key[1] != '0';
      if (known) out.markers = std::max(out.markers, k);
    }
    if (!known) {
      throw bad(
          fmt::format("unknown key '{}' (t, x, y, z, qw, qx, qy, qz, rx, ry, rz, x1, y1, "
                      "z1, ...)",
                      printable(key)));
    }
    const std::string column(detail::trim(entry.substr(eq + 1)));
    if (out.header.count(key)) throw bad(fmt::format("key '{}' given twice", key));
    for (const auto& [other, named] : out.header) {
      if (named == column) {
        throw bad(fmt::format("column '{}' given for both {} and {}: each key its own column",
                              printable(column), other, key));
      }
    }
    out.header.emplace(key, column);
    if (!unit.empty()) out.unit[key] = unit;
  }
  const auto has = [&](const char* k) { return out.header.count(k) > 0; };
  const auto all_or_none = [&](std::initializer_list<const char*> keys, const char* what) {
    const auto n = std::count_if(keys.begin(), keys.end(), has);
    if (n != 0 && n != static_cast<long>(keys.size()))
      throw bad(fmt::format("{}: give all of them", what));
    return n != 0;
  };
  if (!has("t")) throw bad("no t=COLUMN: a stream needs its times");
  const bool position = all_or_none({"x", "y", "z"}, "x, y, z");
  const bool quaternion = all_or_none({"qw", "qx", "qy", "qz"}, "qw, qx, qy, qz");
  const bool vector = all_or_none({"rx", "ry", "rz"}, "rx, ry, rz");
  for (std::size_t k = 1; k <= out.markers; ++k) {
    for (const char axis : {'x', 'y', 'z'}) {
      if (!out.header.count(fmt::format("{}{}", axis, k))) {
        throw bad(
            fmt::format("marker {} has no {}{}=COLUMN (markers are numbered from 1)", k, axis, k));
      }
    }
  }
  if (quaternion && vector) throw bad("both a quaternion and a rotation vector: give one");
  if ((quaternion || vector) && !position) throw bad("an orientation needs x, y, z");
  if (position == (out.markers > 0)) {
    throw bad(position ? "both x, y, z and markers x1, y1, z1...: give one"
                       : "no positions: give x, y, z or markers x1, y1, z1, ...");
  }
  return out;
}

// A header field "PosX [mm]": its name and its unit (empty without brackets).
std::pair<std::string_view, std::string_view> name_and_unit(std::string_view field) {
  const std::size_t open = field.rfind('[');
  if (open == std::string_view::npos || field.back() != ']') return {field, {}};
  return {detail::trim(field.substr(0, open)),
          detail::trim(field.substr(open + 1, field.size() - open - 2))};
}

// The header column the map's `key` names (0-based); InputError if none or several.
std::size_t find_column(const CsvLines& lines, const ColumnMap& map, const std::string& key,
                        const std::vector<std::string>& header_names) {
  const std::string& wanted = map.header.at(key);
  std::ptrdiff_t found = -1;
  for (std::size_t c = 0; c < lines.fields().size(); ++c) {
    if (lines.field(c) != wanted && name_and_unit(lines.field(c)).first != wanted) continue;
    if (found >= 0) {
      fail(lines.name(), lines.number(), c + 1,
           fmt::format("'{}' ({}=) is both column {} and column {}", printable(wanted), key,
                       found + 1, c + 1));
    }
    found = static_cast<std::ptrdiff_t>(c);
  }
  if (found < 0) {
    throw InputError(lines.name(), lines.number(), fmt::format("column '{}'", printable(wanted)),
                     fmt::format("no such column in the header ({}= of --column-map){}", key,
                                 did_you_mean(wanted, header_names)));
  }
  return static_cast<std::size_t>(found);
}

}  // namespace

TrackerStream read_generic_csv(const std::string& text, const std::string& name,
                               const TrackerExportOptions& options) {
  if (!options.body.empty() || !options.markers.empty()) {
    throw InputError(name, 0, options.body.empty() ? "--marker" : "--body",
                     "a generic CSV's columns are chosen by --column-map alone");
  }
  const ColumnMap map = parse_column_map(options.column_map, name);
  CsvLines lines(text, name);
  while (lines.next() && (lines.blank() || lines.line().front() == '#')) {
  }
  if (lines.number() == 0 || lines.blank() || lines.line().front() == '#') {
    fail(name, lines.number() + 1, 1, "no header line: the file is empty");
  }
  std::vector<std::string> header_names;
  for (const std::string_view f : lines.fields()) header_names.emplace_back(name_and_unit(f).first);
  SamplePlan plan;
  plan.width = lines.fields().size();
  const auto column = [&](const std::string& key) {
    return find_column(lines, map, key, header_names);
  };
  const auto unit_of = [&](std::size_t c, const std::string& key, std::string_view kind,
                           const std::string& option, std::string_view flag) {
    std::string_view stated = name_and_unit(lines.field(c)).second;
    if (stated.empty() && map.unit.count(key)) stated = map.unit.at(key);
    return detail::resolve_unit(name, lines.number(), c + 1, kind, stated, option, flag);
  };
  plan.time_column = column("t");
  plan.time_scale = unit_of(plan.time_column, "t", "time", options.time_unit, "--time-unit");
  TrackerStream stream;
  stream.source = fmt::format("CSV with columns {}", printable(options.column_map, 200));
  const auto position = [&](const std::string& suffix, std::array<std::size_t, 3>& c,
                            std::array<double, 3>& scale) {
    for (std::size_t k = 0; k < 3; ++k) {
      const std::string key = std::string(1, "xyz"[k]) + suffix;
      c[k] = column(key);
      scale[k] = unit_of(c[k], key, "length", options.length_unit, "--length-unit");
    }
  };
  if (map.markers == 0) {
    plan.reads_position = true;
    position("", plan.position, plan.position_scale);
  }
  for (std::size_t m = 1; m <= map.markers; ++m) {
    plan.markers.emplace_back();
    plan.marker_scale.emplace_back();
    position(std::to_string(m), plan.markers.back(), plan.marker_scale.back());
    stream.marker_names.emplace_back(name_and_unit(lines.field(plan.markers.back()[0])).first);
  }
  if (map.header.count("qw")) {
    plan.rotation = detail::Rotation::kQuaternion;
    for (std::size_t k = 0; k < 4; ++k)
      plan.rotation_columns[k] = column(std::string("q") + "wxyz"[k]);
  } else if (map.header.count("rx")) {
    plan.rotation = detail::Rotation::kRotationVector;
    for (std::size_t k = 0; k < 3; ++k) {
      const std::string key = std::string("r") + "xyz"[k];
      plan.rotation_columns[k] = column(key);
      const double scale = unit_of(plan.rotation_columns[k], key, "angle", "",
                                   "a unit in the header or the map (rx[deg]=NAME)");
      if (k > 0 && scale != plan.angle_scale) {
        fail(name, lines.number(), plan.rotation_columns[k] + 1,
             "the rotation vector's columns are in different units");
      }
      plan.angle_scale = scale;
    }
  }
  detail::read_samples(lines, plan, false, stream);
  if (stream.t.empty() && stream.lost == 0) fail(name, lines.number() + 1, 1, "no data rows");
  return stream;
}

}  // namespace hapticcal::recording
