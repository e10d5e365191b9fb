// Pose and distance characteristics of ISO 9283:1998 (Manipulating industrial
// robots - Performance criteria and related test methods): pose accuracy AP
// and repeatability RP (position and orientation, clause 7.2), distance
// accuracy AD and repeatability RD (clause 7.3), from the poses a robot
// attained over n cycles against the poses it was commanded to.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "hapticcal/core/log.hpp"
#include "hapticcal/model/frame.hpp"
#include "hapticcal/model/model.hpp"

namespace hapticcal {

// One pose of the test (P1 .. P5): the commanded pose and what was attained in
// each cycle (cycle order; a cycle that missed the pose is absent).
struct IsoPoseRuns {
  std::string label;
  Frame<double> commanded = Frame<double>::Identity();
  std::vector<int> cycles;              // the cycle number of each attained pose
  std::vector<Frame<double>> attained;  // one a cycle
  bool orientation = false;             // the attained orientations were measured
};

// A pose's characteristics. Orientations as the standard's a, b, c: turns
// about the x, y and z axes (here URDF's roll, pitch, yaw: R = Rz(c) Ry(b)
// Rx(a)); an attained angle is taken relative to the commanded one, into
// (-pi, pi], so that a pose near +-pi is not split across the wrap.
struct IsoPoseCriteria {
  std::string label;
  int cycles = 0;                   // n
  Eigen::Vector3d commanded, mean;  // x_c, y_c, z_c; the barycentre [m]
  Eigen::Vector3d ap_xyz;           // AP_x, AP_y, AP_z = mean - commanded [m]
  double ap = 0;                    // AP_P = |mean - commanded| [m]
  double rp = 0;                    // RP_l = l_mean + 3 S_l [m]; NaN with n < 2
  bool orientation = false;
  Eigen::Vector3d ap_abc = Eigen::Vector3d::Zero();  // AP_a, AP_b, AP_c [rad]
  Eigen::Vector3d rp_abc = Eigen::Vector3d::Zero();  // RP_a, RP_b, RP_c = 3 S [rad]; NaN with n < 2
};

// The distance characteristics of two poses over the cycles that attained both:
// D_j = |P_1j - P_2j|, D_c = |P_1c - P_2c|, AD = mean D - D_c, RD = 3 S_D.
struct IsoDistanceCriteria {
  std::string from, to;
  int cycles = 0;
  double commanded = 0, mean = 0;  // D_c, mean D_j [m]
  double ad = 0, rd = 0;           // [m]; rd NaN with fewer than 2 cycles
};

IsoPoseCriteria iso_pose_criteria(const IsoPoseRuns& runs);
IsoDistanceCriteria iso_distance_criteria(const IsoPoseRuns& from, const IsoPoseRuns& to);

// Every pose's characteristics, and the distances: P2 to P4 (the standard's
// pair) if both are there, then P1 (the cube's centre; without one, the first
// pose) to each other pose.
struct IsoCriteria {
  std::vector<IsoPoseCriteria> poses;
  std::vector<IsoDistanceCriteria> distances;
};
IsoCriteria iso_criteria(const std::vector<IsoPoseRuns>& poses);

// The runs of a test log: row r attained the pose labels[r] (P1 .. P5, as the
// plan's plan.csv names them), the k-th row of a label in cycle k. A pose's
// commanded pose is the model's at the mean of its rows' readings; the
// attained ones the log's positions (and orientations, a pose log's). Poses in
// the order P1, P2, ... (other labels after them, by name). Throws InputError for a log without
// positions or labels of another count than its rows.
std::vector<IsoPoseRuns> iso_runs(const DeviceModel& model, const Log& log,
                                  const std::vector<std::string>& labels);

}  // namespace hapticcal
