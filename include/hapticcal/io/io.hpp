// Device files (YAML) and measurement logs (CSV), SPEC section 5. Every problem
// with a file is an InputError naming the file, the line and the key or column.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "hapticcal/model/model.hpp"

namespace hapticcal {

// Device files: `format: hapticcal-device/1`.
DeviceModel load_device(const std::string& path);
// origin names the text in error messages (a file name).
DeviceModel parse_device(const std::string& yaml_text, const std::string& origin);
// YAML text that parse_device reads back to a bit-identical model.
std::string device_to_yaml(const DeviceModel& model);
// Written atomically: the file is either the old one or the complete new one.
void save_device(const DeviceModel& model, const std::string& path);
// Empty if the model is usable, else "key: reason" (e.g. "links[3].limits: lower >= upper").
std::string check_device(const DeviceModel& model);

// The unit a joint-reading column was given in: none (SI), an angle or a length
// (a prismatic joint's; check_log_fits matches it to the model's joint types).
enum class ReadingUnit { kNone, kAngle, kLength };

// A measurement log: one row per sample, SI units (converted from the column units).
struct Log {
  std::string origin;
  int rows = 0;
  Eigen::MatrixXd q;                  // rows x dof, joint readings [rad; m for prismatic joints]
  std::vector<ReadingUnit> q_unit;    // per joint, as the header gave it
  std::vector<std::string> q_column;  // per joint, the header's name (for messages)
  std::vector<ReadingUnit> ext_unit;  // likewise for the ext<i> columns
  std::vector<std::string> ext_column;
  Eigen::MatrixXd ext;        // rows x dof, external encoders [rad]; columns without one are 0
  std::vector<bool> has_ext;  // per joint
  Eigen::VectorXd distance;   // [m], if has_distance
  Eigen::MatrixXd position;   // rows x 3 [m], if has_position
  Eigen::VectorXd t;          // [s], if has_time
  // rows x 4 unit quaternions (w, x, y, z) of the tool in the measurement frame, if
  // has_orientation (which needs has_position: a pose is position and orientation).
  Eigen::MatrixXd orientation;
  bool has_distance = false, has_position = false, has_time = false;
  bool has_orientation = false;
  // Fixture logs: each row's label (has_point: the fixed point the tool point is
  // at; has_plane: the plane it touches); no measured values.
  std::vector<std::string> label;
  bool has_point = false, has_plane = false;
  std::vector<int> line;  // source line of each row
  int dof() const { return static_cast<int>(q.cols()); }
};

// Reads a CSV log. Without `columns` the first non-comment line is the header;
// with it, `columns` names every column ("_" skips one) and all lines are data.
// Column names: q<i>, ext<i>, distance, x, y, z, t, each optionally followed by a
// unit in brackets, and `point` or `plane` (a label a row: a fixture point or a
// plane the tool point is at; such a log has no measured values): [rad] [deg] for angles, [m] [mm]
// [um] for lengths, [s] [ms]. An orientation (beside x, y, z) is either all of qw, qx, qy, qz (no
// unit; a norm more than 1e-3 from 1 is an error, else it is normalised) or all of rx, ry, rz, a
// rotation vector (angle * axis, [rad] or [deg]) converted to a unit quaternion.
Log read_log(const std::string& path, const std::vector<std::string>& columns = {});
Log parse_log(const std::string& csv_text, const std::string& origin,
              const std::vector<std::string>& columns = {});
// Throws InputError unless the log's joint count is the model's and it holds
// distances or positions to compare the model with.
void check_log_fits(const Log& log, const DeviceModel& model);

// CSV text that parse_log reads back to the same numbers (header row; SI units;
// shortest round-trip number format; orientation as qw, qx, qy, qz).
std::string log_to_csv(const Log& log);
// Splits a --columns argument "q1[deg],q2[deg],x,_" into names.
std::vector<std::string> split_columns(const std::string& list);

// Writes text to path atomically (temporary file in the same directory, then
// rename); creates missing parent directories.
void write_file_atomically(const std::string& path, const std::string& text);
// What an input file is, for its size limit (README "Bounded input"). Each
// bound is far above any real file of the kind and keeps the parsers' memory
// (a few tens of bytes per input byte) within a few hundred megabytes.
enum class FileKind {
  kDevice,    // device file (YAML): 256 KiB (a 32-joint device is about 10 KiB)
  kUrdf,      // URDF: 3 MiB (meshes are referenced, not inlined)
  kLog,       // measurement log (CSV): 2 GiB (a one-hour 1 kHz stream is ~0.4 GiB)
  kFixture,   // fixture file (YAML): 256 KiB
  kScenario,  // simulate scenario (YAML): 256 KiB
  kOwn,       // hapticcal's own files (results, figures): 256 MiB
};
std::size_t max_file_bytes(FileKind kind);
// The whole of a regular file, at most max_file_bytes(kind): InputError naming
// the file for a directory, a device, FIFO or socket (never read: /dev/zero
// would not end), or a larger file (checked before and while reading).
std::string read_file(const std::string& path, FileKind kind = FileKind::kOwn);

}  // namespace hapticcal
