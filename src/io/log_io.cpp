#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <numbers>
#include <string_view>

#include "hapticcal/io/error.hpp"
#include "hapticcal/io/io.hpp"

namespace hapticcal {
namespace {

// The quaternion components and the rotation-vector components each in order (w, x, y, z and
// x, y, z): their offset from kQw and kRx is their index.
enum class Quantity {
  kSkip,
  kJoint,
  kExternal,
  kDistance,
  kX,
  kY,
  kZ,
  kTime,
  kQw,
  kQx,
  kQy,
  kQz,
  kRx,
  kRy,
  kRz,
  kPoint,  // a label: the fixture point the tool point is at
  kPlane   // a label: the plane the tool point touches
};
constexpr int kQuantities = static_cast<int>(Quantity::kPlane) + 1;

bool is_quaternion(Quantity q) { return q >= Quantity::kQw && q <= Quantity::kQz; }
bool is_rotation_vector(Quantity q) { return q >= Quantity::kRx && q <= Quantity::kRz; }

// A quaternion whose norm is within this of 1 is unit as far as a double can tell and is kept
// bit for bit; normalising any other (q / |q|) lands within 1.5 eps of norm 1, so a log that
// log_to_csv wrote reads back to the same numbers.
constexpr double kUnitToPrecision = 4 * std::numeric_limits<double>::epsilon();
// Further from norm 1 than this, the numbers are not a unit quaternion (a wrong column, a
// component order other than w, x, y, z) rather than one rounded when it was written.
constexpr double kUnitTolerance = 1e-3;

constexpr std::string_view kQuaternionLetters = "wxyz", kRotationVectorLetters = "xyz";

// The index of `base` among prefix + letters[0], prefix + letters[1], ..., or -1.
int component_index(const std::string& base, char prefix, std::string_view letters) {
  if (base.size() != 2 || base[0] != prefix) return -1;
  const size_t k = letters.find(base[1]);
  return k == std::string_view::npos ? -1 : static_cast<int>(k);
}

constexpr const char* kExpectedColumns =
    "unknown column (expected q<i>, ext<i>, distance, x, y, z, qw, qx, qy, qz, rx, ry, rz, t, "
    "point, plane or _)";

struct Column {
  std::string name;  // as written, for messages
  Quantity quantity = Quantity::kSkip;
  int joint = 0;                          // zero-based, for q and ext
  double scale = 1;                       // to SI
  ReadingUnit unit = ReadingUnit::kNone;  // of a q column: as written
};

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

Column parse_column(const std::string& spec, const std::string& origin, int line) {
  std::string base, index, unit;
  if (!split_spec(spec, base, index, unit)) {
    std::string why = "not a column name";
    if (const std::string problem = text_problem(spec); !problem.empty()) why += ": " + problem;
    throw InputError(origin, line, spec.empty() ? "(empty)" : printable(spec), why);
  }
  Column c;
  c.name = printable(spec);  // messages quote it
  const bool indexed = base == "q" || base == "ext";
  if (base == "_" && index.empty() && unit.empty()) return c;
  if (indexed != !index.empty()) {
    throw InputError(origin, line, c.name, kExpectedColumns);
  }
  if (indexed) {
    if (index.size() > 3) throw InputError(origin, line, c.name, "joint number too large");
    const int i = std::stoi(index);
    if (i < 1) throw InputError(origin, line, c.name, "joint numbers start at 1");
    c.joint = i - 1;
    c.quantity = base == "q" ? Quantity::kJoint : Quantity::kExternal;
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
  } else if (base == "point" || base == "plane") {
    c.quantity = base == "point" ? Quantity::kPoint : Quantity::kPlane;
    if (!unit.empty()) {
      throw InputError(origin, line, c.name,
                       fmt::format("unit '{}': a {} column holds labels", printable(unit), base));
    }
    return c;
  } else if (const int k = component_index(base, 'q', kQuaternionLetters); k >= 0) {
    c.quantity = static_cast<Quantity>(static_cast<int>(Quantity::kQw) + k);
  } else if (const int k = component_index(base, 'r', kRotationVectorLetters); k >= 0) {
    c.quantity = static_cast<Quantity>(static_cast<int>(Quantity::kRx) + k);
  } else {
    throw InputError(origin, line, c.name, kExpectedColumns);
  }
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

// Checks the set of columns as a whole; returns the number of joints.
int check_columns(const std::vector<Column>& columns, const std::string& origin, int line) {
  int dof = 0;
  std::vector<int> count(kQuantities, 0);
  std::vector<std::string> seen;
  for (const Column& c : columns) {
    if (c.quantity == Quantity::kSkip) continue;
    const std::string id = fmt::format("{}:{}", static_cast<int>(c.quantity), c.joint);
    for (const std::string& s : seen) {
      if (s == id) throw InputError(origin, line, c.name, "column appears twice");
    }
    seen.push_back(id);
    ++count[static_cast<int>(c.quantity)];
    if (c.quantity == Quantity::kJoint) dof = std::max(dof, c.joint + 1);
  }
  if (dof == 0) throw InputError(origin, line, "q1", "missing: a log needs joint columns q1..qn");
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
    if (c.quantity == Quantity::kExternal && c.joint >= dof) {
      throw InputError(origin, line, c.name,
                       fmt::format("no joint {} (the log has q1..q{})", c.joint + 1, dof));
    }
  }
  const int xyz = count[static_cast<int>(Quantity::kX)] + count[static_cast<int>(Quantity::kY)] +
                  count[static_cast<int>(Quantity::kZ)];
  if (xyz != 0 && xyz != 3) {
    const char* missing = count[static_cast<int>(Quantity::kX)] == 0   ? "x"
                          : count[static_cast<int>(Quantity::kY)] == 0 ? "y"
                                                                       : "z";
    throw InputError(origin, line, missing, "missing: positions need all of x, y, z");
  }
  check_orientation_columns(columns, count, origin, line);
  const int points = count[static_cast<int>(Quantity::kPoint)];
  const int planes = count[static_cast<int>(Quantity::kPlane)];
  if (points + planes > 0) {
    if (points && planes) {
      throw InputError(origin, line, "plane",
                       "a log holds fixture points or plane contacts, not both");
    }
    const char* label = points ? "point" : "plane";
    if (xyz != 0 || count[static_cast<int>(Quantity::kDistance)] != 0) {
      throw InputError(origin, line, label,
                       fmt::format("a {} log has no measured x, y, z or distance: the {} label is "
                                   "the measurement",
                                   label, label));
    }
  }
  return dof;
}

// q (w, x, y, z) as a unit quaternion: normalised if its norm is within kUnitTolerance of 1
// (kept as it is within kUnitToPrecision), else an InputError.
Eigen::RowVector4d unit_quaternion(const Eigen::RowVector4d& q, const std::string& origin,
                                   int line) {
  const double norm = q.norm();
  if (!(std::abs(norm - 1) <= kUnitTolerance)) {
    throw InputError(origin, line, "qw..qz",
                     fmt::format("not a unit quaternion: norm {} differs from 1 by more than {}",
                                 norm, kUnitTolerance));
  }
  return std::abs(norm - 1) <= kUnitToPrecision ? q : Eigen::RowVector4d(q / norm);
}

// The rotation vector (rx, ry, rz) [rad] = angle * axis as a quaternion (w, x, y, z).
Eigen::RowVector4d rotation_vector_to_quaternion(const Eigen::Vector3d& rotation,
                                                 const std::string& origin, int line) {
  const double angle = rotation.stableNorm();
  if (!std::isfinite(angle)) {
    throw InputError(origin, line, "rx..rz", "the rotation vector is too long to measure");
  }
  if (angle == 0) return {1, 0, 0, 0};
  const Eigen::Quaterniond q(Eigen::AngleAxisd(angle, rotation / angle));
  return {q.w(), q.x(), q.y(), q.z()};
}

}  // namespace

std::vector<std::string> split_columns(const std::string& list) { return split(list); }

// More columns than any log of a chain needs (q, ext per joint, measurements).
constexpr size_t kMaxColumns = 1000;
// A point or plane label's length at most (a name, not a document).
constexpr size_t kMaxLabel = 64;

Log parse_log(const std::string& text, const std::string& origin,
              const std::vector<std::string>& column_names) {
  std::vector<Column> columns;
  int dof = 0;
  auto set_columns = [&](const std::vector<std::string>& names, const std::string& where,
                         int line) {
    for (const std::string& n : names) columns.push_back(parse_column(n, where, line));
    dof = check_columns(columns, where, line);
  };
  if (!column_names.empty()) set_columns(column_names, "--columns", 0);

  // The rows' values one after another (columns.size() a row): one allocation
  // for the log, not one a row; labels only for a log with a label column.
  std::vector<double> values;
  std::vector<std::string> labels;
  std::vector<int> lines;
  size_t pos = 0;
  int line_no = 0;
  while (pos <= text.size()) {
    size_t eol = text.find('\n', pos);
    if (eol == std::string::npos) eol = text.size();
    const std::string line = trim(text.substr(pos, eol - pos));
    pos = eol + 1;
    ++line_no;
    if (line.empty() || line[0] == '#') continue;
    // Fields are counted before they are split: a line of commas costs no memory.
    const size_t field_count = static_cast<size_t>(std::count(line.begin(), line.end(), ',')) + 1;
    if (columns.empty() && field_count > kMaxColumns) {
      throw InputError(
          origin, line_no, "",
          fmt::format("{} columns in the header: a log has at most {}", field_count, kMaxColumns));
    }
    // The first row of a log read with --columns: a header there is a log
    // that names its own columns.
    if (!column_names.empty() && lines.empty() && field_count <= kMaxColumns &&
        looks_like_header(split(line))) {
      throw InputError(origin, line_no, "",
                       "the log has a header line; drop --columns (or remove the header)");
    }
    if (!columns.empty() && field_count != columns.size()) {
      throw InputError(
          origin, line_no, "",
          fmt::format("{} fields, expected {} ({})", field_count, columns.size(),
                      column_names.empty() ? "one per header column" : "one per --columns entry"));
    }
    const std::vector<std::string> fields = split(line);
    if (columns.empty()) {
      if (std::all_of(fields.begin(), fields.end(), is_number)) {
        throw InputError(origin, line_no, "",
                         fmt::format("the log has no header (its first line is numbers): give "
                                     "its {} column names with --columns q1,q2,...,x",
                                     fields.size()));
      }
      set_columns(fields, origin, line_no);
      continue;
    }
    const size_t first = values.size();
    values.resize(first + columns.size(), 0.0);
    double* row = values.data() + first;
    std::string row_label;
    bool labelled = false;
    for (size_t k = 0; k < fields.size(); ++k) {
      if (columns[k].quantity == Quantity::kSkip) continue;
      const std::string& f = fields[k];
      if (columns[k].quantity == Quantity::kPoint || columns[k].quantity == Quantity::kPlane) {
        if (f.empty()) throw InputError(origin, line_no, columns[k].name, "empty label");
        if (f.size() > kMaxLabel) {
          throw InputError(
              origin, line_no, columns[k].name,
              fmt::format("a label of {} characters: at most {}", f.size(), kMaxLabel));
        }
        if (const std::string problem = text_problem(f); !problem.empty()) {
          throw InputError(origin, line_no, columns[k].name, "label " + problem);
        }
        if (f.find_first_of(":=") != std::string::npos) {
          throw InputError(origin, line_no, columns[k].name,
                           fmt::format("label '{}': ':' and '=' are not allowed (--point-distance "
                                       "A:B=METRES names labels)",
                                       printable(f)));
        }
        row_label = f;
        labelled = true;
        continue;
      }
      double v = 0;
      if (!parse_number(f, v)) {
        throw InputError(origin, line_no, columns[k].name,
                         fmt::format("'{}' is not a number", printable(f)));
      }
      if (!std::isfinite(v)) {
        throw InputError(origin, line_no, columns[k].name,
                         fmt::format("'{}' is not finite", printable(f)));
      }
      row[k] = v * columns[k].scale;
    }
    if (labelled) labels.push_back(std::move(row_label));
    lines.push_back(line_no);
  }
  if (columns.empty()) throw InputError(origin, 0, "", "empty log: no header and no data");
  if (lines.empty()) throw InputError(origin, 0, "", "no data rows");

  Log log;
  log.origin = origin;
  log.rows = static_cast<int>(lines.size());
  log.line = std::move(lines);
  log.q.setZero(log.rows, dof);
  log.ext.setZero(log.rows, dof);
  log.has_ext.assign(dof, false);
  log.q_unit.assign(dof, ReadingUnit::kNone);
  log.q_column.assign(dof, "");
  log.ext_unit.assign(dof, ReadingUnit::kNone);
  log.ext_column.assign(dof, "");
  for (const Column& c : columns) {
    switch (c.quantity) {
      case Quantity::kDistance:
        log.has_distance = true;
        break;
      case Quantity::kX:
        log.has_position = true;
        break;
      case Quantity::kTime:
        log.has_time = true;
        break;
      case Quantity::kPoint:
        log.has_point = true;
        break;
      case Quantity::kPlane:
        log.has_plane = true;
        break;
      case Quantity::kExternal:
        log.has_ext[c.joint] = true;
        log.ext_unit[c.joint] = c.unit;
        log.ext_column[c.joint] = c.name;
        break;
      case Quantity::kJoint:
        log.q_unit[c.joint] = c.unit;
        log.q_column[c.joint] = c.name;
        break;
      default:
        log.has_orientation =
            log.has_orientation || is_quaternion(c.quantity) || is_rotation_vector(c.quantity);
        break;
    }
  }
  if (log.has_distance) log.distance.setZero(log.rows);
  if (log.has_position) log.position.setZero(log.rows, 3);
  if (log.has_time) log.t.setZero(log.rows);
  // The rotation vectors, if given, in the first three columns until converted below.
  if (log.has_orientation) log.orientation.setZero(log.rows, 4);
  for (int r = 0; r < log.rows; ++r) {
    for (size_t k = 0; k < columns.size(); ++k) {
      const Column& c = columns[k];
      const double v = values[static_cast<size_t>(r) * columns.size() + k];
      switch (c.quantity) {
        case Quantity::kJoint:
          log.q(r, c.joint) = v;
          break;
        case Quantity::kExternal:
          log.ext(r, c.joint) = v;
          break;
        case Quantity::kDistance:
          log.distance[r] = v;
          break;
        case Quantity::kX:
          log.position(r, 0) = v;
          break;
        case Quantity::kY:
          log.position(r, 1) = v;
          break;
        case Quantity::kZ:
          log.position(r, 2) = v;
          break;
        case Quantity::kTime:
          log.t[r] = v;
          break;
        case Quantity::kQw:
        case Quantity::kQx:
        case Quantity::kQy:
        case Quantity::kQz:
          log.orientation(r, static_cast<int>(c.quantity) - static_cast<int>(Quantity::kQw)) = v;
          break;
        case Quantity::kRx:
        case Quantity::kRy:
        case Quantity::kRz:
          log.orientation(r, static_cast<int>(c.quantity) - static_cast<int>(Quantity::kRx)) = v;
          break;
        case Quantity::kSkip:
        case Quantity::kPoint:
        case Quantity::kPlane:
          break;
      }
    }
  }
  if (log.has_point || log.has_plane) log.label = std::move(labels);
  if (log.has_orientation) {
    const bool rotation_vectors = std::any_of(columns.begin(), columns.end(), [](const Column& c) {
      return is_rotation_vector(c.quantity);
    });
    for (int r = 0; r < log.rows; ++r) {
      if (rotation_vectors) {
        const Eigen::Vector3d rotation = log.orientation.row(r).head<3>();
        log.orientation.row(r) = rotation_vector_to_quaternion(rotation, origin, log.line[r]);
      }
      log.orientation.row(r) = unit_quaternion(log.orientation.row(r), origin, log.line[r]);
    }
  }
  if (log.has_distance) {
    for (int r = 0; r < log.rows; ++r) {
      if (!(log.distance[r] >= 0)) {
        throw InputError(origin, log.line[r], "distance", "a distance cannot be negative");
      }
    }
  }
  return log;
}

void check_log_fits(const Log& log, const DeviceModel& model) {
  if (log.dof() != model.dof()) {
    throw InputError(log.origin, 0, "",
                     fmt::format("the log has {} joint columns but the model '{}' has {} joints",
                                 log.dof(), model.name, model.dof()));
  }
  if (!log.has_distance && !log.has_position && !log.has_point && !log.has_plane) {
    throw InputError(log.origin, 0, "",
                     "no measurements: the log has neither a distance, x, y, z, a point nor a "
                     "plane column");
  }
  // Readings with a unit: angles for turning joints, lengths for prismatic ones.
  auto check = [&](const std::vector<ReadingUnit>& units, const std::vector<std::string>& names) {
    for (int j = 0; j < static_cast<int>(units.size()) && j < model.dof(); ++j) {
      const bool prismatic = model.links[j].prismatic();
      const ReadingUnit u = units[j];
      if (u == ReadingUnit::kNone || (u == ReadingUnit::kLength) == prismatic) continue;
      throw InputError(log.origin, 1, names[j],
                       fmt::format("{} is {}: its readings are {}", model.links[j].name,
                                   prismatic ? "prismatic" : "a turning joint",
                                   prismatic ? "lengths (m, mm, um)" : "angles (rad, deg)"));
    }
  };
  check(log.q_unit, log.q_column);
  check(log.ext_unit, log.ext_column);
}

std::string log_to_csv(const Log& log) {
  std::string out;
  std::vector<std::string> header;
  if (log.has_time) header.push_back("t");
  for (int j = 0; j < log.dof(); ++j) header.push_back(fmt::format("q{}", j + 1));
  for (int j = 0; j < log.dof(); ++j) {
    if (log.has_ext[j]) header.push_back(fmt::format("ext{}", j + 1));
  }
  if (log.has_distance) header.push_back("distance");
  if (log.has_position) header.insert(header.end(), {"x", "y", "z"});
  if (log.has_orientation) header.insert(header.end(), {"qw", "qx", "qy", "qz"});
  if (log.has_point || log.has_plane) header.push_back(log.has_point ? "point" : "plane");
  for (size_t k = 0; k < header.size(); ++k) out += (k ? "," : "") + header[k];
  out += '\n';
  fmt::memory_buffer row;
  for (int r = 0; r < log.rows; ++r) {
    row.clear();
    auto put = [&](double v) {
      fmt::format_to(std::back_inserter(row), "{}{}", row.size() ? "," : "", v);
    };
    if (log.has_time) put(log.t[r]);
    for (int j = 0; j < log.dof(); ++j) put(log.q(r, j));
    for (int j = 0; j < log.dof(); ++j) {
      if (log.has_ext[j]) put(log.ext(r, j));
    }
    if (log.has_distance) put(log.distance[r]);
    if (log.has_position) {
      for (int k = 0; k < 3; ++k) put(log.position(r, k));
    }
    if (log.has_orientation) {
      for (int k = 0; k < 4; ++k) put(log.orientation(r, k));
    }
    if (log.has_point || log.has_plane) {
      fmt::format_to(std::back_inserter(row), "{}{}", row.size() ? "," : "", log.label[r]);
    }
    out.append(row.data(), row.size());
    out += '\n';
  }
  return out;
}

Log read_log(const std::string& path, const std::vector<std::string>& columns) {
  return parse_log(read_file(path, FileKind::kLog), path, columns);
}

}  // namespace hapticcal
