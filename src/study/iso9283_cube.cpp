#include "hapticcal/study/iso9283_cube.hpp"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "hapticcal/core/error.hpp"
#include "hapticcal/kinematics/inverse.hpp"
#include "hapticcal/kinematics/kinematics.hpp"

namespace hapticcal {
namespace {

constexpr double kReached = 1e-11;    // m and rad: a pose is reached
constexpr double kLengthScale = 0.1;  // m/rad: an orientation error's weight against a position's

bool within_limits(const DeviceModel& model, const Eigen::VectorXd& q) {
  for (int i = 0; i < model.dof(); ++i) {
    const Link& l = model.links[i];
    if (l.continuous()) continue;
    if (q[i] < l.lower - 1e-12 || q[i] > l.upper + 1e-12) return false;
  }
  return true;
}

// The cube's corner (sx, sy, sz in -1, +1) in the measurement frame.
Eigen::Vector3d corner(const IsoCubePlan& plan, double sx, double sy, double sz) {
  return plan.centre + plan.axes * (Eigen::Vector3d(sx, sy, sz) * plan.size / 2);
}

// The five poses of a cube of edge `size` (the plan's centre and axes) reached
// from `start` (P1's readings first, each other pose from P1's), or false.
bool place_poses(const DeviceModel& model, const Eigen::VectorXd& start, const Frame<double>& at,
                 IsoCubePlan& plan) {
  // P2 .. P5: 10 % of the plane's diagonal from the corners C1, C2, C7, C8,
  // i.e. 0.9 a corner + 0.1 the opposite one.
  const Eigen::Vector3d c1 = corner(plan, -1, -1, -1), c2 = corner(plan, 1, -1, -1),
                        c7 = corner(plan, 1, 1, 1), c8 = corner(plan, -1, 1, 1);
  const Eigen::Vector3d points[5] = {plan.centre, 0.9 * c1 + 0.1 * c7, 0.9 * c2 + 0.1 * c8,
                                     0.9 * c7 + 0.1 * c1, 0.9 * c8 + 0.1 * c2};
  plan.poses.clear();
  Eigen::VectorXd from = start;
  for (int k = 0; k < 5; ++k) {
    const Frame<double> target{at.R, points[k]};
    const std::optional<Eigen::VectorXd> q = reach_pose(model, from, target, plan.orientation_held);
    if (!q) return false;
    plan.poses.push_back({fmt::format("P{}", k + 1), target, *q});
    if (k == 0) from = *q;
  }
  return true;
}

}  // namespace

std::optional<Eigen::VectorXd> reach_pose(const DeviceModel& model, const Eigen::VectorXd& start,
                                          const Frame<double>& target, bool orientation) {
  InverseOptions options;
  options.orientation = orientation;
  options.position_tolerance = options.rotation_tolerance = kReached;
  options.rotation_scale = kLengthScale;
  options.max_iterations = 300;
  Eigen::VectorXd q(model.dof());
  const InverseResult found =
      inverse_kinematics(PreparedModel(model), target, start.data(), q.data(), options);
  if (found.status == InverseStatus::kNotConverged || !q.allFinite()) return std::nullopt;
  return within_limits(model, q) ? std::optional<Eigen::VectorXd>(q) : std::nullopt;
}

IsoCubePlan plan_iso_cube(const DeviceModel& model, const IsoCubeOptions& options) {
  if (model.dof() == 0) throw InputError("--iso9283: the model has no joints");
  if (model.tree()) throw InputError("--iso9283: a tree has several tips; give --tip one");
  if (options.cycles < 1) throw InputError("--cycles: at least 1");
  if (options.centre && !(options.centre->cwiseAbs().maxCoeff() <= kMaxCubeCentre)) {
    const Eigen::Vector3d& c = *options.centre;
    throw InputError(fmt::format(
        "--cube-centre: ({:.6g}, {:.6g}, {:.6g}) m: each coordinate within +-{:g} m (metres, in "
        "the measurement frame)",
        c.x(), c.y(), c.z(), kMaxCubeCentre));
  }
  Eigen::VectorXd middle(model.dof());
  for (int i = 0; i < model.dof(); ++i) {
    const Link& l = model.links[i];
    middle[i] = l.continuous() ? 0.0 : (l.lower + l.upper) / 2;
  }
  const PreparedModel prepared(model);
  const Frame<double> at_middle = prepared.forward(middle.data());
  IsoCubePlan plan;
  plan.cycles = options.cycles;
  plan.orientation_held = model.dof() >= 6;
  const ChainStructure s = model.structure();
  plan.axes = base_frame(s, model.kinematic_parameters().data()).R;
  plan.centre = options.centre ? *options.centre : at_middle.p;
  // The centre's orientation: the middle readings', reached at a given centre.
  Frame<double> at = at_middle;
  at.p = plan.centre;
  std::optional<Eigen::VectorXd> centre_q = reach_pose(model, middle, at, plan.orientation_held);
  if (!centre_q) {
    throw InputError(
        fmt::format("--cube-centre: the tool cannot reach ({:.1f}, {:.1f}, {:.1f}) mm {}within the "
                    "joint limits",
                    plan.centre.x() * 1e3, plan.centre.y() * 1e3, plan.centre.z() * 1e3,
                    plan.orientation_held ? "at the middle readings' orientation " : ""));
  }
  if (options.size) {
    plan.size = *options.size;
    if (!(plan.size > 0) || !place_poses(model, *centre_q, at, plan)) {
      throw InputError(fmt::format(
          "--cube-size: a cube of {:.1f} mm about ({:.1f}, {:.1f}, {:.1f}) mm leaves a test pose "
          "outside the joint limits or the reach",
          plan.size * 1e3, plan.centre.x() * 1e3, plan.centre.y() * 1e3, plan.centre.z() * 1e3));
    }
  } else {
    // The largest edge: doubled from 10 mm while the poses are reached, then halved
    // between the last that was and the first that was not, to 0.1 mm.
    double good = 0, bad = 0.01;
    while (bad < 10) {
      plan.size = bad;
      if (!place_poses(model, *centre_q, at, plan)) break;
      good = bad;
      bad *= 2;
    }
    while (bad - good > 1e-4) {
      plan.size = (good + bad) / 2;
      (place_poses(model, *centre_q, at, plan) ? good : bad) = plan.size;
    }
    plan.size = good;
    if (!(good >= 0.01) || !place_poses(model, *centre_q, at, plan)) {
      throw InputError(
          "--iso9283: no cube of 10 mm or more about the centre keeps its test poses within "
          "the joint limits; give --cube-centre elsewhere");
    }
  }
  for (const auto& [sx, sy, sz] : {std::array<double, 3>{-1, -1, -1},
                                   {1, -1, -1},
                                   {1, 1, -1},
                                   {-1, 1, -1},
                                   {-1, -1, 1},
                                   {1, -1, 1},
                                   {1, 1, 1},
                                   {-1, 1, 1}})
    plan.corners.push_back(corner(plan, sx, sy, sz));
  return plan;
}

}  // namespace hapticcal
