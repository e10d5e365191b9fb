// Internal to the log reader (log_io.cpp): the fields of a log's lines and the
// columns its header or --columns names (q<i>[unit], ext<i>, distance, x, y, z,
// qw..qz, rx..rz, t, point, plane, _, and a registered measurement kind's
// columns), read and checked by log_columns.cpp.
#pragma once

#include <string>
#include <vector>

#include "hapticcal/core/log.hpp"

namespace hapticcal::detail {

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
  kPoint,      // a label: the fixture point the tool point is at
  kPlane,      // a label: the plane the tool point touches
  kDirection,  // dir<i>: the side joint i approached the pose from (-1, 0, +1)
  kMarkerX,    // x<k>, y<k>, z<k>: marker k of a rigid body (Column::joint = k - 1)
  kMarkerY,
  kMarkerZ,
  kKindValue,  // a registered measurement kind's value (Column::joint its type, ::value which)
};

inline bool is_quaternion(Quantity q) { return q >= Quantity::kQw && q <= Quantity::kQz; }
inline bool is_rotation_vector(Quantity q) { return q >= Quantity::kRx && q <= Quantity::kRz; }

struct Column {
  std::string name;  // as written, for messages
  Quantity quantity = Quantity::kSkip;
  int joint = 0;                          // zero-based, for q and ext
  int value = 0;                          // a kind's value: its index among the kind's
  double scale = 1;                       // to SI
  ReadingUnit unit = ReadingUnit::kNone;  // of a q column: as written
};

// A field without its leading and trailing blanks (spaces, tabs, '\r').
std::string trim(const std::string& s);
// The comma-separated fields of a line, each trimmed.
std::vector<std::string> split(const std::string& line);

// `f` as a number (a leading '+' allowed); false if it is not one.
bool parse_number(const std::string& f, double& v);
bool is_number(const std::string& f);

// The column named `spec` (a header field or a --columns entry), its unit's
// scale to SI; InputError naming `origin` and `line` if it is not one.
Column parse_column(const std::string& spec, const std::string& origin, int line);
// A line that is a header: no field is a number, each is written like a
// column name, and at least one is a column parse_column accepts.
bool looks_like_header(const std::vector<std::string>& fields);
// Checks the set of columns as a whole; returns the number of joints.
// `pose_names`: a chain's `point` column beside x, y, z names the rows' poses.
int check_columns(const std::vector<Column>& columns, const std::string& origin, int line,
                  bool pose_names = false);

}  // namespace hapticcal::detail
