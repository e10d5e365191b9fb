// Builds an orocos KDL chain equal to a device model's kinematics (without
// transmissions: KDL takes the joint angles q + dtheta(q)). KDL is the
// independent reference of the kinematics tests and benchmarks.
#pragma once

#include <kdl/chain.hpp>
#include <kdl/frames.hpp>
#include <kdl/jacobian.hpp>

#include "hapticcal/frame.hpp"
#include "hapticcal/model.hpp"

namespace hapticcal::testing {

inline KDL::Frame kdl_pose(const std::array<double, 6>& v) {
  // KDL's RPY: rotations about the fixed X, Y, Z axes = Rz(yaw) Ry(pitch) Rx(roll).
  return KDL::Frame(KDL::Rotation::RPY(v[3], v[4], v[5]), KDL::Vector(v[0], v[1], v[2]));
}

inline KDL::Chain kdl_chain(const DeviceModel& m) {
  KDL::Chain chain;
  const KDL::Frame base = m.base_kind == BaseKind::kDh
                              ? KDL::Frame::DH(m.base[0], m.base[1], m.base[2], m.base[3])
                              : kdl_pose(m.base);
  chain.addSegment(KDL::Segment("base", KDL::Joint(KDL::Joint::None), base));
  for (const Link& l : m.links) {
    if (l.geometry == Geometry::kDh) {
      // Rz(q) * Rz(theta) Tz(d) Tx(a) Rx(alpha) * Ry(beta)
      chain.addSegment(KDL::Segment(
          l.name, KDL::Joint(KDL::Joint::RotZ),
          KDL::Frame::DH(l.a, l.alpha, l.d, l.theta) * KDL::Frame(KDL::Rotation::RotY(l.beta))));
    } else {
      // Rx(alpha) Tx(a) Ry(beta), then Rz(q) * Rz(theta) Tz(d)
      chain.addSegment(KDL::Segment(
          l.name + "_fixed", KDL::Joint(KDL::Joint::None),
          KDL::Frame::DH_Craig1989(l.a, l.alpha, 0, 0) * KDL::Frame(KDL::Rotation::RotY(l.beta))));
      chain.addSegment(KDL::Segment(l.name, KDL::Joint(KDL::Joint::RotZ),
                                    KDL::Frame::DH_Craig1989(0, 0, l.d, l.theta)));
    }
  }
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

}  // namespace hapticcal::testing
