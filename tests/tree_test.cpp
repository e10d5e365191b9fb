// Several tips on one tree (issue 26, item 4): a two-arm robot on a 3-joint
// torso, one point measured at each hand. The tree's Jacobian against numerical
// derivatives; the joint fit, which identifies the torso once, against the two
// arms fitted apart on held-out poses; bad trees and logs refused.
#include "hapticcal/identification/tree.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/design/tree_plan.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/urdf.hpp"
#include "identification/tree_internal.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

// A humanoid's upper body: a 3-joint torso (yaw, pitch, roll) and two 4-joint
// arms, each hand a link fixed below its wrist (examples/two-arm).
const std::string kUrdf = HAPTICCAL_SOURCE_DIR "/examples/two-arm/two_arm.urdf";
std::string two_arm_urdf() { return read_file(kUrdf, FileKind::kUrdf); }

const std::vector<std::string> kTips{"left_hand", "right_hand"};

DeviceTree nominal_tree() {
  const std::string u = two_arm_urdf();
  std::vector<DeviceModel> chains;
  for (const std::string& tip : kTips) chains.push_back(parse_urdf(u, "two_arm.urdf", tip));
  return make_tree(std::move(chains), kTips);
}

// The nominal tree with its joint origins off by 1 mm / 2 mrad (sd), its hands'
// points off by 1 mm, and its base the tracker's frame.
DeviceTree truth_tree(std::uint64_t seed) {
  DeviceTree tree = nominal_tree();
  Eigen::VectorXd v = tree.values();
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  for (const ParameterInfo& p : tree.parameters) {
    if (p.joint == -1) continue;
    v[p.slot] += (p.unit == ParameterUnit::kLength ? 1e-3 : 2e-3) * gauss(rng);
  }
  v.head<6>() << 1.2, -0.4, 0.3, 0.05, -0.1, 2.0;
  tree.set_values(v);
  return tree;
}

// `rows` random poses of the tree and its hands' points (noise sd `sigma` a
// coordinate; 0: the truth).
Log tree_log(const DeviceTree& truth, int rows, double sigma, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(-1.3, 1.3);
  const int n = truth.dof(), k = static_cast<int>(truth.tips.size());
  Log log = testing::blank_marker_log("tree.csv", rows, n, k);
  for (int r = 0; r < rows; ++r) {
    for (int j = 0; j < n; ++j) log.q(r, j) = uniform(rng);
    for (int c = 0; c < k; ++c) {
      const PreparedModel prepared(truth.chains[static_cast<size_t>(c)]);
      const Eigen::VectorXd q = truth.chain_reading(log.q.row(r).transpose(), c);
      const Eigen::Vector3d p = prepared.forward(q.data()).p;
      for (int x = 0; x < 3; ++x) log.markers(r, 3 * c + x) = p[x] + sigma * gauss(rng);
    }
  }
  return log;
}

// The tree's hands' points at these readings (noise sd `sigma` a coordinate).
Log tree_log_at(const DeviceTree& truth, const Eigen::MatrixXd& readings, double sigma,
                std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const int rows = static_cast<int>(readings.rows()), k = static_cast<int>(truth.tips.size());
  Log log = testing::blank_marker_log("tree.csv", rows, truth.dof(), k);
  log.q = readings;
  for (int c = 0; c < k; ++c) {
    const PreparedModel prepared(truth.chains[static_cast<size_t>(c)]);
    for (int r = 0; r < rows; ++r) {
      const Eigen::VectorXd q = truth.chain_reading(readings.row(r).transpose(), c);
      const Eigen::Vector3d p = prepared.forward(q.data()).p;
      for (int x = 0; x < 3; ++x) log.markers(r, 3 * c + x) = p[x] + sigma * gauss(rng);
    }
  }
  return log;
}

TEST(Tree, SharedJointsAreOneSetOfParameters) {
  const DeviceTree tree = nominal_tree();
  ASSERT_EQ(tree.dof(), 11);
  EXPECT_EQ(tree.joints[0], "torso_yaw");
  EXPECT_EQ(tree.joints[3], "l_shoulder_pitch");
  EXPECT_EQ(tree.joints[7], "r_shoulder_pitch");
  // base 6, 11 joints of 7 (origin and offset), a tool of 6 a hand.
  EXPECT_EQ(tree.num_slots(), 6 + 11 * 7 + 2 * 6);
  int torso = 0;
  for (const ParameterInfo& p : tree.parameters) {
    if (p.name.rfind("torso_", 0) == 0) {
      ++torso;
      EXPECT_EQ(tree.chains_of[static_cast<size_t>(p.slot)], (std::vector<int>{0, 1})) << p.name;
    }
  }
  EXPECT_EQ(torso, 3 * 7);
  EXPECT_EQ(
      tree.parameters[static_cast<size_t>(tree.slot_of[1][tree.chains[1].structure().tool])].name,
      "right_hand.tool.x");
  // values and set_values invert each other; a chain's part is its own vector.
  DeviceTree t = truth_tree(3);
  const Eigen::VectorXd v = t.values();
  t.set_values(v);
  EXPECT_EQ(t.values(), v);
  EXPECT_EQ(t.chain_values(v, 1), t.chains[1].kinematic_parameters());
}

// The tree's stacked Jacobian: central differences of its residuals, column by
// column; a shared joint's column carries both hands' rows.
TEST(Tree, JacobianMatchesNumericalDerivatives) {
  const DeviceTree truth = truth_tree(5);
  const DeviceTree tree = nominal_tree();
  const Log log = tree_log(truth, 20, 0.0, 6);
  detail::TreeData data;
  for (int c = 0; c < 2; ++c) {
    const DeviceModel& m = tree.chains[static_cast<size_t>(c)];
    const Log lc = chain_log(tree, log, c);
    data.s.push_back(m.structure());
    data.joints.emplace_back();
    for (int r = 0; r < log.rows; ++r) data.joints.back().push_back(lc.q.row(r).transpose());
    data.measured.push_back(lc.position);
    data.weights.emplace_back();
  }
  const Eigen::VectorXd v = truth.values();
  const detail::TreeStack at = detail::tree_stack(tree, data, v);
  ASSERT_EQ(at.J.rows(), 2 * 3 * 20);
  for (int k = 0; k < tree.num_slots(); ++k) {
    const double h = 1e-6;
    Eigen::VectorXd up = v, down = v;
    up[k] += h;
    down[k] -= h;
    const Eigen::VectorXd numeric = (detail::tree_stack(tree, data, up, false).r -
                                     detail::tree_stack(tree, data, down, false).r) /
                                    (2 * h);
    EXPECT_LT((at.J.col(k) - numeric).norm(), 1e-6 * std::max(1.0, numeric.norm()))
        << tree.parameters[static_cast<size_t>(k)].name;
  }
  // A torso column moves both hands' rows; a left-arm column only the left's.
  const int torso = tree.slot_of[0][tree.chains[0].structure().link_slot(0)];
  const int left = tree.slot_of[0][tree.chains[0].structure().link_slot(3)];
  EXPECT_GT(at.J.col(torso).tail(60).norm(), 0.0);
  EXPECT_GT(at.J.col(torso).head(60).norm(), 0.0);
  EXPECT_EQ(at.J.col(left).tail(60).norm(), 0.0);
}

// The acceptance: 350 poses to fit, 150 held out, 0.1 mm noise, five
// robots (seeded deviations). The joint fit identifies each torso parameter
// once (both hands' calibrated chains carry the same torso, and it fits fewer
// parameters than the two arms apart) and predicts held-out points better than
// the two arms fitted apart, each of which finds a torso of its own: on the
// noisy held-out points over the five, and against the truth on each.
TEST(Tree, JointFitValidatesBetterThanSeparateFits) {
  const DeviceTree nominal = nominal_tree();
  const double sigma = 1e-4;
  double joint_sum = 0, apart_sum = 0;
  for (std::uint64_t seed = 11; seed < 16; ++seed) {
    const DeviceTree truth = truth_tree(seed);
    const Log fit = tree_log(truth, 350, sigma, 100 + seed);
    const Log held = tree_log(truth, 150, sigma, 200 + seed);
    const Log held_truth = tree_log(truth, 150, 0.0, 200 + seed);
    const TreeCalibration joint = calibrate_tree(nominal, fit, CalibrationOptions());
    ASSERT_EQ(joint.status, CalibrationStatus::kConverged) << joint.status_reason;
    EXPECT_TRUE(joint.frame_registered);
    // Each torso parameter once, and both chains carry its one value.
    for (int j = 0; j < 3; ++j) {
      const Link& left = joint.calibrated.chains[0].links[static_cast<size_t>(j)];
      const Link& right = joint.calibrated.chains[1].links[static_cast<size_t>(j)];
      EXPECT_EQ(left.origin, right.origin) << left.name;
      EXPECT_EQ(left.offset, right.offset) << left.name;
    }
    int torso_identified = 0;
    for (const ParameterEstimate& p : joint.parameters) {
      if (p.name.rfind("torso_", 0) == 0 && p.identifiable) {
        ++torso_identified;
        EXPECT_GT(p.sd, 0.0) << p.name;
      }
    }
    EXPECT_GT(torso_identified, 0);
    const std::vector<double> joint_held = tree_position_rms(joint.calibrated, held);
    const std::vector<double> joint_truth = tree_position_rms(joint.calibrated, held_truth);
    // The two arms apart: calibrate on each chain's log, plain least squares
    // (keep_all), as the tree's fit is.
    CalibrationOptions apart;
    apart.keep_all = true;
    apart.search = false;  // one model
    apart.folds = 0;
    std::vector<double> apart_held, apart_truth;
    std::vector<DeviceModel> separate;
    int apart_identified = 0;
    for (int c = 0; c < 2; ++c) {
      const CalibrationResult r =
          calibrate(nominal.chains[static_cast<size_t>(c)], chain_log(nominal, fit, c), apart);
      ASSERT_EQ(r.status, CalibrationStatus::kConverged) << r.status_reason;
      separate.push_back(r.calibrated);
      apart_identified += r.kinematics.identified;
      DeviceTree alone = nominal;
      alone.chains[static_cast<size_t>(c)] = r.calibrated;
      apart_held.push_back(tree_position_rms(alone, held)[static_cast<size_t>(c)]);
      apart_truth.push_back(tree_position_rms(alone, held_truth)[static_cast<size_t>(c)]);
    }
    const auto mean = [](const std::vector<double>& v) { return (v[0] + v[1]) / 2; };
    std::printf(
        "seed %d: %d parameters (apart %d, torso %d); held out [mm]: joint %.4f / %.4f, "
        "apart %.4f / %.4f; against the truth: joint %.4f / %.4f, apart %.4f / %.4f\n",
        static_cast<int>(seed), joint.identified, apart_identified, torso_identified,
        1e3 * joint_held[0], 1e3 * joint_held[1], 1e3 * apart_held[0], 1e3 * apart_held[1],
        1e3 * joint_truth[0], 1e3 * joint_truth[1], 1e3 * apart_truth[0], 1e3 * apart_truth[1]);
    EXPECT_LT(joint.identified, apart_identified);
    EXPECT_LT(mean(joint_truth), mean(apart_truth)) << "seed " << seed;
    joint_sum += mean(joint_held);
    apart_sum += mean(apart_held);
    // Fitted apart, the two arms find two different torsos.
    bool differ = false;
    for (int j = 0; j < 3; ++j)
      differ = differ || separate[0].links[static_cast<size_t>(j)].origin !=
                             separate[1].links[static_cast<size_t>(j)].origin;
    EXPECT_TRUE(differ);
  }
  std::printf("held out, mean over five robots [mm]: joint %.4f, apart %.4f\n", 1e3 * joint_sum / 5,
              1e3 * apart_sum / 5);
  EXPECT_LT(joint_sum, apart_sum);
}

// plan --tip A,B: the planned poses predict a lower sd of the hands' points
// than random poses, and the prediction is what calibrate_tree on simulated
// measurements at those poses gives (Monte Carlo over noise draws, errors
// against the truth at held-out readings), the planned design's below the
// random one's there too.
TEST(Tree, PlanPredictsAndBeatsRandomPoses) {
  const DeviceTree nominal = nominal_tree();
  TreePlanOptions options;
  options.poses = 30;
  options.pool = 2000;
  options.sigma = 1e-4;
  options.random_draws = 10;
  const TreePlan plan = plan_tree(nominal, options);
  ASSERT_EQ(plan.readings.rows(), 30);
  EXPECT_LT(plan.rms_sd, plan.random_median_rms_sd);
  // The exchange improves on the greedy start: its criterion (the validation
  // sample's mean prediction variance) and the evaluation sample's RMS sd.
  std::printf("tree plan: greedy %.2f um, exchange %.2f um (%d swaps in %d sweeps)\n",
              1e6 * plan.rms_sd_greedy, 1e6 * plan.rms_sd, plan.swaps, plan.sweeps);
  EXPECT_GT(plan.swaps, 0);
  EXPECT_GE(plan.criterion_exchange, plan.criterion_greedy);
  EXPECT_LE(plan.rms_sd, plan.rms_sd_greedy);
  // Every candidate identified or held (a URDF's joints have no beta).
  EXPECT_EQ(static_cast<int>(plan.parameters.size() + plan.held.size()), nominal.num_slots());
  const Eigen::MatrixXd random = tree_random_readings(nominal, 30, 77);
  const Eigen::MatrixXd held = tree_random_readings(nominal, 300, 78);
  const double predicted = tree_predicted_rms_sd(nominal, plan.readings, held, options.sigma);
  const double predicted_random = tree_predicted_rms_sd(nominal, random, held, options.sigma);
  const DeviceTree truth = truth_tree(31);
  const Log held_truth = tree_log_at(truth, held, 0.0, 1);
  double planned_ss = 0, random_ss = 0;
  const int draws = 20;
  for (int d = 0; d < draws; ++d) {
    for (const Eigen::MatrixXd* design : {&plan.readings, &random}) {
      const TreeCalibration fit = calibrate_tree(
          nominal, tree_log_at(truth, *design, options.sigma, 500 + d), CalibrationOptions());
      ASSERT_EQ(fit.status, CalibrationStatus::kConverged) << fit.status_reason;
      // The plan's parameters are those the fit identifies.
      EXPECT_EQ(fit.identified, static_cast<int>(plan.parameters.size()));
      const std::vector<double> rms = tree_position_rms(fit.calibrated, held_truth);
      (design == &plan.readings ? planned_ss : random_ss) +=
          (rms[0] * rms[0] + rms[1] * rms[1]) / 2;
    }
  }
  const double planned_mc = std::sqrt(planned_ss / draws), random_mc = std::sqrt(random_ss / draws);
  std::printf(
      "tree plan, RMS of a hand's point [um]: planned %.2f predicted, %.2f simulated; "
      "random %.2f predicted, %.2f simulated (plan's random median %.2f)\n",
      1e6 * predicted, 1e6 * planned_mc, 1e6 * predicted_random, 1e6 * random_mc,
      1e6 * plan.random_median_rms_sd);
  EXPECT_NEAR(planned_mc, predicted, 0.10 * predicted);
  EXPECT_NEAR(random_mc, predicted_random, 0.25 * predicted_random);
  EXPECT_LT(planned_mc, random_mc);
}

TEST(Tree, BadTreesAndLogsAreRefused) {
  const std::string u = two_arm_urdf();
  const DeviceModel left = parse_urdf(u, "two_arm.urdf", "left_hand");
  EXPECT_THROW(make_tree({left}, {"left_hand"}), InputError);
  EXPECT_THROW(make_tree({left, left}, {"left_hand", "left_hand"}), InputError);
  DeviceModel other = parse_urdf(u, "two_arm.urdf", "right_hand");
  other.links[0].origin[2] += 0.01;  // the "same" torso joint elsewhere
  EXPECT_THROW(make_tree({left, other}, {"left_hand", "right_hand"}), InputError);
  const DeviceTree tree = nominal_tree();
  Log log = tree_log(truth_tree(2), 40, 0.0, 3);
  log.marker_count = 1;
  log.markers.conservativeResize(Eigen::NoChange, 3);
  EXPECT_THROW(calibrate_tree(tree, log, {}), InputError);
  // A tip on the path to another: their tools could not both be written back.
  EXPECT_THROW(parse_tree(u, "two_arm.urdf", {"l_fore", "left_hand"}), InputError);
  EXPECT_THROW(parse_tree(u, "two_arm.urdf", {"left_hand", "l_fore"}), InputError);
  EXPECT_NO_THROW(parse_tree(u, "two_arm.urdf", {"right_hand", "l_fore"}));
  // Tips moved by the same joints (a link and one fixed below it).
  EXPECT_THROW(parse_tree(u, "two_arm.urdf", {"l_wrist_link", "left_hand"}), InputError);
  EXPECT_THROW(parse_tree(u, "two_arm.urdf", {"left_hand", "l_wrist_link"}), InputError);
  // Every parameter held: nothing to fit, a status, no crash; a held base is
  // not registered either.
  CalibrationOptions all;
  for (const ParameterInfo& p : tree.parameters) all.fix.push_back(p.name);
  const Log good = tree_log(truth_tree(2), 40, 0.0, 3);
  const TreeCalibration none = calibrate_tree(tree, good, all);
  EXPECT_EQ(none.status, CalibrationStatus::kRankDeficient);
  EXPECT_FALSE(none.frame_registered);
  EXPECT_EQ(none.rms_after, none.rms_before);
  CalibrationOptions unknown;
  unknown.fix = {"j1.a"};
  EXPECT_THROW(calibrate_tree(tree, good, unknown), InputError);
  Log fewer = tree_log(truth_tree(2), 40, 0.0, 3);
  fewer.q.conservativeResize(Eigen::NoChange, 10);
  EXPECT_THROW(calibrate_tree(tree, fewer, {}), InputError);
}

// The command line: calibrate --tip A,B on the URDF writes the tree's
// calibrated.urdf and results.json; evaluate --tip A,B of that URDF (from its
// measurement frame) predicts held-out points as the fit does; bad requests
// exit 2 with one line.
TEST(Tree, CalibrateAndEvaluateOnTheCommandLine) {
  const std::string dir = testing::fresh_folder("tree_cli");
  std::filesystem::copy_file(kUrdf, dir + "/two_arm.urdf");
  const DeviceTree truth = truth_tree(21);
  const Log fit = tree_log(truth, 350, 1e-4, 22);
  const Log held = tree_log(truth, 150, 1e-4, 23);
  std::ofstream(dir + "/fit.csv") << log_to_csv(fit);
  std::ofstream(dir + "/held.csv") << log_to_csv(held);
  const testing::CliResult c =
      testing::run_cli({"calibrate", "--model", dir + "/two_arm.urdf", "--tip",
                        "left_hand,right_hand", "--log", dir + "/fit.csv", "--out", dir + "/cal"});
  ASSERT_EQ(c.exit_code, 0) << c.err << c.out;
  EXPECT_NE(c.out.find("tree two_arm: tips left_hand, right_hand; 11 joints (3 shared)"),
            std::string::npos)
      << c.out;
  const auto j = nlohmann::json::parse(read_file(dir + "/cal/results.json"));
  EXPECT_EQ(j["tree"]["tips"], nlohmann::json({"left_hand", "right_hand"}));
  EXPECT_EQ(j["parameters"]["torso_pitch.z"]["tips"], nlohmann::json({"left_hand", "right_hand"}));
  EXPECT_EQ(j["parameters"]["l_elbow.z"]["tips"], nlohmann::json({"left_hand"}));
  EXPECT_LT(j["rms_after"]["right_hand"].get<double>(), 2e-4);
  // The calibrated URDF from its measurement frame is the fit's tree.
  const TreeCalibration in_process = calibrate_tree(nominal_tree(), fit, CalibrationOptions());
  const std::vector<double> expected = tree_position_rms(in_process.calibrated, held);
  const testing::CliResult e = testing::run_cli(
      {"evaluate", "--model", dir + "/cal/calibrated.urdf", "--root", "hapticcal_measurement",
       "--tip", "left_hand,right_hand", "--log", dir + "/held.csv", "--json"});
  ASSERT_EQ(e.exit_code, 0) << e.err;
  const auto ev = nlohmann::json::parse(e.out);
  EXPECT_NEAR(ev["tips"]["left_hand"]["rms_position"].get<double>(), expected[0], 1e-9);
  EXPECT_NEAR(ev["tips"]["right_hand"]["rms_position"].get<double>(), expected[1], 1e-9);
  // Bad requests.
  Log one = fit;
  one.marker_count = 1;
  one.markers.conservativeResize(Eigen::NoChange, 3);
  std::ofstream(dir + "/one.csv") << log_to_csv(one);
  testing::expect_input_error(
      testing::run_cli({"calibrate", "--model", dir + "/two_arm.urdf", "--tip",
                        "left_hand,right_hand", "--log", dir + "/one.csv", "--out", dir + "/b"}),
      "2 tips (left_hand, right_hand) need the points x1, y1, z1 .. x2, y2, z2");
  testing::expect_input_error(
      testing::run_cli({"calibrate", "--model", "geomagic-touch", "--tip", "a,b", "--log",
                        dir + "/fit.csv", "--out", dir + "/b"}),
      "several tips (a tree) need a URDF model");
  testing::expect_input_error(
      testing::run_cli({"calibrate", "--model", dir + "/two_arm.urdf", "--tip", "left_hand,",
                        "--log", dir + "/fit.csv", "--out", dir + "/b"}),
      "an empty tip name");
  testing::expect_input_error(
      testing::run_cli({"evaluate", "--model", dir + "/two_arm.urdf", "--tip",
                        "left_hand,right_hand", "--log", dir + "/one.csv"}),
      "2 tips (left_hand, right_hand) need the points x1, y1, z1 .. x2, y2, z2; the log has 1 "
      "point");
  EXPECT_FALSE(std::filesystem::exists(dir + "/b"));
  // plan --tip A,B: plan.csv holds the tree's readings, plan.json the prediction.
  const testing::CliResult p = testing::run_cli(
      {"plan", "--model", dir + "/two_arm.urdf", "--tip", "left_hand,right_hand", "--measurement",
       "position", "--poses", "20", "--pool", "1000", "--out", dir + "/plan"});
  ASSERT_EQ(p.exit_code, 0) << p.err << p.out;
  const std::string csv = read_file(dir + "/plan/plan.csv");
  EXPECT_EQ(csv.substr(0, csv.find('\n')), "q1,q2,q3,q4,q5,q6,q7,q8,q9,q10,q11");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 21);
  const auto pj = nlohmann::json::parse(read_file(dir + "/plan/plan.json"));
  EXPECT_LT(pj["predicted_rms_sd"].get<double>(), pj["random_median_rms_sd"].get<double>());
  testing::expect_input_error(
      testing::run_cli({"plan", "--model", dir + "/two_arm.urdf", "--tip", "left_hand,right_hand",
                        "--measurement", "distance", "--poses", "20", "--out", dir + "/b"}),
      "a tree's plan measures its tips' points: position");
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace hapticcal
