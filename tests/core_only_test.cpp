// Links hapticcal_core alone (no Ceres, yaml-cpp, JSON or urdfdom): what a 1 kHz
// controller links. The build of this test is the check that the core needs
// nothing else; its assertion compares the prepared and the generic kinematics.
#include <gtest/gtest.h>

#include <cmath>

#include "hapticcal/kinematics/kinematics.hpp"

namespace hapticcal {
namespace {

TEST(CoreOnly, PreparedKinematicsWithTransmissionsNeedOnlyTheCore) {
  DeviceModel m;
  m.name = "core";
  for (int i = 0; i < 3; ++i) {
    Link l;
    l.name = "j" + std::to_string(i + 1);
    l.geometry = i == 1 ? Geometry::kOrigin : Geometry::kMdh;
    l.a = 0.1 * i;
    l.alpha = 0.3;
    l.d = 0.05;
    l.origin = {0.02, 0.1, 0.03, 0.2, -0.1, 0.3};
    l.lower = -2;
    l.upper = 2;
    if (i == 2) l.transmission = Transmission(Capstan{10, 0.005, 0, 1e-3, 1e-4, 0.1, 1e-4, 0.2});
    m.links.push_back(l);
  }
  const PreparedModel prepared(m);
  const double q[3] = {0.3, -0.7, 1.1};
  const Eigen::VectorXd joint = m.compensate(Eigen::Vector3d(q[0], q[1], q[2]));
  const Eigen::VectorXd params = m.kinematic_parameters();
  const Frame<double> a = prepared.forward(q);
  const Frame<double> b = forward_kinematics(m.structure(), params.data(), joint.data());
  EXPECT_LT((a.p - b.p).norm() + (a.R - b.R).norm(), 1e-12);
  EXPECT_GT(std::abs(joint[2] - q[2]), 0);  // the capstan's error is applied
}

}  // namespace
}  // namespace hapticcal
