// The device model: a value holding the kinematic parameters, joint limits and
// transmissions of a serial chain (SPEC sections 1 and 5).
#pragma once

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "hapticcal/transmission.hpp"

namespace hapticcal {

// Standard DH with the Hayati beta (paper eq. 3):
//   A_i = Rz(theta_i) * T(a_i, 0, d_i) * Rx(alpha_i) * Ry(beta_i)
// Modified DH (Craig 1989, eq. 3.6), with a Hayati beta about the y axis at the
// foot of the new joint axis (zero: Craig's transform):
//   A_i = Rx(alpha_i) * Tx(a_i) * Ry(beta_i) * Rz(theta_i) * Tz(d_i)
// beta is what a small tilt of a joint axis parallel to its neighbour needs: the
// four DH parameters cannot express it (Hayati 1983).
enum class Convention { kDh, kMdh };
// The base transform B: a DH link without joint (paper's frame "w") or a pose.
enum class BaseKind { kDh, kPose };

struct Link {
  std::string name;
  double a = 0.0, alpha = 0.0, d = 0.0;
  double theta = 0.0;               // joint offset theta_offset_i [rad]
  double beta = 0.0;                // Hayati parameter [rad]
  double lower = 0.0, upper = 0.0;  // joint limits on q [rad]
  Transmission transmission;
};

// Layout of the flat kinematic parameter vector used by the generic kinematics:
//   base: 6 slots  (DH: a, alpha, d, theta, -, -;  pose: x, y, z, roll, pitch, yaw)
//   link: 5 slots each (a, alpha, d, theta, beta)
//   tool: 6 slots  (x, y, z, roll, pitch, yaw)
// Slots without meaning (base DH slots 4-5) must stay zero.
constexpr int kBaseSlots = 6;
constexpr int kLinkSlots = 5;
constexpr int kToolSlots = 6;
constexpr int kLinkA = 0, kLinkAlpha = 1, kLinkD = 2, kLinkTheta = 3, kLinkBeta = 4;

// What the generic kinematics need besides the parameter values.
struct ChainStructure {
  Convention convention = Convention::kDh;
  BaseKind base_kind = BaseKind::kPose;
  int dof = 0;
  int num_slots() const { return kBaseSlots + kLinkSlots * dof + kToolSlots; }
  int link_slot(int i) const { return kBaseSlots + kLinkSlots * i; }  // i zero-based
  int tool_slot() const { return kBaseSlots + kLinkSlots * dof; }
};

enum class ParameterUnit { kLength, kAngle };

// One meaningful kinematic parameter: its stable dotted name ("base.a",
// "j3.alpha", "tool.x") and its slot in the flat vector.
struct ParameterInfo {
  std::string name;
  int slot = 0;
  ParameterUnit unit = ParameterUnit::kLength;
};

struct DeviceModel {
  std::string name;
  Convention convention = Convention::kDh;
  BaseKind base_kind = BaseKind::kPose;
  std::array<double, 6> base{};  // see the slot layout above
  std::vector<Link> links;
  std::array<double, 6> tool{};  // x, y, z, roll, pitch, yaw

  int dof() const { return static_cast<int>(links.size()); }
  ChainStructure structure() const { return {convention, base_kind, dof()}; }

  // The flat kinematic parameter vector and its inverse.
  Eigen::VectorXd kinematic_parameters() const;
  void set_kinematic_parameters(const Eigen::VectorXd& params);
  // The meaningful slots, in slot order, with their dotted names.
  std::vector<ParameterInfo> parameter_info() const;

  // Joint angles theta_i = q_i + dtheta_i(q_i) + theta_offset_i are formed by the
  // kinematics; this returns q_i + dtheta_i(q_i), the angle without the offset.
  Eigen::VectorXd compensate(const Eigen::VectorXd& q) const;
};

}  // namespace hapticcal
