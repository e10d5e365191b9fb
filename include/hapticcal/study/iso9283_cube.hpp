// The test poses of ISO 9283:1998 (clause 6.8): a cube in the workspace, its
// edges parallel to the robot's base frame, and five poses on its diagonal
// plane C1-C2-C7-C8: P1 at the centre, P2 .. P5 on the plane's diagonals at
// 10 % of the diagonal's length from the corners. Each pose is found as joint
// readings within the limits (inverse kinematics of the model); a robot of six
// or more joints holds the centre's orientation at every pose.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "hapticcal/model/frame.hpp"
#include "hapticcal/model/model.hpp"

namespace hapticcal {

// A given centre's coordinates are at most this far from the frame's origin [m].
inline constexpr double kMaxCubeCentre = 100;

struct IsoCubeOptions {
  // The cube's centre in the measurement frame [m], each coordinate within
  // +-kMaxCubeCentre; none: the tool point at the middle of every joint's range.
  std::optional<Eigen::Vector3d> centre;
  // The edge [m]; none: the largest whose five poses the joint limits allow
  // (to 0.1 mm).
  std::optional<double> size;
  int cycles = 30;  // the standard's number of cycles for the pose characteristics
};

struct IsoTestPose {
  std::string label;         // P1 .. P5
  Frame<double> pose;        // the commanded pose in the measurement frame
  Eigen::VectorXd readings;  // the joint targets that reach it
};

struct IsoCubePlan {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double size = 0;                                     // the edge [m]
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();  // the cube's edges: the base frame's axes
  bool orientation_held = false;   // every pose at the centre's orientation (six joints or more)
  std::vector<IsoTestPose> poses;  // P1 .. P5
  // A cycle: the poses visited in this order (P1, P5, P4, P3, P2), each
  // reached from the one before; `cycles` of them.
  std::vector<int> order{0, 4, 3, 2, 1};
  int cycles = 30;
  // The cube's corners C1 .. C8 (C1-C2-C7-C8 the measuring plane), for figures.
  std::vector<Eigen::Vector3d> corners;
};

// Throws InputError for a cube the joint limits do not allow (a given centre
// or size), a model without joints, or a tree.
IsoCubePlan plan_iso_cube(const DeviceModel& model, const IsoCubeOptions& options = {});

// Readings near `start` that put the model's tool at `target`: its position,
// and with `orientation` its orientation too (damped least squares on the
// geometric Jacobian through the readings); none if not reached within the
// joint limits.
std::optional<Eigen::VectorXd> reach_pose(const DeviceModel& model, const Eigen::VectorXd& start,
                                          const Frame<double>& target, bool orientation);

}  // namespace hapticcal
