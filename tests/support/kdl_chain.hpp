// Builds an orocos KDL chain equal to a device model's kinematics (without
// transmissions: KDL takes the joint angles q + dtheta(q)). KDL is the
// independent reference of the kinematics tests and benchmarks: every geometry
// (DH, MDH, URDF origin + axis) and joint type (revolute, continuous, prismatic)
// is built from KDL's own frames and joints, not from hapticcal's.
#pragma once

#include <kdl/chain.hpp>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainjnttojacsolver.hpp>
#include <kdl/frames.hpp>
#include <kdl/jacobian.hpp>
#include <stdexcept>

#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model/frame.hpp"
#include "hapticcal/model/model.hpp"

namespace hapticcal::testing {

inline KDL::Frame kdl_pose(const std::array<double, 6>& v) {
  // KDL's RPY: rotations about the fixed X, Y, Z axes = Rz(yaw) Ry(pitch) Rx(roll).
  return KDL::Frame(KDL::Rotation::RPY(v[3], v[4], v[5]), KDL::Vector(v[0], v[1], v[2]));
}

// A KDL segment turns or slides by its joint first, then applies its tip
// frame: pose(q) * f_tip.
inline KDL::Joint kdl_z_joint(const Link& l) {
  return KDL::Joint(l.name, l.prismatic() ? KDL::Joint::TransZ : KDL::Joint::RotZ);
}

inline void add_link(KDL::Chain& chain, const Link& l) {
  const KDL::Frame beta(KDL::Rotation::RotY(l.beta));
  if (l.geometry == Geometry::kDh) {
    // Revolute: Rz(q) * Rz(theta) Tz(d) Tx(a) Rx(alpha) * Ry(beta).
    // Prismatic: Tz(q) * the same, = Rz(theta) Tz(d + q) Tx(a) Rx(alpha) Ry(beta).
    chain.addSegment(
        KDL::Segment(l.name, kdl_z_joint(l), KDL::Frame::DH(l.a, l.alpha, l.d, l.theta) * beta));
  } else if (l.geometry == Geometry::kMdh) {
    // Rx(alpha) Tx(a) Ry(beta), then Rz(q) or Tz(q) * Rz(theta) Tz(d).
    chain.addSegment(KDL::Segment(l.name + "_fixed", KDL::Joint(KDL::Joint::None),
                                  KDL::Frame::DH_Craig1989(l.a, l.alpha, 0, 0) * beta));
    chain.addSegment(
        KDL::Segment(l.name, kdl_z_joint(l), KDL::Frame::DH_Craig1989(0, 0, l.d, l.theta)));
  } else {
    // URDF: the fixed origin frame and the offset's motion, then a joint about /
    // along the axis through the origin. (A KDL joint's own offset would cancel:
    // KDL::Segment stores joint.pose(0)^-1 * f_tip, the tip at the joint's zero.)
    const KDL::Vector axis(l.axis[0], l.axis[1], l.axis[2]);
    const KDL::Frame offset = l.prismatic() ? KDL::Frame(axis * l.offset)
                                            : KDL::Frame(KDL::Rotation::Rot2(axis, l.offset));
    chain.addSegment(KDL::Segment(l.name + "_origin", KDL::Joint(KDL::Joint::None),
                                  kdl_pose(l.origin) * offset));
    const KDL::Joint::JointType type = l.prismatic() ? KDL::Joint::TransAxis : KDL::Joint::RotAxis;
    chain.addSegment(KDL::Segment(l.name, KDL::Joint(l.name, KDL::Vector::Zero(), axis, type)));
  }
}

inline KDL::Chain kdl_chain(const DeviceModel& m) {
  KDL::Chain chain;
  const KDL::Frame base = m.base_kind == BaseKind::kDh
                              ? KDL::Frame::DH(m.base[0], m.base[1], m.base[2], m.base[3])
                              : kdl_pose(m.base);
  chain.addSegment(KDL::Segment("base", KDL::Joint(KDL::Joint::None), base));
  for (const Link& l : m.links) add_link(chain, l);
  chain.addSegment(KDL::Segment("tool", KDL::Joint(KDL::Joint::None), kdl_pose(m.tool)));
  return chain;
}

inline Frame<double> from_kdl(const KDL::Frame& f) {
  Frame<double> out;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out.R(r, c) = f.M(r, c);
    out.p[r] = f.p[r];
  }
  return out;
}

// KDL's tool frame and Jacobians at the joint values: the reference point at
// the chain's end, expressed in its base (here the measurement) frame, and with
// changeBase(R^T) in the tool frame. Throws if a solver fails.
struct KdlSolution {
  Frame<double> T;
  Jacobian6<double> J, J_tool;  // JacobianFrame::kMeasurement, kTool
};
inline KdlSolution kdl_solve(KDL::ChainFkSolverPos_recursive& fk,
                             KDL::ChainJntToJacSolver& jacobian, const Eigen::VectorXd& joint) {
  const int n = static_cast<int>(joint.size());
  KDL::JntArray kq(n);
  for (int i = 0; i < n; ++i) kq(i) = joint[i];
  KDL::Frame kf;
  KDL::Jacobian kj(n), kjt(n);
  if (fk.JntToCart(kq, kf) < 0 || jacobian.JntToJac(kq, kj) < 0) {
    throw std::runtime_error("a KDL solver failed");
  }
  KDL::changeBase(kj, kf.M.Inverse(), kjt);
  KdlSolution out{from_kdl(kf), Jacobian6<double>(6, n), Jacobian6<double>(6, n)};
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < n; ++c) {
      out.J(r, c) = kj(r, c);
      out.J_tool(r, c) = kjt(r, c);
    }
  }
  return out;
}

}  // namespace hapticcal::testing
