// Measurement logs (CSV): a log's lines read into a Log, and a
// Log written back as CSV. The column names are log_columns.cpp's.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

#include "data_io/log_columns.hpp"
#include "hapticcal/core/cancel.hpp"
#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/identification/measurement.hpp"

namespace hapticcal {
namespace {

using detail::check_columns;
using detail::Column;
using detail::is_number;
using detail::is_quaternion;
using detail::is_rotation_vector;
using detail::looks_like_header;
using detail::parse_column;
using detail::parse_number;
using detail::Quantity;
using detail::split;
using detail::trim;

// A quaternion whose norm is within this of 1 is unit as far as a double can tell and is kept
// bit for bit; normalising any other (q / |q|) lands within 1.5 eps of norm 1, so a log that
// log_to_csv wrote reads back to the same numbers.
constexpr double kUnitToPrecision = 4 * std::numeric_limits<double>::epsilon();
// Further from norm 1 than this, the numbers are not a unit quaternion (a wrong column, a
// component order other than w, x, y, z) rather than one rounded when it was written.
constexpr double kUnitTolerance = 1e-3;

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

// More columns than any log of a chain needs (q, ext per joint, measurements).
constexpr size_t kMaxColumns = 1000;
// A point or plane label's length at most (a name, not a document).
constexpr size_t kMaxLabel = 64;

// A log's text as read: its columns and its data rows. The rows' values one
// after another (columns.size() a row): one allocation for the log, not one a
// row; labels only for a log with a label column.
struct Table {
  std::vector<Column> columns;
  int dof = 0;
  std::vector<double> values;
  std::vector<std::string> labels;
  std::vector<int> lines;  // of each row
  std::string comment;     // the first comment line's text
  PointColumn point = PointColumn::kFixture;

  void set_columns(const std::vector<std::string>& names, const std::string& where, int line) {
    for (const std::string& n : names) columns.push_back(parse_column(n, where, line));
    dof = check_columns(columns, where, line, point == PointColumn::kPoseName);
  }
};

// InputError unless the field `f` of the label column `c` is a usable label.
void check_label(const std::string& f, const Column& c, const std::string& origin, int line) {
  if (f.empty()) throw InputError(origin, line, c.name, "empty label");
  if (f.size() > kMaxLabel) {
    throw InputError(origin, line, c.name,
                     fmt::format("a label of {} characters: at most {}", f.size(), kMaxLabel));
  }
  if (const std::string problem = text_problem(f); !problem.empty()) {
    throw InputError(origin, line, c.name, "label " + problem);
  }
  if (f.find_first_of(":=") != std::string::npos) {
    throw InputError(origin, line, c.name,
                     fmt::format("label '{}': ':' and '=' are not allowed (--point-distance "
                                 "A:B=METRES names labels)",
                                 printable(f)));
  }
}

// The field `f` of the numeric column `c`, in SI units; InputError unless it is
// a finite number.
double field_value(const std::string& f, const Column& c, const std::string& origin, int line) {
  double v = 0;
  if (!parse_number(f, v)) {
    throw InputError(origin, line, c.name, fmt::format("'{}' is not a number", printable(f)));
  }
  if (!std::isfinite(v)) {
    throw InputError(origin, line, c.name, fmt::format("'{}' is not finite", printable(f)));
  }
  return v * c.scale;
}

// A data row's fields (as many as the columns) into the table.
void add_row(Table& table, const std::vector<std::string>& fields, const std::string& origin,
             int line) {
  const std::vector<Column>& columns = table.columns;
  const size_t first = table.values.size();
  table.values.resize(first + columns.size(), 0.0);
  double* row = table.values.data() + first;
  // A row's label; a tree's (point1 .. pointK) tip by tip, joined by ',' (no
  // field holds one).
  std::vector<std::string> row_labels;
  for (size_t k = 0; k < fields.size(); ++k) {
    if (columns[k].quantity == Quantity::kSkip) continue;
    const std::string& f = fields[k];
    if (columns[k].quantity == Quantity::kPoint || columns[k].quantity == Quantity::kPlane) {
      check_label(f, columns[k], origin, line);
      const auto at = static_cast<size_t>(std::max(columns[k].joint, 1) - 1);
      if (row_labels.size() <= at) row_labels.resize(at + 1);
      row_labels[at] = f;
      continue;
    }
    row[k] = field_value(f, columns[k], origin, line);
  }
  if (!row_labels.empty()) table.labels.push_back(fmt::format("{}", fmt::join(row_labels, ",")));
  table.lines.push_back(line);
}

// The columns (from the header line, or `column_names` if given) and the data
// rows of the log `text`.
Table read_table(const std::string& text, const std::string& origin,
                 const std::vector<std::string>& column_names,
                 PointColumn point = PointColumn::kFixture) {
  Table table;
  table.point = point;
  if (!column_names.empty()) table.set_columns(column_names, "--columns", 0);
  const std::vector<Column>& columns = table.columns;
  size_t pos = 0;
  int line_no = 0;
  while (pos <= text.size()) {
    size_t eol = text.find('\n', pos);
    if (eol == std::string::npos) eol = text.size();
    const std::string line = trim(text.substr(pos, eol - pos));
    pos = eol + 1;
    if ((++line_no & 4095) == 0) throw_if_cancelled();  // Python's Ctrl-C (core/cancel.hpp)
    if (!line.empty() && line[0] == '#' && table.comment.empty())
      table.comment = trim(line.substr(1, 1000));
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
    if (!column_names.empty() && table.lines.empty() && field_count <= kMaxColumns &&
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
      table.set_columns(fields, origin, line_no);
      continue;
    }
    add_row(table, fields, origin, line_no);
  }
  if (columns.empty()) throw InputError(origin, 0, "", "empty log: no header and no data");
  if (table.lines.empty()) throw InputError(origin, 0, "", "no data rows");
  return table;
}

// The log of the table's rows (their lines moved out of the table), with its
// flags, units and column names from the columns and its arrays zero.
Log zero_log(Table& table, const std::string& origin) {
  const int dof = table.dof;
  Log log;
  log.origin = origin;
  log.rows = static_cast<int>(table.lines.size());
  log.line = std::move(table.lines);
  log.q.setZero(log.rows, dof);
  log.ext.setZero(log.rows, dof);
  log.has_ext.assign(dof, false);
  log.direction.setZero(log.rows, dof);
  log.has_direction.assign(dof, false);
  log.q_unit.assign(dof, ReadingUnit::kNone);
  log.q_column.assign(dof, "");
  log.ext_unit.assign(dof, ReadingUnit::kNone);
  log.ext_column.assign(dof, "");
  for (const Column& c : table.columns) {
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
      case Quantity::kDirection:
        log.has_direction[c.joint] = true;
        break;
      case Quantity::kJoint:
        log.q_unit[c.joint] = c.unit;
        log.q_column[c.joint] = c.name;
        break;
      case Quantity::kMarkerX:
        log.marker_count = std::max(log.marker_count, c.joint + 1);
        break;
      case Quantity::kKindValue: {
        const MeasurementTraits& kind = traits(static_cast<MeasurementType>(c.joint));
        log.columns[kind.name].setZero(log.rows, kind.width);
        break;
      }
      default:
        log.has_orientation =
            log.has_orientation || is_quaternion(c.quantity) || is_rotation_vector(c.quantity);
        break;
    }
  }
  if (log.has_distance) log.distance.setZero(log.rows);
  if (log.has_position) log.position.setZero(log.rows, 3);
  if (log.has_time) log.t.setZero(log.rows);
  if (log.marker_count > 0) log.markers.setZero(log.rows, 3 * log.marker_count);
  // The rotation vectors, if given, in the first three columns until
  // normalise_orientations converts them.
  if (log.has_orientation) log.orientation.setZero(log.rows, 4);
  return log;
}

// The table's values into the log's arrays (zero_log's shape).
void fill_values(Log& log, const Table& table) {
  const std::vector<Column>& columns = table.columns;
  const std::vector<double>& values = table.values;
  std::vector<Eigen::MatrixXd*> kind_values(columns.size(), nullptr);  // kKindValue's
  for (size_t k = 0; k < columns.size(); ++k) {
    if (columns[k].quantity == Quantity::kKindValue)
      kind_values[k] = &log.columns[traits(static_cast<MeasurementType>(columns[k].joint)).name];
  }
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
        case Quantity::kDirection:
          if (v != -1 && v != 0 && v != 1) {
            throw InputError(log.origin, log.line[r], c.name,
                             fmt::format("{}: a direction is -1, 0 or +1 (the side the joint "
                                         "approached the pose from)",
                                         v));
          }
          log.direction(r, c.joint) = v;
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
        case Quantity::kMarkerX:
        case Quantity::kMarkerY:
        case Quantity::kMarkerZ:
          log.markers(r, 3 * c.joint + static_cast<int>(c.quantity) -
                             static_cast<int>(Quantity::kMarkerX)) = v;
          break;
        case Quantity::kKindValue:
          (*kind_values[k])(r, c.value) = v;
          break;
        case Quantity::kSkip:
        case Quantity::kPoint:
        case Quantity::kPlane:
          break;
      }
    }
  }
}

// The orientations as unit quaternions: rotation vectors converted, quaternions
// normalised (or refused).
void normalise_orientations(Log& log, const std::vector<Column>& columns) {
  const std::string& origin = log.origin;
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

}  // namespace

namespace {

// The log of a table read; the table's values are released once copied.
Log log_of_table(Table& table, const std::string& origin) {
  Log log = zero_log(table, origin);
  log.comment = std::move(table.comment);
  fill_values(log, table);
  std::vector<double>().swap(table.values);
  if (log.has_point || log.has_plane) log.label = std::move(table.labels);
  if (log.has_point && log.has_position) log.has_point = false;  // the poses' names (kPoseName)
  if (log.has_orientation) normalise_orientations(log, table.columns);
  if (log.has_distance) {
    for (int r = 0; r < log.rows; ++r) {
      if (!(log.distance[r] >= 0)) {
        throw InputError(origin, log.line[r], "distance", "a distance cannot be negative");
      }
    }
  }
  return log;
}

}  // namespace

Log parse_log(const std::string& text, const std::string& origin,
              const std::vector<std::string>& column_names) {
  Table table = read_table(text, origin, column_names);
  return log_of_table(table, origin);
}

std::string log_to_csv(const Log& log) {
  std::string out;
  std::vector<std::string> header;
  if (log.has_time) header.push_back("t");
  for (int j = 0; j < log.dof(); ++j) header.push_back(fmt::format("q{}", j + 1));
  for (int j = 0; j < log.dof(); ++j) {
    if (log.has_ext[j]) header.push_back(fmt::format("ext{}", j + 1));
  }
  for (int j = 0; j < log.dof(); ++j) {
    if (log.directed(j)) header.push_back(fmt::format("dir{}", j + 1));
  }
  if (log.has_distance) header.push_back("distance");
  if (log.has_position) header.insert(header.end(), {"x", "y", "z"});
  if (log.has_orientation) header.insert(header.end(), {"qw", "qx", "qy", "qz"});
  for (int k = 1; k <= log.marker_count; ++k) {
    for (const char* c : {"x", "y", "z"}) header.push_back(fmt::format("{}{}", c, k));
  }
  // A registered kind's values under its columns' names (a kind without
  // columns has none in a file).
  std::vector<const Eigen::MatrixXd*> kind_values;
  for (const auto& [name, values] : log.columns) {
    const std::optional<MeasurementType> type = measurement_type_named(name);
    if (!type || traits(*type).columns.empty()) continue;
    header.insert(header.end(), traits(*type).columns.begin(), traits(*type).columns.end());
    kind_values.push_back(&values);
  }
  if (log.has_point || log.has_plane) {  // a tree's labels, tip by tip: point1 .. pointK
    const char* label = log.has_point ? "point" : "plane";
    const auto tips =
        log.label.empty() ? 1 : std::count(log.label[0].begin(), log.label[0].end(), ',') + 1;
    for (long k = 1; k <= tips; ++k)
      header.push_back(tips > 1 ? fmt::format("{}{}", label, k) : std::string(label));
  }
  for (size_t k = 0; k < header.size(); ++k) out += (k ? "," : "") + header[k];
  out += '\n';
  fmt::memory_buffer row;
  for (int r = 0; r < log.rows; ++r) {
    if ((r & 4095) == 4095) throw_if_cancelled();
    row.clear();
    auto put = [&](double v) {
      fmt::format_to(std::back_inserter(row), "{}{}", row.size() ? "," : "", v);
    };
    if (log.has_time) put(log.t[r]);
    for (int j = 0; j < log.dof(); ++j) put(log.q(r, j));
    for (int j = 0; j < log.dof(); ++j) {
      if (log.has_ext[j]) put(log.ext(r, j));
    }
    for (int j = 0; j < log.dof(); ++j) {
      if (log.directed(j)) put(log.direction(r, j));
    }
    if (log.has_distance) put(log.distance[r]);
    if (log.has_position) {
      for (int k = 0; k < 3; ++k) put(log.position(r, k));
    }
    if (log.has_orientation) {
      for (int k = 0; k < 4; ++k) put(log.orientation(r, k));
    }
    for (int k = 0; k < 3 * log.marker_count; ++k) put(log.markers(r, k));
    for (const Eigen::MatrixXd* values : kind_values) {
      for (Eigen::Index k = 0; k < values->cols(); ++k) put((*values)(r, k));
    }
    if (log.has_point || log.has_plane) {
      fmt::format_to(std::back_inserter(row), "{}{}", row.size() ? "," : "", log.label[r]);
    }
    out.append(row.data(), row.size());
    out += '\n';
  }
  return out;
}

Log read_log(const std::string& path, const std::vector<std::string>& columns, PointColumn point) {
  std::string text = read_file(path, FileKind::kLog);
  Table table = read_table(text, path, columns, point);
  std::string().swap(text);  // a one-hour stream's text is 0.5 GB: gone before the log is made
  return log_of_table(table, path);
}

}  // namespace hapticcal
