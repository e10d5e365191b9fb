// Internal to the tracker export readers (tracker_export.cpp, tracker_generic.cpp,
// tracker_formats.cpp, tracker_vicon.cpp): the lines and fields of a CSV export
// (bounded: a line at most 1 MiB, at most 4096 fields), units, rotations, the
// matching of names and the rows of samples every layout ends in.
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "hapticcal/recording/tracker_export.hpp"

namespace hapticcal::recording::detail {

inline constexpr std::size_t kMaxColumns = 4096;
inline constexpr std::size_t kMaxLineBytes = std::size_t{1} << 20;
// A frame rate a file states (Vicon's under each section's title) lies in
// (kMinRateHz, kMaxRateHz]: optical trackers run at tens of Hz to a few kHz; a
// rate outside is a damaged file (1e-300 Hz would put the second frame 1e300 s on).
inline constexpr double kMinRateHz = 0.1;
inline constexpr double kMaxRateHz = 1e5;

// Every problem: an InputError naming the file, the line and the column (1-based;
// the line too, 0 when the problem is not on one line).
[[noreturn]] void fail(const std::string& name, int line, std::size_t column,
                       const std::string& message);

// Where the line starting at `from` ends (before its "\n", "\r\n" or lone "\r":
// exports written on any system) and where the next one starts.
struct LineEnd {
  std::size_t eol, next;
};
LineEnd line_end(std::string_view text, std::size_t from);

// A text's lines one after another (ended by "\n", "\r\n" or a lone "\r"; a UTF-8
// byte order mark at the start skipped), each split at commas into trimmed fields.
// Exports quote nothing: a '"' is read as written.
class CsvLines {
 public:
  CsvLines(std::string_view text, const std::string& name);
  // Moves to the next line; false after the last. InputError for a line beyond
  // the bounds (before it is split).
  bool next();
  // Makes the line at `offset` (a line's start, from offset() or next_offset()) the
  // next one, numbered `number`.
  void seek(std::size_t offset, int number);

  int number() const { return number_; }
  std::size_t offset() const { return start_; }
  std::size_t next_offset() const { return pos_; }  // where the next line starts
  std::string_view line() const { return line_; }
  const std::vector<std::string_view>& fields() const { return fields_; }
  std::string_view field(std::size_t k) const { return k < fields_.size() ? fields_[k] : ""; }
  // Every field empty (an empty line, or one of commas only).
  bool blank() const;
  const std::string& name() const { return name_; }

 private:
  std::string_view text_;
  const std::string& name_;
  std::size_t pos_ = 0, start_ = 0;
  int number_ = 0;
  std::string_view line_;
  std::vector<std::string_view> fields_;
};

std::string_view trim(std::string_view s);
// A finite decimal number (a leading '+' allowed), the whole field.
bool parse_number(std::string_view f, double& v);
// `f` as a number: InputError naming the column when it is not one.
double number_at(const CsvLines& lines, std::size_t k, const std::string& what);
// "'a', 'b', 'c'": names quoted through printable(), at most 20, then how many more.
std::string name_list(const std::vector<std::string>& names);

// The markers `found` for the names `wanted` (one each, in order) are distinct:
// InputError naming --markers if one is named twice, or two names are one marker.
void check_markers_once(const std::vector<std::string>& wanted,
                        const std::vector<std::string>& found, const std::string& name);

// The scale to metres of a length unit as files and options write it ("m", "mm",
// "cm", "um", Motive's "Meters", "Centimeters", "Millimeters"); 0 if unknown.
double length_scale(std::string_view unit);
// The scale to seconds of "s" or "ms" (also "Seconds", "Milliseconds"); 0 if unknown.
double time_scale(std::string_view unit);
// The scale to radians of "rad" or "deg"; 0 if unknown.
double angle_scale(std::string_view unit);

// The scale of a column from the unit the file states (`file_unit`, may be empty)
// and the one given (`option`, may be empty, with its option's name `flag`): the
// file's wins, a given one that disagrees is an error, none anywhere is an error.
// `kind` is "length", "time" or "angle".
double resolve_unit(const std::string& name, int line, std::size_t column, std::string_view kind,
                    std::string_view file_unit, const std::string& option, std::string_view flag);

// How a pose's orientation is written.
enum class Rotation { kNone, kQuaternion, kRotationVector, kEuler };

// What to take from each data row: the columns (0-based field indices) and their
// scales to SI. Time is either a column or frame / rate.
struct SamplePlan {
  std::size_t width = 0;  // fields a data row has (the header's)
  std::size_t time_column = 0;
  double time_scale = 1;                 // a time column's unit to seconds
  double frame_rate = 0;                 // > 0: the time column is a frame number, t = frame / rate
  std::ptrdiff_t sub_frame_column = -1;  // Vicon's sub frame: must be 0
  std::array<std::size_t, 3> position{};  // x, y, z
  std::array<double, 3> position_scale{1, 1, 1};
  bool reads_position = false;  // x, y, z (position) are read
  Rotation rotation = Rotation::kNone;
  std::array<std::size_t, 4> rotation_columns{};    // quaternion w, x, y, z; else about x, y, z
  double angle_scale = 1;                           // rotation vector / Euler angles to radians
  std::string euler_order;                          // "XYZ": R = Rx * Ry * Rz (intrinsic)
  std::vector<std::array<std::size_t, 3>> markers;  // each x, y, z
  std::vector<std::array<double, 3>> marker_scale;
};

// A line with a word in its first field and nothing else: a Vicon section's title.
bool is_title(const CsvLines& lines);

// Reads data rows from the line after the current one of `lines` to the end (or,
// with `stop_at_blank`, to the first blank line or section title) into `stream`. A row with a
// needed field empty is lost (counted); a row of the wrong width, a field that is no number, a time
// not after the last one or a quaternion far from unit norm is an error.
void read_samples(CsvLines& lines, const SamplePlan& plan, bool stop_at_blank,
                  TrackerStream& stream);

// Unit quaternion (w, x, y, z) of a rotation vector (radians) and of Euler
// angles (radians about x, y, z) applied in `order` as intrinsic rotations.
std::array<double, 4> rotation_vector_quaternion(double rx, double ry, double rz);
std::array<double, 4> euler_quaternion(const std::string& order, double ax, double ay, double az);

// True if `full` names `wanted`: equal, or "Subject:wanted" (a Vicon subject's or
// a Motive rigid body's prefix).
bool names_match(std::string_view full, std::string_view wanted);

// The names of a list, each once, in order.
std::vector<std::string> unique(const std::vector<std::string>& names);
// The one of `names` that `wanted` names: itself, "PREFIX:wanted" with `prefix`
// (the body given with markers), or the only "ANY:wanted" (names_match); "" if
// none; InputError naming `line` if several.
std::string match_one(const std::vector<std::string>& names, const std::string& wanted,
                      const std::string& file, int line, const char* what,
                      const std::string& prefix = "");
// A row's fields as strings, and its field k ("" past its end).
std::vector<std::string> copy(const std::vector<std::string_view>& fields);
std::string at(const std::vector<std::string>& row, std::size_t k);

}  // namespace hapticcal::recording::detail
