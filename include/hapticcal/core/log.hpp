// A measurement log in memory: joint readings, external
// encoders and what the instrument measured, one row a sample, SI units. A
// project-wide type: read by data_io/log.hpp, used by every layer above core.
#pragma once

#include <Eigen/Core>
#include <map>
#include <string>
#include <vector>

namespace hapticcal {

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
  // dir<i> columns: the side joint i approached the pose from (+1 moving up
  // in q, -1 moving down, 0 not known); rows x dof, 0 where a joint has none.
  // The feature of a backlash (Link::backlash, --joint-errors backlash).
  Eigen::MatrixXd direction;
  std::vector<bool> has_direction;  // per joint
  Eigen::VectorXd distance;         // [m], if has_distance
  Eigen::MatrixXd position;         // rows x 3 [m], if has_position
  Eigen::VectorXd t;                // [s], if has_time
  // rows x 4 unit quaternions (w, x, y, z) of the tool in the measurement frame, if
  // has_orientation (which needs has_position: a pose is position and orientation).
  Eigen::MatrixXd orientation;
  // Several markers of one rigid body (columns x1, y1, z1, x2, ...): rows x 3
  // marker_count, each marker's x, y, z in the measurement frame [m]
  // (markers_to_poses turns them into poses of the body).
  Eigen::MatrixXd markers;
  int marker_count = 0;
  bool has_distance = false, has_position = false, has_time = false;
  bool has_orientation = false;
  // Fixture logs: each row's label (has_point: the fixed point the tool point is
  // at; has_plane: the plane it touches); no measured values.
  std::vector<std::string> label;
  bool has_point = false, has_plane = false;
  // The values of a measurement kind registered by a program
  // (register_measurement_kind), rows x its width, by the kind's name: the log
  // reader does not read them (yet); repeats are averaged like the columns above.
  std::map<std::string, Eigen::MatrixXd> columns;
  std::vector<int> line;  // source line of each row
  // The file's first comment line (after '#', trimmed): what wrote it
  // (`hapticcal import` names its recording and --convention).
  std::string comment;
  // A tree's samples (tip_samples: a row a tip of a log row): the tip each row
  // measures; empty: the first (a chain's only one).
  std::vector<int> tip;
  int dof() const { return static_cast<int>(q.cols()); }
  bool directed(int joint) const {
    return joint < static_cast<int>(has_direction.size()) && has_direction[joint];
  }
  bool any_direction() const {
    for (bool d : has_direction)
      if (d) return true;
    return false;
  }
};

}  // namespace hapticcal
