// A tree as one model (DeviceModel::tree): the chains of a URDF to several tips
// as one set of links, each with its parent, and one tool a tip. Each tip's
// kinematics against orocos KDL's chain to that tip read from the URDF by
// urdfdom; its parameters against the chains' (identification/tree.hpp).
#include <gtest/gtest.h>

#include <kdl/chainfksolverpos_recursive.hpp>
#include <map>
#include <random>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/identification/tree.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/model_io/urdf.hpp"
#include "held_out.hpp"
#include "identification/problem/stack.hpp"
#include "kdl_urdf.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

// The chains' parameters and readings by the tree's slots and joints (its
// slot_of and joint_of), the reference tree_model is checked against.
Eigen::VectorXd tree_values(const DeviceTree& tree) {
  Eigen::VectorXd out(tree.num_slots());
  for (size_t c = 0; c < tree.chains.size(); ++c) {
    const Eigen::VectorXd v = tree.chains[c].kinematic_parameters();
    for (Eigen::Index k = 0; k < v.size(); ++k) out[tree.slot_of[c][static_cast<size_t>(k)]] = v[k];
  }
  return out;
}

void set_tree_values(DeviceTree& tree, const Eigen::VectorXd& values) {
  for (size_t c = 0; c < tree.chains.size(); ++c) {
    const std::vector<int>& map = tree.slot_of[c];
    Eigen::VectorXd v(static_cast<Eigen::Index>(map.size()));
    for (size_t k = 0; k < map.size(); ++k) v[static_cast<Eigen::Index>(k)] = values[map[k]];
    tree.chains[c].set_kinematic_parameters(v);
  }
}

Eigen::VectorXd chain_reading(const DeviceTree& tree, const Eigen::VectorXd& reading, int chain) {
  const std::vector<int>& map = tree.joint_of[static_cast<size_t>(chain)];
  Eigen::VectorXd out(static_cast<Eigen::Index>(map.size()));
  for (size_t k = 0; k < map.size(); ++k) out[static_cast<Eigen::Index>(k)] = reading[map[k]];
  return out;
}

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
  // The prepared model of a tree: its readings compensated as a chain's, its
  // first tip's pose by forward(q) and forward(q, 0).
  const PreparedModel prepared(m);
  Eigen::VectorXd q = Eigen::VectorXd::Constant(m.dof(), 0.3), joint(m.dof());
  prepared.compensate(q.data(), joint.data());
  EXPECT_EQ(joint, q);
  EXPECT_EQ(prepared.tips(), 2);
  EXPECT_EQ(prepared.forward(q.data()).p, prepared.forward(q.data(), 0).p);
  EXPECT_THROW(prepared.forward(q.data(), 2), std::out_of_range);
  EXPECT_THROW(prepared.forward(q.data(), -1), std::out_of_range);
  Jacobian6<double> J(6, m.dof());
  EXPECT_THROW(prepared.forward_jacobian(q.data(), 2, JacobianFrame::kMeasurement, J.data()),
               std::out_of_range);
  // A device file holds the tree (its parents and tips); a URDF written from a
  // model holds one chain: a tree is refused, not written as the chain
  // through every link.
  EXPECT_EQ(check_device(m), "");
  EXPECT_EQ(parse_device(device_to_yaml(m), "tree.yaml").parents, m.parents);
  EXPECT_THROW(device_to_urdf(m), InputError);
  EXPECT_EQ(check_device(chain), "");
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
  const PreparedModel prepared(m);  // every link's frame once, then the tip's
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
      const Frame<double> g = prepared.forward(q.data(), tip);
      for (int x = 0; x < 3; ++x) {
        EXPECT_NEAR(f.p[x], kf.p(x), 1e-12) << tip;
        EXPECT_NEAR(g.p[x], kf.p(x), 1e-12) << tip;
      }
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) {
          EXPECT_NEAR(f.R(r, c), kf.M(r, c), 1e-12);
          EXPECT_NEAR(g.R(r, c), kf.M(r, c), 1e-12);
        }
      }
    }
  }

  // Each tip's Jacobian against central differences of its pose in the joint
  // values; the joints off its path move nothing.
  for (int tip = 0; tip < 2; ++tip) {
    Eigen::VectorXd q(m.dof());
    for (int j = 0; j < m.dof(); ++j) q[j] = uniform(rng);
    Jacobian6<double> J(6, m.dof());
    const Frame<double> f =
        prepared.forward_jacobian(q.data(), tip, JacobianFrame::kMeasurement, J.data());
    const double h = 1e-6;
    for (int j = 0; j < m.dof(); ++j) {
      Eigen::VectorXd plus = q, minus = q;
      plus[j] += h;
      minus[j] -= h;
      const Frame<double> a = prepared.forward(plus.data(), tip),
                          b = prepared.forward(minus.data(), tip);
      const Eigen::Vector3d dp = (a.p - b.p) / (2 * h);
      const Eigen::Matrix3d dR = (a.R - b.R) / (2 * h) * f.R.transpose();
      const Eigen::Vector3d w(dR(2, 1), dR(0, 2), dR(1, 0));
      EXPECT_LT((J.col(j).head<3>() - dp).norm(), 1e-8) << tip << " " << j;
      EXPECT_LT((J.col(j).tail<3>() - w).norm(), 1e-8) << tip << " " << j;
    }
  }

  // tip_chain: each tip's chain as a model of its own, the same kinematics.
  for (int tip = 0; tip < 2; ++tip) {
    const DeviceModel chain = tip_chain(m, tip);
    EXPECT_FALSE(chain.tree());
    ASSERT_EQ(chain.dof(), 7);
    const PreparedModel prepared(chain);
    Eigen::VectorXd q(m.dof());
    for (int j = 0; j < m.dof(); ++j) q[j] = uniform(rng);
    const std::vector<int> path = m.path(tip);
    Eigen::VectorXd qc(7);
    for (int i = 0; i < 7; ++i) qc[i] = q[path[static_cast<size_t>(i)]];
    EXPECT_LT((prepared.forward(qc.data()).p - tip_frame(m, tip, q).p).norm(), 1e-12);
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
  Eigen::VectorXd tv = tree_values(moved_tree);
  for (const ParameterInfo& p : tree.parameters) {
    ASSERT_TRUE(by_name.count(p.name)) << p.name;
    tv[p.slot] = by_name[p.name];
  }
  set_tree_values(moved_tree, tv);
  for (int tip = 0; tip < 2; ++tip) {
    const PreparedModel chain(moved_tree.chains[static_cast<size_t>(tip)]);
    for (int trial = 0; trial < 10; ++trial) {
      Eigen::VectorXd q(m.dof());
      for (int j = 0; j < m.dof(); ++j) q[j] = uniform(rng);
      const Eigen::VectorXd qc = chain_reading(moved_tree, q, tip);
      const Frame<double> want = chain.forward(qc.data());
      const Frame<double> got = tip_frame(moved, tip, q);
      EXPECT_LT((got.p - want.p).norm(), 1e-12);
      EXPECT_LT((got.R - want.R).norm(), 1e-12);
    }
  }
}

// The tree moved by 1 mm / 2 mrad (sd) in every joint and tool slot, its base
// the tracker's frame: a truth, as the chains (DeviceTree, each its own
// DeviceModel) and as one model.
struct Truth {
  DeviceTree chains;
  DeviceModel model;
};
Truth truth(std::uint64_t seed) {
  Truth t{two_arm_tree(), {}};
  Eigen::VectorXd v = tree_values(t.chains);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  for (const ParameterInfo& p : t.chains.parameters) {
    if (p.block == ParameterBlock::kBase) continue;
    v[p.slot] += (p.unit == ParameterUnit::kLength ? 1e-3 : 2e-3) * gauss(rng);
  }
  v.head<6>() << 1.2, -0.4, 0.3, 0.05, -0.1, 2.0;
  set_tree_values(t.chains, v);
  t.model = tree_model(t.chains);
  return t;
}

// Random poses and each hand's point (x1.. the first tip, x2.. the second) from
// the chains' own kinematics, noise sd `sigma` a coordinate.
Log hands_log(const DeviceTree& chains, int rows, double sigma, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(-1.3, 1.3);
  Log log = testing::blank_marker_log("hands.csv", rows, chains.dof(), 2);
  for (int r = 0; r < rows; ++r) {
    for (int j = 0; j < chains.dof(); ++j) log.q(r, j) = uniform(rng);
    for (int c = 0; c < 2; ++c) {
      const PreparedModel chain(chains.chains[static_cast<size_t>(c)]);
      const Eigen::VectorXd q = chain_reading(chains, log.q.row(r).transpose(), c);
      const Eigen::Vector3d p = chain.forward(q.data()).p;
      for (int x = 0; x < 3; ++x) log.markers(r, 3 * c + x) = p[x] + sigma * gauss(rng);
    }
  }
  return log;
}

// A tree log as one sample a tip; the tree's problem (the chain's pipeline:
// kinematic_problem, its rows): each sample's residual the chains' prediction
// minus the point, and the Jacobian against central differences.
TEST(TreeModel, TheChainsProblemHoldsATree) {
  const Truth t = truth(7);
  const DeviceModel nominal = tree_model(two_arm_tree());
  const Log log = hands_log(t.chains, 15, 0.0, 8);
  const Log samples = tip_samples(nominal, log);
  ASSERT_EQ(samples.rows, 30);
  EXPECT_EQ(samples.tip[3], 1);
  EXPECT_EQ(samples.line[3], log.line[1]);
  const KinematicProblem problem = kinematic_problem(nominal, samples, {}, CalibrationOptions{});
  ASSERT_TRUE(problem.tip.has_value());
  const ChainStructure s = nominal.structure();
  const detail::RowsOf rows = detail::rows_of(problem);

  // At the truth's vector every residual is zero; at the nominal's, the
  // nominal chains' points minus the truth's.
  const Eigen::VectorXd v = t.model.kinematic_parameters();
  const detail::Stack at = detail::stack(s, v, problem.joints, rows, problem.measured, {});
  ASSERT_EQ(at.r.size(), 90);
  EXPECT_LT(at.r.cwiseAbs().maxCoeff(), 1e-12);
  const DeviceTree nominal_chains = two_arm_tree();
  const Eigen::VectorXd r = detail::residuals_at(s, nominal.kinematic_parameters(), problem.joints,
                                                 rows, problem.measured, {});
  for (int i = 0; i < samples.rows; ++i) {
    const int c = samples.tip[static_cast<size_t>(i)];
    const PreparedModel chain(nominal_chains.chains[static_cast<size_t>(c)]);
    const Eigen::VectorXd q = chain_reading(nominal_chains, samples.q.row(i).transpose(), c);
    const Eigen::Vector3d want = chain.forward(q.data()).p - samples.position.row(i).transpose();
    EXPECT_LT((r.segment<3>(3 * i) - want).norm(), 1e-12) << i;
  }

  // Columns: central differences; a left-arm joint moves only the left hand's
  // samples, a torso joint both.
  for (Eigen::Index k = 0; k < v.size(); ++k) {
    const double h = 1e-6;
    Eigen::VectorXd up = v, down = v;
    up[k] += h;
    down[k] -= h;
    const Eigen::VectorXd numeric =
        (detail::residuals_at(s, up, problem.joints, rows, problem.measured, {}) -
         detail::residuals_at(s, down, problem.joints, rows, problem.measured, {})) /
        (2 * h);
    EXPECT_LT((at.J.col(k) - numeric).norm(), 1e-6 * std::max(1.0, numeric.norm())) << k;
  }
  const int left = s.link_slot(3), torso = s.link_slot(0);
  double left_on_right = 0, torso_on_right = 0;
  for (int i = 0; i < samples.rows; ++i) {
    if (samples.tip[static_cast<size_t>(i)] != 1) continue;
    left_on_right += at.J.block(3 * i, left, 3, kOriginSlots).norm();
    torso_on_right += at.J.block(3 * i, torso, 3, kOriginSlots).norm();
  }
  EXPECT_EQ(left_on_right, 0.0);
  EXPECT_GT(torso_on_right, 0.0);

  // Held out together: a pose's two hands in one fold, 15 units; a chain's
  // folds are its poses'.
  EXPECT_EQ(detail::pose_units(problem).back(), 14);
  const std::vector<int> folds = detail::unit_folds(problem, 5, 1);
  const std::vector<int> of_pose = pose_folds(15, 5, 1);
  for (int i = 0; i < samples.rows; ++i) EXPECT_EQ(folds[i], of_pose[i / 2]) << i;
  const DeviceModel left_arm = two_arm_tree().chains[0];
  Log chain_samples = chain_log(two_arm_tree(), log, 0);
  const KinematicProblem chain =
      kinematic_problem(left_arm, chain_samples, {}, CalibrationOptions{});
  EXPECT_EQ(detail::unit_folds(chain, 5, 1), pose_folds(15, 5, 1));
}

// A tree model takes a log of one sample a tip, each naming one of its tips;
// a malformed tree is refused before anything indexes by it.
TEST(TreeModel, LogsAndTreesThatDoNotFitAreRefused) {
  const DeviceModel m = tree_model(two_arm_tree());
  const Log log = hands_log(two_arm_tree(), 10, 0.0, 3);
  try {
    calibrate(m, log, CalibrationOptions{});  // the raw log: two points a row, no tips
    FAIL() << "a tree log without tips was calibrated";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("one sample a tip"), std::string::npos) << e.what();
  }
  Log samples = tip_samples(m, log);
  samples.tip[5] = 2;
  try {
    calibrate(m, samples, CalibrationOptions{});
    FAIL() << "a tip beyond the tree's was calibrated";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("tip 2 of a model with 2 tip(s)"), std::string::npos)
        << e.what();
  }
  // tip_samples refuses a log of another number of points.
  Log one = log;
  one.marker_count = 1;
  one.markers.conservativeResize(Eigen::NoChange, 3);
  EXPECT_THROW(tip_samples(m, one), InputError);
  // Malformed trees: a parent after its child, a tip inside another's path.
  DeviceModel bad = m;
  bad.parents[3] = 5;
  EXPECT_NE(tree_problem(bad).find("is not a link before it"), std::string::npos);
  EXPECT_THROW(calibrate(bad, tip_samples(m, log), CalibrationOptions{}), InputError);
  bad = m;
  bad.branches[0].link = 2;  // the torso's last joint: the left arm passes it
  EXPECT_NE(tree_problem(bad).find("another tip ends at or passes"), std::string::npos);
  EXPECT_EQ(tree_problem(m), "");
  EXPECT_EQ(tree_problem(two_arm_tree().chains[0]), "");
}

// RMS position error [m] of a model on a tree's samples (one a tip of each row).
double held_out_rms(const DeviceModel& m, const Log& samples) {
  const KinematicProblem p = kinematic_problem(m, samples, {}, CalibrationOptions{});
  const Eigen::VectorXd r = detail::residuals_at(m.structure(), m.kinematic_parameters(), p.joints,
                                                 detail::rows_of(p), p.measured, {});
  return std::sqrt(r.squaredNorm() / samples.rows);
}

// The chain's whole procedure (calibrate: registration, the plausibility
// check, the rank test, the significance cut, the model search) on a tree's
// samples: 350 poses at 0.1 mm, 150 held out without noise (the error against
// the truth). Within 10 % of plain least squares on the same samples (what
// the tree's separate fit was: 28.1 um on this case), and far below the
// nominal model's.
TEST(TreeModel, CalibrateRunsTheChainsProcedure) {
  const Truth t = truth(11);
  const DeviceModel nominal = tree_model(two_arm_tree());
  const Log log = hands_log(t.chains, 350, 1e-4, 12);
  const CalibrationResult fit = calibrate(nominal, tip_samples(nominal, log), CalibrationOptions{});
  ASSERT_EQ(fit.status, CalibrationStatus::kConverged) << fit.status_reason;
  EXPECT_TRUE(fit.calibrated.tree());
  // The model search holds out poses: a pose's two hands together.
  EXPECT_EQ(fit.kinematics.search.units, 350);
  const Log test = tip_samples(nominal, hands_log(t.chains, 150, 0.0, 13));
  const double after = held_out_rms(fit.calibrated, test);
  CalibrationOptions plain;
  plain.keep_all = true;
  plain.search = false;
  plain.folds = 0;
  const CalibrationResult least_squares = calibrate(nominal, tip_samples(nominal, log), plain);
  ASSERT_EQ(least_squares.status, CalibrationStatus::kConverged);
  const double tree_after = held_out_rms(least_squares.calibrated, test);
  DeviceModel registered = nominal;
  registered.base = fit.calibrated.base;
  EXPECT_LT(after, 1.1 * tree_after) << after << " " << tree_after;
  EXPECT_LT(after, 0.1 * held_out_rms(registered, test));
  EXPECT_LT(after, 5e-5);
}

// Masses on every link of the two-arm tree (the chains carry the same; the
// second chain none on the torso, so that the two chains' torques add up to
// the tree's) and gravity along the pelvis's -z.
void load(DeviceTree& chains) {
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::map<std::string, std::pair<double, Eigen::Vector3d>> mass;
  for (DeviceModel& c : chains.chains) {
    for (Link& l : c.links) {
      if (!mass.count(l.name))
        mass[l.name] = {2 + unit(rng), 0.05 * Eigen::Vector3d(unit(rng), unit(rng), unit(rng))};
      l.mass = mass[l.name].first;
      l.com = mass[l.name].second;
    }
  }
  for (Link& l : chains.chains[1].links) {
    if (l.name.rfind("torso", 0) == 0) l.mass = 0;
  }
}

// A tree joint carries every link below it in the tree: a torso joint both
// arms. Its gravity and lateral torques against the sum of the chains' (each
// on its own chain, the torso's masses counted once), at random poses.
TEST(TreeModel, GravityLoadsEachJointWithItsSubtree) {
  DeviceTree chains = two_arm_tree();
  load(chains);
  DeviceModel m = tree_model(chains);
  for (int i = 0; i < 3; ++i)
    m.links[static_cast<size_t>(i)].mass = chains.chains[0].links[static_cast<size_t>(i)].mass;
  const GravityModel tree(m);
  const GravityModel left(chains.chains[0]), right(chains.chains[1]);
  std::mt19937_64 rng(22);
  std::uniform_real_distribution<double> uniform(-1.2, 1.2);
  for (int trial = 0; trial < 10; ++trial) {
    Eigen::VectorXd q(m.dof());
    for (int j = 0; j < m.dof(); ++j) q[j] = uniform(rng);
    const Eigen::VectorXd ql = chain_reading(chains, q, 0), qr = chain_reading(chains, q, 1);
    std::array<double, kMaxDof> t, tl, tr, lt, ltl, ltr;
    tree.torques(q.data(), t.data());
    left.torques(ql.data(), tl.data());
    right.torques(qr.data(), tr.data());
    tree.lateral_torques(q.data(), lt.data());
    left.lateral_torques(ql.data(), ltl.data());
    right.lateral_torques(qr.data(), ltr.data());
    for (int i = 0; i < m.dof(); ++i) {
      double want = 0, want_lateral = 0;
      for (int c = 0; c < 2; ++c) {
        const std::vector<int>& joints = chains.joint_of[static_cast<size_t>(c)];
        for (size_t k = 0; k < joints.size(); ++k) {
          if (joints[k] != i) continue;
          want += (c == 0 ? tl : tr)[k];
          want_lateral += (c == 0 ? ltl : ltr)[k];
        }
      }
      EXPECT_NEAR(t[static_cast<size_t>(i)], want, 1e-9 * (1 + std::abs(want)))
          << m.links[static_cast<size_t>(i)].name;
      EXPECT_NEAR(lt[static_cast<size_t>(i)], want_lateral, 1e-9 * (1 + std::abs(want_lateral)));
    }
  }
}

// Tip k's point of a tree at readings q, its joints deflected and its links
// bent under gravity (GravityModel::pose_constants on the tree, then tip k's
// chain), noise sd `sigma` a coordinate.
Eigen::Vector3d tip_point(const DeviceModel& m, int tip, const Eigen::VectorXd& q) {
  const GravityModel gravity(m);
  const Eigen::VectorXd joint = m.compensate(q);  // deflected (joint compliance)
  const ChainConstants<double> bent = gravity.pose_constants(q.data());
  const std::vector<int> path = m.path(tip);
  const ChainStructure s = m.structure(tip);
  ChainConstants<double> c;
  c.base = bent.base;
  const Eigen::VectorXd params = m.kinematic_parameters();
  c.tool = tool_frame(s, params.data());
  Eigen::VectorXd on_path(static_cast<Eigen::Index>(path.size()));
  for (size_t i = 0; i < path.size(); ++i) {
    c.links[i] = bent.links[static_cast<size_t>(path[i])];
    on_path[static_cast<Eigen::Index>(i)] = joint[path[i]];
  }
  return forward_kinematics(s, c, on_path.data()).p;
}

Log compliant_log(const DeviceModel& truth, int rows, double sigma, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(-1.3, 1.3);
  Log log = testing::blank_marker_log("hands.csv", rows, truth.dof(), truth.tips());
  for (int r = 0; r < rows; ++r) {
    for (int j = 0; j < truth.dof(); ++j) log.q(r, j) = uniform(rng);
    for (int t = 0; t < truth.tips(); ++t) {
      const Eigen::Vector3d p = tip_point(truth, t, log.q.row(r).transpose());
      for (int x = 0; x < 3; ++x) log.markers(r, 3 * t + x) = p[x] + sigma * gauss(rng);
    }
  }
  return log;
}

// Joint and lateral compliance of a tree: the torso bends under both arms.
// 350 poses at 0.1 mm; the fit with both families comes within 10 % of the
// noise floor (the truth's error on the noisy held-out points), each
// compliance within 3 sd; without compliance at least 2x worse.
TEST(TreeModel, ComplianceOfATreeIsRecovered) {
  DeviceTree chains = two_arm_tree();
  load(chains);
  const DeviceModel nominal = tree_model(chains);
  const Truth t = truth(31);
  DeviceModel actual = nominal;
  actual.set_kinematic_parameters(t.model.kinematic_parameters());
  // rad / N m: the torso's pitch and a shoulder of each arm; the torso's yaw (a
  // vertical axis, no gravity torque about it) and pitch bending sideways (the
  // roll's axis is its origin's x: its bend is its own turn).
  actual.links[1].compliance = 5e-4;
  actual.links[4].compliance = 1e-3;
  actual.links[8].compliance = 8e-4;
  actual.links[0].lateral_compliance = 3e-4;
  actual.links[1].lateral_compliance = -4e-4;
  const double sigma = 1e-4;
  const Log log = compliant_log(actual, 350, sigma, 32);
  const Log test = tip_samples(nominal, compliant_log(actual, 150, sigma, 33));
  // RMS error of a model on the held-out noisy points; the truth's is the floor.
  auto held_out = [&](const DeviceModel& m) {
    double sum = 0;
    for (int r = 0; r < test.rows; ++r)
      sum += (tip_point(m, test.tip[static_cast<size_t>(r)], test.q.row(r).transpose()) -
              test.position.row(r).transpose())
                 .squaredNorm();
    return std::sqrt(sum / test.rows);
  };
  const double floor = held_out(actual);
  // The prepared model (the runtime's) deflects and bends the tree the same.
  const PreparedModel prepared(actual);
  for (int r = 0; r < 20; ++r) {
    const Eigen::VectorXd q = test.q.row(r).transpose();
    const int tip = test.tip[static_cast<size_t>(r)];
    EXPECT_LT((prepared.forward(q.data(), tip).p - tip_point(actual, tip, q)).norm(), 1e-12);
  }
  const Log samples = tip_samples(nominal, log);
  CalibrationOptions both;
  both.joint_errors = {"compliance", "lateral"};
  const CalibrationResult fit = calibrate(nominal, samples, both);
  ASSERT_EQ(fit.status, CalibrationStatus::kConverged) << fit.status_reason;
  CalibrationOptions none;
  none.joint_errors = {"none"};
  const CalibrationResult rigid = calibrate(nominal, samples, none);
  const double with = held_out(fit.calibrated), without = held_out(rigid.calibrated);
  EXPECT_LT(with, 1.1 * floor) << with << " floor " << floor;
  // The calibrated tree holds its compliance (folded into its links): its
  // problem deflects and bends each pose as the kinematics above do.
  ASSERT_NE(fit.calibrated.links[1].compliance, 0.0);
  EXPECT_NEAR(held_out_rms(fit.calibrated, test), with, 1e-9);
  EXPECT_GT(without, 2 * with) << without;
  for (const auto& [link, suffix] : std::vector<std::pair<int, std::string>>{
           {1, ".k"}, {4, ".k"}, {8, ".k"}, {0, ".kx"}, {1, ".kx"}}) {
    const std::string name = actual.links[static_cast<size_t>(link)].name + suffix;
    const ParameterEstimate* e = testing::find_parameter(fit.kinematics, name);
    ASSERT_NE(e, nullptr) << name;
    const double truth_value = suffix == ".k"
                                   ? actual.links[static_cast<size_t>(link)].compliance
                                   : actual.links[static_cast<size_t>(link)].lateral_compliance;
    EXPECT_LT(std::abs(e->value - truth_value), 3 * e->sd)
        << name << " " << e->value << " +- " << e->sd;
  }
  // The default search finds the compliance of the tree without flags.
  const CalibrationResult found = calibrate(nominal, samples, CalibrationOptions{});
  const ModelSearch& search = found.kinematics.search;
  ASSERT_GE(search.kept, 0) << search.note;
  EXPECT_EQ(search.candidates[static_cast<size_t>(search.kept)].families,
            (std::vector<std::string>{"compliance", "lateral"}));
  EXPECT_LT(held_out(found.calibrated), 1.1 * floor);
}

}  // namespace
}  // namespace hapticcal
