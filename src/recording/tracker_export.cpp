// Trackers' CSV exports, the parts every layout shares: lines and fields
// (bounded), units, rotations, the rows of samples; and which layout a file is.
// The generic CSV read with a column map is tracker_generic.cpp's; the layouts of
// Motive and Vicon exports are tracker_formats.cpp's and tracker_vicon.cpp's.
//
// A row of samples (all layouts): an empty field is a sample the tracker lost (an
// occluded marker, OptiTrack: "When there is an occlusion in a marker, the CSV
// file will contain blank cells", https://docs.optitrack.com/motive/data-export/
// data-export-csv); a sample with any of its fields empty is left out and counted.
#include "hapticcal/recording/tracker_export.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <map>
#include <utility>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "recording/tracker_csv.hpp"

namespace hapticcal::recording {
namespace detail {

void fail(const std::string& name, int line, std::size_t column, const std::string& message) {
  throw InputError(name, line, column > 0 ? fmt::format("column {}", column) : std::string(),
                   message);
}

CsvLines::CsvLines(std::string_view text, const std::string& name) : text_(text), name_(name) {
  if (text_.substr(0, 3) == "\xEF\xBB\xBF") pos_ = 3;  // a UTF-8 byte order mark
}

LineEnd line_end(std::string_view text, std::size_t from) {
  const std::size_t eol = std::min(text.find_first_of("\r\n", from), text.size());
  const std::size_t next = eol + (text.compare(eol, 2, "\r\n") == 0 ? 2
                                  : eol < text.size()               ? 1
                                                                    : 0);
  return {eol, next};
}

bool CsvLines::next() {
  if (pos_ >= text_.size()) return false;
  start_ = pos_;
  const auto [eol, after] = line_end(text_, pos_);
  ++number_;
  if (eol - pos_ > kMaxLineBytes) {
    fail(name_, number_, 1,
         fmt::format("a line of {} bytes: at most {} (1 MiB)", eol - pos_, kMaxLineBytes));
  }
  line_ = text_.substr(pos_, eol - pos_);
  pos_ = after;
  // Counted before they are split: a line of commas costs no memory.
  const auto count = static_cast<std::size_t>(std::count(line_.begin(), line_.end(), ',')) + 1;
  if (count > kMaxColumns) {
    fail(name_, number_, kMaxColumns + 1,
         fmt::format("{} fields: an export has at most {} columns", count, kMaxColumns));
  }
  fields_.clear();
  std::size_t from = 0;
  for (;;) {
    const std::size_t comma = line_.find(',', from);
    fields_.push_back(
        trim(line_.substr(from, comma == std::string_view::npos ? comma : comma - from)));
    if (comma == std::string_view::npos) break;
    from = comma + 1;
  }
  return true;
}

void CsvLines::seek(std::size_t offset, int number) {
  pos_ = offset;
  number_ = number - 1;
}

bool CsvLines::blank() const {
  return std::all_of(fields_.begin(), fields_.end(), [](std::string_view f) { return f.empty(); });
}

std::string_view trim(std::string_view s) {
  const auto blank = [](char c) { return c == ' ' || c == '\t' || c == '\r'; };
  while (!s.empty() && blank(s.front())) s.remove_prefix(1);
  while (!s.empty() && blank(s.back())) s.remove_suffix(1);
  return s;
}

bool parse_number(std::string_view f, double& v) {
  if (!f.empty() && f.front() == '+') f.remove_prefix(1);
  if (f.empty() || f.front() == '+') return false;
  const auto [end, ec] = std::from_chars(f.data(), f.data() + f.size(), v);
  return ec == std::errc() && end == f.data() + f.size() && std::isfinite(v);
}

double number_at(const CsvLines& lines, std::size_t k, const std::string& what) {
  double v = 0;
  if (!parse_number(lines.field(k), v)) {
    fail(lines.name(), lines.number(), k + 1,
         fmt::format("{} '{}' is not a number", what, printable(std::string(lines.field(k)))));
  }
  return v;
}

std::string name_list(const std::vector<std::string>& names) {
  std::string out;
  const std::size_t shown = std::min<std::size_t>(names.size(), 20);
  for (std::size_t k = 0; k < shown; ++k) {
    out += fmt::format("{}'{}'", k > 0 ? ", " : "", printable(names[k]));
  }
  if (names.size() > shown) out += fmt::format(" and {} more", names.size() - shown);
  return out;
}

void check_markers_once(const std::vector<std::string>& wanted,
                        const std::vector<std::string>& found, const std::string& name) {
  for (std::size_t i = 0; i < found.size(); ++i) {
    for (std::size_t k = 0; k < i; ++k) {
      if (found[k] != found[i]) continue;
      throw InputError(
          name, 0, "--markers",
          wanted[k] == wanted[i]
              ? fmt::format("'{}' is named twice: each marker once", printable(wanted[i]))
              : fmt::format("'{}' and '{}' are one marker, '{}': each marker once",
                            printable(wanted[k]), printable(wanted[i]), printable(found[i])));
    }
  }
}

namespace {

bool same_text(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) ==
                  std::tolower(static_cast<unsigned char>(y));
         });
}

double scale_of(std::string_view unit, const std::map<std::string_view, double>& known) {
  for (const auto& [name, scale] : known) {
    if (same_text(unit, name)) return scale;
  }
  return 0;
}

}  // namespace

double length_scale(std::string_view unit) {
  static const std::map<std::string_view, double> known{{"m", 1},
                                                        {"mm", 1e-3},
                                                        {"cm", 1e-2},
                                                        {"um", 1e-6},
                                                        {"meters", 1},
                                                        {"millimeters", 1e-3},
                                                        {"centimeters", 1e-2},
                                                        {"metres", 1},
                                                        {"millimetres", 1e-3},
                                                        {"centimetres", 1e-2}};
  return scale_of(unit, known);
}

double time_scale(std::string_view unit) {
  static const std::map<std::string_view, double> known{
      {"s", 1}, {"ms", 1e-3}, {"seconds", 1}, {"milliseconds", 1e-3}};
  return scale_of(unit, known);
}

double angle_scale(std::string_view unit) {
  static const std::map<std::string_view, double> known{
      {"rad", 1}, {"deg", M_PI / 180}, {"radians", 1}, {"degrees", M_PI / 180}};
  return scale_of(unit, known);
}

double resolve_unit(const std::string& name, int line, std::size_t column, std::string_view kind,
                    std::string_view file_unit, const std::string& option, std::string_view flag) {
  const auto scale = [&](std::string_view unit) {
    return kind == "length" ? length_scale(unit)
           : kind == "time" ? time_scale(unit)
                            : angle_scale(unit);
  };
  const char* known = kind == "length" ? "m, mm, cm, um" : kind == "time" ? "s, ms" : "rad, deg";
  double given = 0;
  if (!option.empty()) {
    given = scale(option);
    if (given == 0) {
      throw InputError(name, 0, std::string(flag),
                       fmt::format("unknown {} unit '{}' ({})", kind, printable(option), known));
    }
  }
  if (file_unit.empty()) {
    if (given == 0) {
      fail(name, line, column,
           fmt::format("the file states no {} unit: give {} ({})", kind, flag, known));
    }
    return given;
  }
  const double stated = scale(file_unit);
  if (stated == 0) {
    fail(name, line, column,
         fmt::format("unknown {} unit '{}' ({})", kind, printable(std::string(file_unit)), known));
  }
  if (given != 0 && given != stated) {
    fail(name, line, column,
         fmt::format("the file's {} unit is '{}', {} {} disagrees", kind,
                     printable(std::string(file_unit)), flag, printable(option)));
  }
  return stated;
}

std::array<double, 4> rotation_vector_quaternion(double rx, double ry, double rz) {
  const double angle = std::sqrt(rx * rx + ry * ry + rz * rz);
  // sin(angle / 2) / angle, by its series near 0 (no division by a tiny angle).
  const double k = angle < 1e-6 ? 0.5 - angle * angle / 48 : std::sin(angle / 2) / angle;
  return {std::cos(angle / 2), k * rx, k * ry, k * rz};
}

namespace {

std::array<double, 4> multiply(const std::array<double, 4>& a, const std::array<double, 4>& b) {
  return {a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
          a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
          a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
          a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0]};
}

}  // namespace

std::array<double, 4> euler_quaternion(const std::string& order, double ax, double ay, double az) {
  // Intrinsic: the first axis's rotation, then about the new second axis, then
  // the new third: R = R_first * R_second * R_third.
  std::array<double, 4> q{1, 0, 0, 0};
  for (const char axis : order) {
    const int k = axis == 'X' ? 1 : axis == 'Y' ? 2 : 3;
    const double angle = k == 1 ? ax : k == 2 ? ay : az;
    std::array<double, 4> step{std::cos(angle / 2), 0, 0, 0};
    step[static_cast<std::size_t>(k)] = std::sin(angle / 2);
    q = multiply(q, step);
  }
  return q;
}

bool names_match(std::string_view full, std::string_view wanted) {
  if (full == wanted) return true;
  return full.size() > wanted.size() + 1 && full.substr(full.size() - wanted.size()) == wanted &&
         full[full.size() - wanted.size() - 1] == ':';
}

namespace {

// The row's time in seconds.
double row_time(const CsvLines& lines, const SamplePlan& plan) {
  const std::size_t c = plan.time_column;
  if (lines.field(c).empty()) {
    fail(lines.name(), lines.number(), c + 1, plan.frame_rate > 0 ? "no frame number" : "no time");
  }
  if (plan.sub_frame_column >= 0) {
    const auto s = static_cast<std::size_t>(plan.sub_frame_column);
    if (number_at(lines, s, "sub frame") != 0) {
      fail(lines.name(), lines.number(), s + 1,
           fmt::format("sub frame {}: rows between frames (sampled faster than the section's "
                       "frame rate) are not read",
                       printable(std::string(lines.field(s)))));
    }
  }
  if (plan.frame_rate > 0) {
    const double frame = number_at(lines, c, "frame");
    if (frame != std::floor(frame) || frame < 0 || frame > 9e15) {
      fail(lines.name(), lines.number(), c + 1,
           fmt::format("frame {} is not a whole number", printable(std::string(lines.field(c)))));
    }
    return frame / plan.frame_rate;
  }
  return number_at(lines, c, "time") * plan.time_scale;
}

// The value of column `c` scaled, or false for an empty field.
bool value(const CsvLines& lines, std::size_t c, double scale, double& v) {
  if (lines.field(c).empty()) return false;
  v = number_at(lines, c, "value") * scale;
  return true;
}

// The row's orientation as a unit quaternion; false if a field is empty.
bool row_rotation(const CsvLines& lines, const SamplePlan& plan, std::array<double, 4>& q) {
  const auto& c = plan.rotation_columns;
  if (plan.rotation == Rotation::kQuaternion) {
    bool all = true;
    for (std::size_t k = 0; k < 4; ++k) all = value(lines, c[k], 1, q[k]) && all;
    if (!all) return false;
    const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (std::abs(norm - 1) > 1e-3) {
      fail(lines.name(), lines.number(), *std::min_element(c.begin(), c.end()) + 1,
           fmt::format("a quaternion of norm {:.6g}: not a rotation (further than 1e-3 from 1)",
                       norm));
    }
    for (double& v : q) v /= norm;
    return true;
  }
  std::array<double, 3> a{};
  bool all = true;
  for (std::size_t k = 0; k < 3; ++k) all = value(lines, c[k], plan.angle_scale, a[k]) && all;
  if (!all) return false;
  q = plan.rotation == Rotation::kRotationVector
          ? rotation_vector_quaternion(a[0], a[1], a[2])
          : euler_quaternion(plan.euler_order, a[0], a[1], a[2]);
  return true;
}

// The row's sample into `stream`; false if one of its fields is empty.
bool add_row(const CsvLines& lines, const SamplePlan& plan, double t, TrackerStream& stream) {
  bool all = true;
  std::array<double, 3> p{};
  if (plan.reads_position) {
    for (std::size_t k = 0; k < 3; ++k) {
      all = value(lines, plan.position[k], plan.position_scale[k], p[k]) && all;
    }
  }
  std::array<double, 4> q{};
  if (plan.rotation != Rotation::kNone) all = row_rotation(lines, plan, q) && all;
  std::vector<std::array<double, 3>> markers(plan.markers.size());
  for (std::size_t m = 0; m < plan.markers.size(); ++m) {
    for (std::size_t k = 0; k < 3; ++k) {
      all = value(lines, plan.markers[m][k], plan.marker_scale[m][k], markers[m][k]) && all;
    }
  }
  if (!all) return false;
  stream.t.push_back(t);
  if (plan.reads_position) stream.p.push_back(p);
  if (plan.rotation != Rotation::kNone) stream.q.push_back(q);
  if (!plan.markers.empty()) stream.markers.push_back(std::move(markers));
  return true;
}

// The first of the row's columns read that is empty (a lost sample's), 0-based.
std::size_t first_empty(const CsvLines& lines, const SamplePlan& plan) {
  std::vector<std::size_t> read;
  if (plan.reads_position) read.insert(read.end(), plan.position.begin(), plan.position.end());
  if (plan.rotation != Rotation::kNone) {
    read.insert(read.end(), plan.rotation_columns.begin(),
                plan.rotation_columns.begin() + (plan.rotation == Rotation::kQuaternion ? 4 : 3));
  }
  for (const auto& m : plan.markers) read.insert(read.end(), m.begin(), m.end());
  std::sort(read.begin(), read.end());
  const auto it =
      std::find_if(read.begin(), read.end(), [&](std::size_t c) { return lines.field(c).empty(); });
  return it == read.end() ? 0 : *it;
}

}  // namespace

bool is_title(const CsvLines& lines) {
  double v = 0;
  return !lines.field(0).empty() && !parse_number(lines.field(0), v) &&
         std::all_of(lines.fields().begin() + 1, lines.fields().end(),
                     [](std::string_view f) { return f.empty(); });
}

void read_samples(CsvLines& lines, const SamplePlan& plan, bool stop_at_blank,
                  TrackerStream& stream) {
  const int header_line = lines.number();
  double last_t = -std::numeric_limits<double>::infinity();
  int last_line = 0;
  std::size_t lost_column = 0;  // the first lost sample's empty column
  int lost_line = 0;
  const std::size_t kept = stream.t.size(), lost = stream.lost;
  // Every sample lost: nothing to import, and the rows say why.
  const auto check_kept = [&] {
    if (stream.t.size() > kept || stream.lost == lost) return;
    fail(lines.name(), lost_line, lost_column + 1,
         fmt::format("all {} samples lost: every row has an empty field among the columns read "
                     "(a tracker leaves an occluded sample's cells blank), this row first: the "
                     "tracker never saw what was chosen (the right --body, --markers or "
                     "--column-map?); nothing to import",
                     stream.lost - lost));
  };
  while (lines.next()) {
    if (lines.blank()) {
      if (stop_at_blank) return check_kept();
      continue;
    }
    if (stop_at_blank && is_title(lines)) return check_kept();
    const std::size_t n = lines.fields().size();
    if (n != plan.width) {
      fail(lines.name(), lines.number(), std::min(n, plan.width) + 1,
           fmt::format("{} fields, the header (line {}) has {}{}", n, header_line, plan.width,
                       n < plan.width ? ": a row cut short" : ""));
    }
    const double t = row_time(lines, plan);
    if (!(t > last_t)) {
      fail(lines.name(), lines.number(), plan.time_column + 1,
           fmt::format("time {:.9g} s is not after the previous sample's {:.9g} s (line {})", t,
                       last_t, last_line));
    }
    last_t = t;
    last_line = lines.number();
    if (add_row(lines, plan, t, stream)) continue;
    if (stream.lost++ == lost) lost_line = lines.number(), lost_column = first_empty(lines, plan);
  }
  check_kept();
}

}  // namespace detail

std::string tracker_export_format(const std::string& text) {
  // The first line that is not blank, read without splitting it (no bound to keep).
  std::string_view rest(text);
  if (rest.substr(0, 3) == "\xEF\xBB\xBF") rest.remove_prefix(3);
  while (!rest.empty()) {
    const auto [eol, next] = detail::line_end(rest, 0);
    const std::string_view line = rest.substr(0, eol);
    rest.remove_prefix(next);
    const std::size_t comma = std::min(line.find(','), line.size());
    const std::string_view first = detail::trim(line.substr(0, comma));
    const bool alone = line.find_first_not_of(", \t\r", comma) == std::string_view::npos;
    if (first.empty() && alone) continue;
    if (first == "Format Version") return "Motive";
    static const std::string_view kSections[] = {"Trajectories", "Segments", "Model Outputs",
                                                 "Joints", "Devices"};
    if (alone &&
        std::find(std::begin(kSections), std::end(kSections), first) != std::end(kSections)) {
      return "Vicon";
    }
    return "CSV";
  }
  return "CSV";
}

TrackerStream read_tracker_export(const std::string& path, const TrackerExportOptions& options) {
  const std::string text = read_file(path, FileKind::kLog);
  const std::string format = tracker_export_format(text);
  if (format != "CSV" && !options.column_map.empty()) {
    throw InputError(path, 0, "--column-map",
                     fmt::format("a column map is for a generic CSV; this file is a {} export "
                                 "(read by its own header)",
                                 format));
  }
  if (format == "Motive") return read_motive_csv(text, path, options);
  if (format == "Vicon") return read_vicon_csv(text, path, options);
  if (options.column_map.empty()) {
    throw InputError(path, 1, "",
                     "neither a Motive export (\"Format Version,...\") nor a Vicon one (a "
                     "\"Trajectories\" or \"Segments\" section): give --column-map "
                     "t=NAME,x=NAME,y=NAME,z=NAME");
  }
  return read_generic_csv(text, path, options);
}

}  // namespace hapticcal::recording
