// The fields of a log's lines and the grammar of its column names
// (docs/file-formats.md): each name read with its unit, and the set of columns checked as a whole.
#include "data_io/log_columns.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <numbers>
#include <string_view>

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/measurement.hpp"

namespace hapticcal::detail {
namespace {

constexpr int kQuantities = static_cast<int>(Quantity::kKindValue) + 1;
// Markers on one rigid body at most (a marker body carries 3 to 8).
constexpr int kMaxMarkers = 32;

constexpr std::string_view kQuaternionLetters = "wxyz", kRotationVectorLetters = "xyz";

// The index of `base` among prefix + letters[0], prefix + letters[1], ..., or -1.
int component_index(const std::string& base, char prefix, std::string_view letters) {
  if (base.size() != 2 || base[0] != prefix) return -1;
  const size_t k = letters.find(base[1]);
  return k == std::string_view::npos ? -1 : static_cast<int>(k);
}

constexpr const char* kExpectedColumns =
    "unknown column (expected q<i>, ext<i>, dir<i>, distance, x, y, z, x<k>, y<k>, z<k>, qw, qx, "
    "qy, qz, rx, ry, rz, t, point, plane or _)";

bool ascii_letter(char c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z'); }
bool ascii_digit(char c) { return c >= '0' && c <= '9'; }

// A column name: BASE INDEX [UNIT], i.e. [A-Za-z_]+[0-9]*(\[[A-Za-z]+\])?.
// Scanned by hand: std::regex recurses per character and overflows the stack
// on a long field.
bool split_spec(const std::string& spec, std::string& base, std::string& index, std::string& unit) {
  size_t i = 0;
  const size_t n = spec.size();
  while (i < n && (ascii_letter(spec[i]) || spec[i] == '_')) ++i;
  if (i == 0) return false;
  const size_t index_begin = i;
  while (i < n && ascii_digit(spec[i])) ++i;
  base = spec.substr(0, index_begin);
  index = spec.substr(index_begin, i - index_begin);
  unit.clear();
  if (i == n) return true;
  if (spec[i] != '[' || spec[n - 1] != ']') return false;
  const size_t unit_begin = i + 1, unit_end = n - 1;
  if (unit_begin >= unit_end) return false;
  for (size_t k = unit_begin; k < unit_end; ++k) {
    if (!ascii_letter(spec[k])) return false;
  }
  unit = spec.substr(unit_begin, unit_end - unit_begin);
  return true;
}

// An orientation is one complete set, qw, qx, qy, qz or rx, ry, rz, beside the position x, y, z.
// count: the columns of each quantity.
void check_orientation_columns(const std::vector<Column>& columns, const std::vector<int>& count,
                               const std::string& origin, int line) {
  auto counted = [&](Quantity first, int n) {
    int sum = 0;
    for (int k = 0; k < n; ++k) sum += count[static_cast<int>(first) + k];
    return sum;
  };
  const int quaternion = counted(Quantity::kQw, 4), rotation_vector = counted(Quantity::kRx, 3);
  if (quaternion == 0 && rotation_vector == 0) return;
  if (quaternion != 0 && rotation_vector != 0) {
    // Named: the first column of whichever set starts later.
    const Column* first_q = nullptr;
    const Column* first_r = nullptr;
    for (const Column& c : columns) {
      if (!first_q && is_quaternion(c.quantity)) first_q = &c;
      if (!first_r && is_rotation_vector(c.quantity)) first_r = &c;
    }
    throw InputError(origin, line, (first_q < first_r ? first_r : first_q)->name,
                     "an orientation is either qw, qx, qy, qz or rx, ry, rz, not both");
  }
  const bool is_q = quaternion != 0;
  const Quantity first = is_q ? Quantity::kQw : Quantity::kRx;
  const std::string_view letters = is_q ? kQuaternionLetters : kRotationVectorLetters;
  for (size_t k = 0; k < letters.size(); ++k) {
    if (count[static_cast<int>(first) + k] == 0) {
      throw InputError(origin, line, std::string{is_q ? 'q' : 'r', letters[k]},
                       is_q ? "missing: quaternions need all of qw, qx, qy, qz"
                            : "missing: rotation vectors need all of rx, ry, rz");
    }
  }
  if (count[static_cast<int>(Quantity::kX)] == 0) {
    throw InputError(origin, line, "x",
                     "missing: an orientation needs the position x, y, z (a pose is both)");
  }
}

}  // namespace

std::string trim(const std::string& s) {
  const size_t b = s.find_first_not_of(" \t\r");
  if (b == std::string::npos) return {};
  const size_t e = s.find_last_not_of(" \t\r");
  return s.substr(b, e - b + 1);
}

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> fields;
  size_t start = 0;
  while (true) {
    const size_t comma = line.find(',', start);
    fields.push_back(trim(line.substr(start, comma - start)));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return fields;
}

// A column with its unit's scale to SI and its ReadingUnit: what the unit
// means for its quantity, or an InputError.
Column with_unit(Column c, const std::string& unit, const std::string& origin, int line) {
  const bool angle = c.quantity == Quantity::kJoint || c.quantity == Quantity::kExternal ||
                     is_rotation_vector(c.quantity);
  const bool time = c.quantity == Quantity::kTime;
  if (unit.empty()) return c;
  if (is_quaternion(c.quantity)) {
    throw InputError(origin, line, c.name,
                     fmt::format("unit '{}': a quaternion component has no unit", printable(unit)));
  }
  const bool reading = c.quantity == Quantity::kJoint || c.quantity == Quantity::kExternal;
  if (angle && unit == "rad") {
    c.unit = ReadingUnit::kAngle;
    return c;
  }
  if (angle && unit == "deg") {
    c.scale = std::numbers::pi / 180;
    c.unit = ReadingUnit::kAngle;
    return c;
  }
  // A prismatic joint's readings are lengths (check_log_fits matches them to the joints).
  if (reading && (unit == "m" || unit == "mm" || unit == "um")) {
    c.scale = unit == "m" ? 1 : unit == "mm" ? 1e-3 : 1e-6;
    c.unit = ReadingUnit::kLength;
    return c;
  }
  if (time && unit == "s") return c;
  if (time && unit == "ms") {
    c.scale = 1e-3;
    return c;
  }
  if (!angle && !time) {
    if (unit == "m") return c;
    if (unit == "mm") {
      c.scale = 1e-3;
      return c;
    }
    if (unit == "um") {
      c.scale = 1e-6;
      return c;
    }
  }
  throw InputError(
      origin, line, c.name,
      fmt::format("unit '{}' does not fit (angles, rx..rz: rad, deg; lengths, readings of "
                  "prismatic joints: m, mm, um; time: s, ms)",
                  printable(unit)));
}

Column parse_column(const std::string& spec, const std::string& origin, int line) {
  std::string base, index, unit;
  if (!split_spec(spec, base, index, unit)) {
    std::string why = "not a column name";
    if (const std::string problem = text_problem(spec); !problem.empty()) why += ": " + problem;
    throw InputError(origin, line, spec.empty() ? "(empty)" : printable(spec), why);
  }
  Column c;
  c.name = printable(spec);                  // messages quote it
  if (base == "point" || base == "plane") {  // a label; point<k>: a tree's tip k's
    c.quantity = base == "point" ? Quantity::kPoint : Quantity::kPlane;
    if (!unit.empty()) {
      throw InputError(origin, line, c.name,
                       fmt::format("unit '{}': a {} column holds labels", printable(unit), base));
    }
    if (index.size() > 3) throw InputError(origin, line, c.name, "tip number too large");
    c.joint = index.empty() ? 0 : std::stoi(index);
    if (!index.empty() && c.joint < 1)
      throw InputError(origin, line, c.name, "tip numbers start at 1");
    return c;
  }
  const bool marker = (base == "x" || base == "y" || base == "z") && !index.empty();
  const bool indexed = base == "q" || base == "ext" || base == "dir" || marker;
  if (base == "_" && index.empty() && unit.empty()) return c;
  const std::optional<std::pair<MeasurementType, int>> kind =
      index.empty() ? measurement_column(base) : std::nullopt;
  if (!kind && indexed != !index.empty()) {
    throw InputError(origin, line, c.name, kExpectedColumns);
  }
  if (kind) {  // a registered kind's value: a length
    c.quantity = Quantity::kKindValue;
    c.joint = static_cast<int>(kind->first);
    c.value = kind->second;
  } else if (indexed) {
    const char* what = marker ? "marker" : "joint";
    if (index.size() > 3)
      throw InputError(origin, line, c.name, fmt::format("{} number too large", what));
    const int i = std::stoi(index);
    if (i < 1) throw InputError(origin, line, c.name, fmt::format("{} numbers start at 1", what));
    c.joint = i - 1;
    if (marker) {
      if (i > kMaxMarkers) {
        throw InputError(origin, line, c.name,
                         fmt::format("more than {} markers on one body", kMaxMarkers));
      }
      c.quantity = base == "x"   ? Quantity::kMarkerX
                   : base == "y" ? Quantity::kMarkerY
                                 : Quantity::kMarkerZ;
    } else {
      c.quantity = base == "q"     ? Quantity::kJoint
                   : base == "ext" ? Quantity::kExternal
                                   : Quantity::kDirection;
    }
    if (c.quantity == Quantity::kDirection && !unit.empty()) {
      throw InputError(
          origin, line, c.name,
          fmt::format("unit '{}': a direction column holds -1, 0 or +1", printable(unit)));
    }
  } else if (base == "distance") {
    c.quantity = Quantity::kDistance;
  } else if (base == "x") {
    c.quantity = Quantity::kX;
  } else if (base == "y") {
    c.quantity = Quantity::kY;
  } else if (base == "z") {
    c.quantity = Quantity::kZ;
  } else if (base == "t") {
    c.quantity = Quantity::kTime;
  } else if (const int k = component_index(base, 'q', kQuaternionLetters); k >= 0) {
    c.quantity = static_cast<Quantity>(static_cast<int>(Quantity::kQw) + k);
  } else if (const int k = component_index(base, 'r', kRotationVectorLetters); k >= 0) {
    c.quantity = static_cast<Quantity>(static_cast<int>(Quantity::kRx) + k);
  } else {
    throw InputError(origin, line, c.name, kExpectedColumns);
  }
  return with_unit(c, unit, origin, line);
}

// `f` as a number (a leading '+' allowed); false if it is not one.
bool parse_number(const std::string& f, double& v) {
  const char* begin = f.data();
  const char* end = f.data() + f.size();
  if (begin != end && *begin == '+') ++begin;
  const auto [ptr, ec] = std::from_chars(begin, end, v);
  return ec == std::errc() && ptr == end && !f.empty();
}

bool is_number(const std::string& f) {
  double v = 0;
  return parse_number(f, v);
}

// A line that is a header: no field is a number, each is written like a
// column name, and at least one is a column parse_column accepts.
bool looks_like_header(const std::vector<std::string>& fields) {
  bool known = false;
  for (const std::string& f : fields) {
    std::string base, index, unit;
    if (is_number(f) || !split_spec(f, base, index, unit)) return false;
    try {
      parse_column(f, "", 0);
      known = true;
    } catch (const InputError&) {
    }
  }
  return known;
}

// Markers x<k>, y<k>, z<k>: each with all three, numbered 1..K without gaps, not
// beside a single x, y, z, and not in a fixture log.
void check_marker_columns(const std::vector<Column>& columns, const std::vector<int>& count,
                          const std::string& origin, int line) {
  const int xs = count[static_cast<int>(Quantity::kMarkerX)];
  if (xs + count[static_cast<int>(Quantity::kMarkerY)] +
          count[static_cast<int>(Quantity::kMarkerZ)] ==
      0)
    return;
  int markers = 0;
  for (const Column& c : columns) {
    if (c.quantity == Quantity::kMarkerX || c.quantity == Quantity::kMarkerY ||
        c.quantity == Quantity::kMarkerZ)
      markers = std::max(markers, c.joint + 1);
  }
  for (int k = 0; k < markers; ++k) {
    const std::pair<Quantity, char> kinds[] = {
        {Quantity::kMarkerX, 'x'}, {Quantity::kMarkerY, 'y'}, {Quantity::kMarkerZ, 'z'}};
    for (const std::pair<Quantity, char>& kind : kinds) {
      const bool found = std::any_of(columns.begin(), columns.end(), [&](const Column& c) {
        return c.quantity == kind.first && c.joint == k;
      });
      if (!found) {
        throw InputError(origin, line, fmt::format("{}{}", kind.second, k + 1),
                         fmt::format("missing: markers need x, y, z each, numbered 1..{} without "
                                     "gaps",
                                     markers));
      }
    }
  }
  const int single = count[static_cast<int>(Quantity::kX)] + count[static_cast<int>(Quantity::kY)] +
                     count[static_cast<int>(Quantity::kZ)];
  if (single != 0) {
    throw InputError(origin, line, "x",
                     "a log holds one point (x, y, z) or numbered markers (x1, y1, z1, ...), not "
                     "both");
  }
  for (const Quantity q :
       {Quantity::kPoint, Quantity::kPlane, Quantity::kDistance, Quantity::kQw, Quantity::kRx}) {
    if (count[static_cast<int>(q)] != 0) {
      throw InputError(origin, line, "x1",
                       "markers are a rigid body's pose in themselves: no distance, orientation "
                       "or fixture label beside them");
    }
  }
}

// A registered kind's columns: all of them, if any.
void check_kind_columns(const std::vector<Column>& columns, const std::string& origin, int line) {
  for (const Column& c : columns) {
    if (c.quantity != Quantity::kKindValue) continue;
    const auto type = static_cast<MeasurementType>(c.joint);
    for (const std::string& name : traits(type).columns) {
      const bool found = std::any_of(columns.begin(), columns.end(), [&](const Column& d) {
        return d.quantity == Quantity::kKindValue && traits(type).columns[d.value] == name &&
               d.joint == c.joint;
      });
      if (!found) {
        throw InputError(origin, line, name,
                         fmt::format("missing: {} need all of their columns", traits(type).plural));
      }
    }
  }
}

// Checks the set of columns as a whole; returns the number of joints.
int check_columns(const std::vector<Column>& columns, const std::string& origin, int line,
                  bool pose_names) {
  int dof = 0;
  std::vector<int> count(kQuantities, 0);
  std::vector<std::string> seen;
  for (const Column& c : columns) {
    if (c.quantity == Quantity::kSkip) continue;
    const std::string id = fmt::format("{}:{}:{}", static_cast<int>(c.quantity), c.joint, c.value);
    for (const std::string& s : seen) {
      if (s == id) throw InputError(origin, line, c.name, "column appears twice");
    }
    seen.push_back(id);
    ++count[static_cast<int>(c.quantity)];
    if (c.quantity == Quantity::kJoint) dof = std::max(dof, c.joint + 1);
  }
  // A tracker's stream (calibrate --tracker) is times and positions alone: a
  // point (x, y, z) or markers (x1, y1, z1, ...: a tree's, one a tip).
  const auto has = [&](Quantity q) { return count[static_cast<int>(q)] > 0; };
  const bool tracker_stream =
      count[static_cast<int>(Quantity::kTime)] == 1 &&
      ((count[static_cast<int>(Quantity::kX)] == 1 && count[static_cast<int>(Quantity::kY)] == 1 &&
        count[static_cast<int>(Quantity::kZ)] == 1) ||
       (has(Quantity::kMarkerX) && has(Quantity::kMarkerY) && has(Quantity::kMarkerZ)));
  if (dof == 0 && !tracker_stream) {
    throw InputError(origin, line, "q1",
                     "missing: a log needs joint columns q1..qn (a tracker's stream: t, x, y, z, "
                     "or t, x1, y1, z1, ...)");
  }
  if (count[static_cast<int>(Quantity::kJoint)] != dof) {
    for (int i = 0; i < dof; ++i) {
      bool found = false;
      for (const Column& c : columns)
        found = found || (c.quantity == Quantity::kJoint && c.joint == i);
      if (!found)
        throw InputError(origin, line, fmt::format("q{}", i + 1),
                         "missing (joint columns must be q1..qn without gaps)");
    }
  }
  for (const Column& c : columns) {
    if ((c.quantity == Quantity::kExternal || c.quantity == Quantity::kDirection) &&
        c.joint >= dof) {
      throw InputError(origin, line, c.name,
                       fmt::format("no joint {} (the log has q1..q{})", c.joint + 1, dof));
    }
  }
  check_marker_columns(columns, count, origin, line);
  const int xyz = count[static_cast<int>(Quantity::kX)] + count[static_cast<int>(Quantity::kY)] +
                  count[static_cast<int>(Quantity::kZ)];
  if (xyz != 0 && xyz != 3) {
    const char* missing = count[static_cast<int>(Quantity::kX)] == 0   ? "x"
                          : count[static_cast<int>(Quantity::kY)] == 0 ? "y"
                                                                       : "z";
    throw InputError(origin, line, missing, "missing: positions need all of x, y, z");
  }
  check_orientation_columns(columns, count, origin, line);
  check_kind_columns(columns, origin, line);
  const int points = count[static_cast<int>(Quantity::kPoint)];
  const int planes = count[static_cast<int>(Quantity::kPlane)];
  if (points + planes > 0) {
    if (points && planes) {
      throw InputError(origin, line, "plane",
                       "a log holds fixture points or plane contacts, not both");
    }
    const char* label = points ? "point" : "plane";
    // Several: a tree's, point1 .. pointK, one a tip.
    std::vector<int> numbers;
    for (const Column& c : columns) {
      if (c.quantity == Quantity::kPoint || c.quantity == Quantity::kPlane)
        numbers.push_back(c.joint);
    }
    std::sort(numbers.begin(), numbers.end());
    const int labels = points + planes;
    const bool unnumbered = labels == 1 && numbers[0] == 0;  // a chain's `point`
    for (int k = 0; k < labels && !unnumbered; ++k) {
      if (numbers[static_cast<size_t>(k)] != k + 1) {
        throw InputError(origin, line, label,
                         fmt::format("{} label columns: a chain's is '{}', a tree's {}1 .. {}{}, "
                                     "one a tip",
                                     labels, label, label, label, labels));
      }
    }
    const bool named_poses = pose_names && points && unnumbered && xyz != 0;
    if (!named_poses && (xyz != 0 || count[static_cast<int>(Quantity::kDistance)] != 0)) {
      throw InputError(origin, line, label,
                       fmt::format("a {} log has no measured x, y, z or distance: the {} label is "
                                   "the measurement",
                                   label, label));
    }
  }
  return dof;
}

}  // namespace hapticcal::detail

namespace hapticcal {

std::vector<std::string> split_columns(const std::string& list) { return detail::split(list); }

}  // namespace hapticcal
