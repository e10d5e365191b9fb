// The test poses of ISO 9283:1998 (clause 6.8): a cube in the workspace, its
// edges parallel to the robot's base frame, and five poses on its diagonal
// plane C1-C2-C7-C8: P1 at the centre, P2 .. P5 on the plane's diagonals at
// 10 % of the diagonal's length from the corners. Each pose is found as joint
// readings within the limits (inverse kinematics of the model); a robot of six
// or more joints holds the centre's orientation at every pose.
//
// The standard places the cube in the most used part of the workspace with the
// largest volume the workspace allows. By default the centre and the orientation
// are searched: readings drawn within the limits give candidate centres (their
// tool points) and orientations; the largest cube about each, then the best
// centre moved while a larger cube fits. A cube fits when its five poses are
// reached within the limits away from singularities and its eight corners are
// within reach (at any orientation: the workspace's points).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "hapticcal/model/frame.hpp"
#include "hapticcal/model/model.hpp"

namespace hapticcal {

// A given centre's coordinates are at most this far from the frame's origin [m].
inline constexpr double kMaxCubeCentre = 100;

// A pose is away from singularities when no direction of the tool's motion
// (a rotation counted at 0.1 m/rad) moves by less than this per radian of the
// joints [m/rad]: the smallest singular value of the Jacobian by the readings.
inline constexpr double kIsoAwayFromSingular = 0.01;

struct IsoCubeOptions {
  // The cube's centre in the measurement frame [m], each coordinate within
  // +-kMaxCubeCentre; none: searched over the workspace.
  std::optional<Eigen::Vector3d> centre;
  // The edge [m]; none: the largest that fits (to 0.1 mm).
  std::optional<double> size;
  // The tool's orientation held at every pose (six joints or more), in the
  // measurement frame; none: searched (the drawn readings' orientations).
  std::optional<Eigen::Matrix3d> orientation;
  int cycles = 30;  // the standard's number of cycles for the pose characteristics
  int draws = 256;  // readings drawn within the limits for the search
  std::uint64_t seed = 9283;
};

// How the cube was found, for the terminal and iso9283.json.
struct IsoCubeSearch {
  bool centre_given = false, size_given = false;
  int candidates = 0;      // centres and orientations tried
  int moves = 0;           // steps of the best centre that gave a larger cube
  std::uint64_t seed = 0;  // of the readings drawn
  // Why the edge is not larger: the first pose or corner a larger cube loses
  // ("P3: outside j5's limits at 163.3 mm"); empty for a given size.
  std::string stopped;
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
  IsoCubeSearch search;
};

// How the cube was placed, in a line: "the largest of 257 centres and
// orientations searched over the workspace (seed 9283), its centre then moved
// 4 times; a larger one loses P3: outside j5's limits at 163.3 mm".
std::string iso_search_text(const IsoCubeSearch& search);

// Throws InputError when no cube of 10 mm or more fits (about a given centre,
// or of a given size), for a model without joints, or a tree.
IsoCubePlan plan_iso_cube(const DeviceModel& model, const IsoCubeOptions& options = {});

// Readings near `start` that put the model's tool at `target`: its position,
// and with `orientation` its orientation too (damped least squares on the
// geometric Jacobian through the readings); none if not reached within the
// joint limits.
std::optional<Eigen::VectorXd> reach_pose(const DeviceModel& model, const Eigen::VectorXd& start,
                                          const Frame<double>& target, bool orientation);

}  // namespace hapticcal
