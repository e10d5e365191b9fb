// A tree as one model (DeviceModel::tree): the chains of a URDF to several tips
// as one set of links, each with its parent, and one tool a tip. Each tip's
// kinematics against orocos KDL's chain to that tip read from the URDF by
// urdfdom; its parameters against the chains' (identification/tree.hpp).
#include <gtest/gtest.h>

#include <kdl/chainfksolverpos_recursive.hpp>
#include <map>
#include <random>

#include "hapticcal/core/files.hpp"
#include "hapticcal/identification/tree.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/urdf.hpp"
#include "kdl_urdf.hpp"

namespace hapticcal {
namespace {

const std::string kTwoArm = HAPTICCAL_SOURCE_DIR "/examples/two-arm/two_arm.urdf";
const std::vector<std::string> kHands{"left_hand", "right_hand"};

DeviceTree two_arm_tree() { return load_tree(kTwoArm, kHands); }

// Tip k's frame at the tree's joint values `q` (its path's values in order).
Frame<double> tip_frame(const DeviceModel& m, int tip, const Eigen::VectorXd& q) {
  const std::vector<int> path = m.path(tip);
  Eigen::VectorXd joint(static_cast<Eigen::Index>(path.size()));
  for (size_t i = 0; i < path.size(); ++i) joint[static_cast<Eigen::Index>(i)] = q[path[i]];
  const Eigen::VectorXd params = m.kinematic_parameters();
  return forward_kinematics(m.structure(tip), params.data(), joint.data());
}

TEST(TreeModel, LinksParentsAndTips) {
  const DeviceModel m = tree_model(two_arm_tree());
  ASSERT_TRUE(m.tree());
  ASSERT_EQ(m.tips(), 2);
  ASSERT_EQ(m.dof(), 11);
  EXPECT_EQ(m.tip_name(0), "left_hand");
  EXPECT_EQ(m.tip_name(1), "right_hand");
  // The torso (0..2), the left arm below it (3..6), the right arm below the
  // torso too (7..10).
  EXPECT_EQ(m.path(0), (std::vector<int>{0, 1, 2, 3, 4, 5, 6}));
  EXPECT_EQ(m.path(1), (std::vector<int>{0, 1, 2, 7, 8, 9, 10}));
  EXPECT_EQ(m.links[7].name, "r_shoulder_pitch");
  // A chain is a tree with one tip: its path is every link, its structure the whole.
  const DeviceModel chain = two_arm_tree().chains[0];
  EXPECT_FALSE(chain.tree());
  EXPECT_EQ(chain.path(0).size(), 7u);
  EXPECT_EQ(chain.structure(0).num_slots(), chain.structure().num_slots());
  EXPECT_EQ(chain.tool_slot(0), chain.structure().tool_slot());
}

// Each tip's forward kinematics against KDL's chain to that tip, on the
// nominal tree and on one whose every slot is moved (the moved model's frames
// against the chains moved the same, by parameter name).
TEST(TreeModel, EachTipMatchesKdlAndTheChains) {
  const DeviceTree tree = two_arm_tree();
  const DeviceModel m = tree_model(tree);
  const std::string urdf = read_file(kTwoArm, FileKind::kUrdf);
  std::mt19937_64 rng(41);
  std::uniform_real_distribution<double> uniform(-1.2, 1.2);
  for (int tip = 0; tip < 2; ++tip) {
    KDL::Chain chain = testing::kdl_chain_from_urdf(urdf, "pelvis", kHands[tip]);
    KDL::ChainFkSolverPos_recursive fk(chain);
    ASSERT_EQ(chain.getNrOfJoints(), m.path(tip).size());
    for (int trial = 0; trial < 20; ++trial) {
      Eigen::VectorXd q(m.dof());
      for (int j = 0; j < m.dof(); ++j) q[j] = uniform(rng);
      const std::vector<int> path = m.path(tip);
      KDL::JntArray kq(static_cast<unsigned>(path.size()));
      for (size_t i = 0; i < path.size(); ++i) kq(static_cast<unsigned>(i)) = q[path[i]];
      KDL::Frame kf;
      ASSERT_GE(fk.JntToCart(kq, kf), 0);
      const Frame<double> f = tip_frame(m, tip, q);
      for (int x = 0; x < 3; ++x) EXPECT_NEAR(f.p[x], kf.p(x), 1e-12) << tip;
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(f.R(r, c), kf.M(r, c), 1e-12);
    }
  }

  // Move every slot; the chains moved by name give the same tips.
  DeviceModel moved = m;
  DeviceTree moved_tree = tree;
  Eigen::VectorXd v = m.kinematic_parameters();
  std::normal_distribution<double> gauss(0.0, 1e-2);
  for (Eigen::Index k = 0; k < v.size(); ++k) v[k] += gauss(rng);
  moved.set_kinematic_parameters(v);
  EXPECT_EQ(moved.kinematic_parameters(), v);
  std::map<std::string, double> by_name;
  const std::vector<ParameterInfo> info = moved.parameter_info();
  ASSERT_EQ(info.size(), tree.parameters.size());
  for (const ParameterInfo& p : info) by_name[p.name] = v[p.slot];
  Eigen::VectorXd tv = moved_tree.values();
  for (const ParameterInfo& p : tree.parameters) {
    ASSERT_TRUE(by_name.count(p.name)) << p.name;
    tv[p.slot] = by_name[p.name];
  }
  moved_tree.set_values(tv);
  for (int tip = 0; tip < 2; ++tip) {
    const PreparedModel chain(moved_tree.chains[static_cast<size_t>(tip)]);
    for (int trial = 0; trial < 10; ++trial) {
      Eigen::VectorXd q(m.dof());
      for (int j = 0; j < m.dof(); ++j) q[j] = uniform(rng);
      const Eigen::VectorXd qc = moved_tree.chain_reading(q, tip);
      const Frame<double> want = chain.forward(qc.data());
      const Frame<double> got = tip_frame(moved, tip, q);
      EXPECT_LT((got.p - want.p).norm(), 1e-12);
      EXPECT_LT((got.R - want.R).norm(), 1e-12);
    }
  }
}

}  // namespace
}  // namespace hapticcal
