// Measurement logs (CSV). Every problem with a file is an
// InputError naming the file, the line and the column.
#pragma once

#include <string>
#include <vector>

#include "hapticcal/core/log.hpp"
#include "hapticcal/identification/log_fit.hpp"
#include "hapticcal/model/model.hpp"

namespace hapticcal {

// Reads a CSV log. Without `columns` the first non-comment line is the header;
// with it, `columns` names every column ("_" skips one) and all lines are data.
// Column names: q<i>, ext<i>, distance, x, y, z, t, each optionally followed by a
// unit in brackets, and `point` or `plane` (a label a row: a fixture point or a
// plane the tool point is at; such a log has no measured values): [rad] [deg] for angles, [m] [mm]
// [um] for lengths, [s] [ms]. An orientation (beside x, y, z) is either all of qw, qx, qy, qz (no
// unit; a norm more than 1e-3 from 1 is an error, else it is normalised) or all of rx, ry, rz, a
// rotation vector (angle * axis, [rad] or [deg]) converted to a unit quaternion.
//
// `point` says what a `point` column beside measured x, y, z is: refused
// (kFixture: a fixture log's label is its measurement), or each row's pose's
// name (kPoseName: an ISO 9283 test log that keeps its plan's column; the
// names in Log::label, has_point false).
enum class PointColumn { kFixture, kPoseName };
Log read_log(const std::string& path, const std::vector<std::string>& columns = {},
             PointColumn point = PointColumn::kFixture);
Log parse_log(const std::string& csv_text, const std::string& origin,
              const std::vector<std::string>& columns = {});

// CSV text that parse_log reads back to the same numbers (header row; SI units;
// shortest round-trip number format; orientation as qw, qx, qy, qz).
std::string log_to_csv(const Log& log);
// Splits a --columns argument "q1[deg],q2[deg],x,_" into names.
std::vector<std::string> split_columns(const std::string& list);

}  // namespace hapticcal
