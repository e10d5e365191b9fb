// A log's rows as a whole: some of them taken (select_rows) or groups of them
// averaged into one row each (average_rows). With the log's reader and writer,
// the one place that knows every per-row field of a Log.
#pragma once

#include <vector>

#include "hapticcal/core/log.hpp"

namespace hapticcal {

// The log's rows `rows` (0-based, in the order given): every per-row field.
Log select_rows(const Log& log, const std::vector<int>& rows);
// One row a group of rows: the first row's readings, sides, label, tip, line
// and time; the mean of their external encoders and measured values (a
// registered kind's too; orientations: the normalised mean of the quaternions,
// each aligned with the first's sign).
Log average_rows(const Log& log, const std::vector<std::vector<int>>& groups);

}  // namespace hapticcal
