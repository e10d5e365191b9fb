// Several tips on one tree (identification/tree.hpp): a URDF's chains to two
// hands as one model (tree_model) calibrated, evaluated and planned by the
// chain's own procedure; against the two arms fitted apart, the plan's
// prediction against simulated calibrations, bad trees and logs refused, and
// the command line.
#include "hapticcal/identification/tree.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/design/plan.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/jobs/calibrate_job.hpp"
#include "hapticcal/jobs/evaluate_job.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/model_source.hpp"
#include "hapticcal/model_io/urdf.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "hapticcal/study/session.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

// A humanoid's upper body: a 3-joint torso (yaw, pitch, roll) and two 4-joint
// arms, each hand a link fixed below its wrist (examples/two-arm).
const std::string kUrdf = HAPTICCAL_SOURCE_DIR "/examples/two-arm/two_arm.urdf";
std::string two_arm_urdf() { return read_file(kUrdf, FileKind::kUrdf); }

const std::vector<std::string> kTips{"left_hand", "right_hand"};

DeviceTree nominal_tree() { return parse_tree(two_arm_urdf(), "two_arm.urdf", kTips); }
DeviceModel nominal_model() { return tree_model(nominal_tree()); }

// The nominal tree with its joint origins off by 1 mm / 2 mrad (sd), its hands'
// points off by 1 mm, and its base the tracker's frame.
DeviceModel truth_model(std::uint64_t seed) {
  DeviceModel m = nominal_model();
  Eigen::VectorXd v = m.kinematic_parameters();
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  for (const ParameterInfo& p : m.parameter_info()) {
    if (p.block == ParameterBlock::kBase) continue;
    v[p.slot] += (p.unit == ParameterUnit::kLength ? 1e-3 : 2e-3) * gauss(rng);
  }
  v.head<6>() << 1.2, -0.4, 0.3, 0.05, -0.1, 2.0;
  m.set_kinematic_parameters(v);
  return m;
}

// The hands' points (x1.. the first tip, x2.. the second) at these readings,
// noise sd `sigma` a coordinate (0: the truth).
Log hands_at(const DeviceModel& truth, const Eigen::MatrixXd& readings, double sigma,
             std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const int rows = static_cast<int>(readings.rows());
  Log log = testing::blank_marker_log("tree.csv", rows, truth.dof(), truth.tips());
  log.q = readings;
  const PreparedModel prepared(truth);
  for (int r = 0; r < rows; ++r) {
    const Eigen::VectorXd q = readings.row(r).transpose();
    for (int t = 0; t < truth.tips(); ++t) {
      const Eigen::Vector3d p = prepared.forward(q.data(), t).p;
      for (int x = 0; x < 3; ++x) log.markers(r, 3 * t + x) = p[x] + sigma * gauss(rng);
    }
  }
  return log;
}

// `rows` random readings (each joint uniform in +-1.3 rad) and the hands' points.
Log hands_log(const DeviceModel& truth, int rows, double sigma, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(-1.3, 1.3);
  Eigen::MatrixXd q(rows, truth.dof());
  for (int r = 0; r < rows; ++r)
    for (int j = 0; j < truth.dof(); ++j) q(r, j) = uniform(rng);
  return hands_at(truth, q, sigma, seed + 1000);
}

// Each tip's RMS position error of a tree model on a tree log.
std::vector<double> tip_rms(const DeviceModel& m, const Log& log) {
  std::vector<double> out;
  for (int t = 0; t < m.tips(); ++t)
    out.push_back(evaluate(m, tip_samples(m, log, t)).figure("position")->stats.rms);
  return out;
}

// Tip k's chain and its log (the readings of its path), for a fit of one arm.
Log arm_log(const DeviceModel& tree, const Log& log, int tip) {
  const std::vector<int> path = tree.path(tip);
  Log out = testing::blank_marker_log("arm.csv", log.rows, static_cast<int>(path.size()), 0);
  out.has_position = true;
  out.position = log.markers.middleCols(3 * tip, 3);
  for (size_t j = 0; j < path.size(); ++j)
    out.q.col(static_cast<Eigen::Index>(j)) = log.q.col(path[j]);
  return out;
}

TEST(Tree, SharedJointsAreOneSetOfParameters) {
  const DeviceTree tree = nominal_tree();
  ASSERT_EQ(tree.dof(), 11);
  EXPECT_EQ(tree.joints[0], "torso_yaw");
  EXPECT_EQ(tree.joints[3], "l_shoulder_pitch");
  EXPECT_EQ(tree.joints[7], "r_shoulder_pitch");
  const DeviceModel m = tree_model(tree);
  // base 6, 11 joints of 7 (origin and offset), a tool of 6 a hand.
  const std::vector<ParameterInfo> info = m.parameter_info();
  EXPECT_EQ(static_cast<int>(info.size()), 6 + 11 * 7 + 2 * 6);
  int torso = 0;
  for (const ParameterInfo& p : info) torso += p.name.rfind("torso_", 0) == 0;
  EXPECT_EQ(torso, 3 * 7);
  EXPECT_EQ(info[static_cast<size_t>(m.tool_slot(1))].name, "right_hand.tool.x");
  // Both tips' paths start with the torso's joints; each arm's only on its own.
  const std::vector<int> left = m.path(0), right = m.path(1);
  EXPECT_EQ(std::vector<int>(left.begin(), left.begin() + 3), std::vector<int>({0, 1, 2}));
  EXPECT_EQ(std::vector<int>(right.begin(), right.begin() + 3), std::vector<int>({0, 1, 2}));
  EXPECT_EQ(std::count(right.begin(), right.end(), 3), 0);
}

// 350 poses to fit, 150 held out, 0.1 mm noise, five robots (seeded
// deviations). The tree's fit (calibrate's default on the tree model)
// predicts held-out points better than the two arms fitted apart by the same
// procedure, each of which finds a torso of its own: on the noisy held-out
// points over the five, and against the truth on each.
TEST(Tree, JointFitValidatesBetterThanSeparateFits) {
  const DeviceModel nominal = nominal_model();
  const std::string u = two_arm_urdf();
  const double sigma = 1e-4;
  double joint_sum = 0, apart_sum = 0;
  for (std::uint64_t seed = 11; seed < 16; ++seed) {
    const DeviceModel truth = truth_model(seed);
    const Log fit = hands_log(truth, 350, sigma, 100 + seed);
    const Log held = hands_log(truth, 150, sigma, 200 + seed);
    const Log held_truth = hands_log(truth, 150, 0.0, 200 + seed);
    const CalibrationResult joint = calibrate(nominal, tip_samples(nominal, fit), {});
    ASSERT_EQ(joint.status, CalibrationStatus::kConverged) << joint.status_reason;
    EXPECT_TRUE(joint.kinematics.frame_registered);
    const std::vector<double> joint_held = tip_rms(joint.calibrated, held);
    const std::vector<double> joint_truth = tip_rms(joint.calibrated, held_truth);
    std::vector<double> apart_held, apart_truth;
    std::vector<DeviceModel> separate;
    for (int c = 0; c < 2; ++c) {
      const DeviceModel arm = parse_urdf(u, "two_arm.urdf", kTips[static_cast<size_t>(c)]);
      const CalibrationResult r = calibrate(arm, arm_log(nominal, fit, c), {});
      ASSERT_EQ(r.status, CalibrationStatus::kConverged) << r.status_reason;
      separate.push_back(r.calibrated);
      apart_held.push_back(
          evaluate(r.calibrated, arm_log(nominal, held, c)).figure("position")->stats.rms);
      apart_truth.push_back(
          evaluate(r.calibrated, arm_log(nominal, held_truth, c)).figure("position")->stats.rms);
    }
    const auto mean = [](const std::vector<double>& v) { return (v[0] + v[1]) / 2; };
    std::printf(
        "seed %d: held out [mm]: joint %.4f / %.4f, apart %.4f / %.4f; against the truth: joint "
        "%.4f / %.4f, apart %.4f / %.4f\n",
        static_cast<int>(seed), 1e3 * joint_held[0], 1e3 * joint_held[1], 1e3 * apart_held[0],
        1e3 * apart_held[1], 1e3 * joint_truth[0], 1e3 * joint_truth[1], 1e3 * apart_truth[0],
        1e3 * apart_truth[1]);
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

// plan of a tree (the chain's planner on the tree model, each pose measuring
// both hands): the planned poses predict a lower sd of the hands' points than
// random poses, the exchange does not undo the greedy start, and the
// prediction is what calibrate on simulated measurements at those poses gives
// (plain least squares, Monte Carlo over noise draws, errors against the truth
// at held-out readings), the planned design's below the random one's there too.
TEST(Tree, PlanPredictsAndBeatsRandomPoses) {
  const DeviceModel nominal = nominal_model();
  const double sigma = 1e-4;
  const PlanProblem problem(nominal, MeasurementType::kPosition, sigma, 1e-3,
                            random_readings(nominal, 300, 5));
  PlanOptions options;
  options.poses = 30;
  options.pool = 2000;
  options.random_draws = 10;
  const Plan plan = plan_poses(problem, options);
  ASSERT_EQ(plan.readings.rows(), 30);
  EXPECT_LT(plan.planned.rms_sd, plan.random_median_rms_sd);
  std::printf("tree plan: %d swaps in %d sweeps; criterion greedy %.6g, exchange %.6g\n",
              plan.swaps, plan.sweeps, plan.two_step_greedy, plan.two_step_exchange);
  EXPECT_GE(plan.two_step_exchange, plan.two_step_greedy);
  const Eigen::MatrixXd random = random_readings(nominal, 30, 77);
  const Eigen::MatrixXd held = random_readings(nominal, 300, 78);
  const double predicted = problem.predicted_rms_sd(plan.readings, held);
  const double predicted_random = problem.predicted_rms_sd(random, held);
  const DeviceModel truth = truth_model(31);
  const Log held_truth = hands_at(truth, held, 0.0, 1);
  CalibrationOptions plain;  // least squares on the candidates the plan is for
  plain.keep_all = true;
  plain.search = false;
  plain.folds = 0;
  double planned_ss = 0, random_ss = 0;
  const int draws = 20;
  for (int d = 0; d < draws; ++d) {
    for (const Eigen::MatrixXd* design : {&plan.readings, &random}) {
      const CalibrationResult fit =
          calibrate(nominal, tip_samples(nominal, hands_at(truth, *design, sigma, 500 + d)), plain);
      ASSERT_EQ(fit.status, CalibrationStatus::kConverged) << fit.status_reason;
      if (design == &plan.readings) {  // the plan's parameters are those the fit identifies
        EXPECT_EQ(fit.kinematics.identified, static_cast<int>(problem.kinematic_slots().size()));
      }
      const std::vector<double> rms = tip_rms(fit.calibrated, held_truth);
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
  const DeviceModel tree = nominal_model();
  Log log = hands_log(truth_model(2), 40, 0.0, 3);
  log.marker_count = 1;
  log.markers.conservativeResize(Eigen::NoChange, 3);
  EXPECT_THROW(tip_samples(tree, log), InputError);
  // A tip on the path to another: their tools could not both be written back.
  EXPECT_THROW(parse_tree(u, "two_arm.urdf", {"l_fore", "left_hand"}), InputError);
  EXPECT_THROW(parse_tree(u, "two_arm.urdf", {"left_hand", "l_fore"}), InputError);
  EXPECT_NO_THROW(parse_tree(u, "two_arm.urdf", {"right_hand", "l_fore"}));
  // Tips moved by the same joints (a link and one fixed below it).
  EXPECT_THROW(parse_tree(u, "two_arm.urdf", {"l_wrist_link", "left_hand"}), InputError);
  EXPECT_THROW(parse_tree(u, "two_arm.urdf", {"left_hand", "l_wrist_link"}), InputError);
  // Every parameter held: nothing to fit, a status, no crash.
  const Log good = tip_samples(tree, hands_log(truth_model(2), 40, 0.0, 3));
  CalibrationOptions all;
  for (const ParameterInfo& p : tree.parameter_info()) all.fix.push_back(p.name);
  const CalibrationResult none = calibrate(tree, good, all);
  EXPECT_NE(none.status, CalibrationStatus::kConverged);
  CalibrationOptions unknown;
  unknown.fix = {"j1.a"};
  EXPECT_THROW(calibrate(tree, good, unknown), InputError);
  Log fewer = good;
  fewer.q.conservativeResize(Eigen::NoChange, 10);
  EXPECT_THROW(calibrate(tree, fewer, {}), InputError);
  // Points in millimetres with a bare header: refused, the unit named (a tree
  // and one of its arms alike).
  Log mm = hands_log(truth_model(2), 60, 1e-4, 4);
  mm.markers *= 1e3;
  const Log arm_mm = arm_log(tree, mm, 0);
  for (int chain = 0; chain < 2; ++chain) {
    try {
      if (chain) {
        calibrate(left, arm_mm, {});
      } else {
        calibrate(tree, tip_samples(tree, mm), {});
      }
      FAIL() << "points in mm calibrated";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("The measurements fit it in mm: give the unit"),
                std::string::npos)
          << e.what();
    }
  }
  // A tree's fixture labels (point1, point2) given to one chain.
  Log labelled = testing::blank_marker_log("sockets.csv", 4, 7, 0);
  labelled.q.setZero();
  labelled.has_point = true;
  labelled.label = {"A,B", "A,C", "B,C", "A,B"};
  try {
    calibrate(left, labelled, {});
    FAIL() << "a chain took a tree's labels";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("numbered labels (point1, point2, ...) are a tree's"),
              std::string::npos)
        << e.what();
  }
}

// A fresh folder holding a copy of the two-arm URDF (calibrated.urdf's base).
std::string urdf_folder(const std::string& name) {
  const std::string dir = testing::fresh_folder(name);
  std::filesystem::copy_file(kUrdf, dir + "/two_arm.urdf");
  return dir;
}

// One loader for chains and trees: several tips give the URDF's tree, one the
// chain; the commands that need one tool point refuse a tree by name.
TEST(Tree, OneLoaderForChainsAndTrees) {
  const DeviceModel tree = load_model(kUrdf, "left_hand,right_hand");
  const DeviceModel expected = tree_model(nominal_tree());
  ASSERT_TRUE(tree.tree());
  auto names = [](const DeviceModel& m) {
    std::vector<std::string> out;
    for (const ParameterInfo& p : m.parameter_info()) out.push_back(p.name);
    return out;
  };
  EXPECT_EQ(names(tree), names(expected));
  EXPECT_EQ(tree.kinematic_parameters(), expected.kinematic_parameters());
  const std::string text = two_arm_urdf();
  EXPECT_EQ(
      load_model("two_arm.urdf", std::vector<std::string>{"left_hand", "right_hand"}, "", &text)
          .kinematic_parameters(),
      expected.kinematic_parameters());
  const DeviceModel left = load_model(kUrdf, "left_hand");
  EXPECT_FALSE(left.tree());
  EXPECT_EQ(left.kinematic_parameters(),
            parse_urdf(text, "two_arm.urdf", "left_hand").kinematic_parameters());
  EXPECT_THROW(load_model(kUrdf, "left_hand,"), InputError);  // an empty tip's name
  try {
    load_model(builtin_device_path(), "a,b");
    ADD_FAILURE() << "a device file with several tips was loaded";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("several tips apply to a URDF"), std::string::npos)
        << e.what();
  }
  const std::string dir = urdf_folder("tree_refused");
  const std::string urdf = dir + "/two_arm.urdf";
  const testing::CliResult force =
      testing::run_cli({"force", "--actual", urdf, "--nominal", urdf, "--calibrated", urdf, "--tip",
                        "left_hand,right_hand", "--out", dir + "/force"});
  EXPECT_EQ(force.exit_code, 2) << force.out << force.err;
  EXPECT_NE(force.err.find("force: a tree has several tips"), std::string::npos) << force.err;
  EXPECT_FALSE(std::filesystem::exists(dir + "/force"));
  std::string targets, zeros;  // joint targets: every joint at zero
  for (int j = 0; j < tree.dof(); ++j) {
    targets += fmt::format("{}q{}", j ? "," : "", j + 1);
    zeros += j ? ",0" : "0";
  }
  std::ofstream(dir + "/targets.csv") << targets << "\n" << zeros << "\n";
  const testing::CliResult compensate = testing::run_cli(
      {"compensate", "--model", urdf, "--nominal", urdf, "--tip", "left_hand,right_hand",
       "--targets", dir + "/targets.csv", "--out", dir + "/compensated"});
  EXPECT_EQ(compensate.exit_code, 2) << compensate.out << compensate.err;
  EXPECT_NE(compensate.err.find("a tree has several tips"), std::string::npos) << compensate.err;
}

// The largest distance [m] between the tips of a calibration's tree and of
// its calibrated.urdf read back from the measurement frame, at random readings.
double urdf_round_trip_gap(const DeviceModel& calibrated, const std::string& urdf) {
  // From the measurement frame calibrate wrote, if it fitted one (a fixture's
  // sockets are unknown: its base stays the URDF's root).
  const bool measured =
      read_file(urdf, FileKind::kUrdf).find("\"hapticcal_measurement\"") != std::string::npos;
  const DeviceModel back =
      tree_model(load_tree(urdf, kTips, measured ? "hapticcal_measurement" : ""));
  const PreparedModel a(calibrated), b(back);
  const Eigen::MatrixXd q = random_readings(calibrated, 50, 9);
  double gap = 0;
  for (Eigen::Index r = 0; r < q.rows(); ++r) {
    const Eigen::VectorXd x = q.row(r).transpose();
    for (int t = 0; t < calibrated.tips();
         ++t) {  // the tip's origin and a point 1 m along each axis
      const Frame<double> fa = a.forward(x.data(), t), fb = b.forward(x.data(), t);
      gap = std::max({gap, (fa.p - fb.p).norm(), (fa.R - fb.R).cwiseAbs().maxCoeff()});
    }
  }
  return gap;
}

// A tree from a hand-guided session: the device's readings and a tracker's
// stream of one marker a hand on two clocks (37.3 ms and 20 ppm apart, 0.1 mm
// noise, 60 s at 60 Hz): calibrate --tip A,B --tracker finds the offset and
// fits the tree, and calibrated.urdf gives back the fitted tree to 1e-9 m.
TEST(Tree, CalibratesFromATwoClockStream) {
  const std::string dir = urdf_folder("tree_stream");
  const DeviceModel truth = truth_model(41);
  SessionOptions o;
  o.seconds = 60;
  o.tracker_rate_hz = 60;
  const Session session = simulate_session(truth, o, 42);
  ASSERT_EQ(session.tracker.marker_count, 2);
  std::ofstream(dir + "/device.csv") << log_to_csv(session.device);
  std::ofstream(dir + "/tracker.csv") << log_to_csv(session.tracker);
  CalibrateRequest request;
  request.model = dir + "/two_arm.urdf";
  request.tip = "left_hand,right_hand";
  request.log = dir + "/device.csv";
  request.tracker = dir + "/tracker.csv";
  request.stream.drift = true;
  request.out = dir + "/cal";
  const CalibrateJob job = run_calibrate_job(request);
  ASSERT_TRUE(job.usable()) << job.result.status_reason;
  ASSERT_TRUE(job.result.clock.has_value());
  const ClockEstimate& c = *job.result.clock;
  std::printf("tree stream: offset %.4f ms +- %.4f (truth 37.3), training RMS %.4f mm\n",
              1e3 * c.clock.offset, 1e3 * c.offset_sd, 1e3 * job.result.kinematics.rms_after);
  EXPECT_LT(std::abs(c.clock.offset - o.clock_offset), 4 * c.offset_sd + 2e-5);
  // The residual is the markers' noise (Euclidean: sqrt(3) sigma) and little else.
  EXPECT_LT(job.result.kinematics.rms_after, 1.3 * std::sqrt(3.0) * o.sigma_position);
  // Against the truth at other readings: the tree is calibrated.
  const Log truth_points = hands_log(truth, 100, 0.0, 43);
  const std::vector<double> gap = tip_rms(job.result.calibrated, truth_points);
  std::printf("tree stream: against the truth %.4f / %.4f mm\n", 1e3 * gap[0], 1e3 * gap[1]);
  EXPECT_LT(std::max(gap[0], gap[1]), 1e-4) << gap[0] << " " << gap[1];
  EXPECT_LT(urdf_round_trip_gap(job.result.calibrated, dir + "/cal/calibrated.urdf"), 1e-9);
  std::filesystem::remove_all(dir);
}

// Readings at which tip 0 is at `a` and tip 1 at `b` (damped least squares on
// both tips' points over every joint, from `start`); false if not reached.
bool reach_both(const DeviceModel& m, Eigen::VectorXd& q, const Eigen::Vector3d& a,
                const Eigen::Vector3d& b) {
  const PreparedModel prepared(m);
  Jacobian6<double> J(6, m.dof());
  for (int step = 0; step < 200; ++step) {
    Eigen::MatrixXd A(6, m.dof());
    Eigen::VectorXd e(6);
    for (int t = 0; t < 2; ++t) {
      const Frame<double> f =
          prepared.forward_jacobian(q.data(), t, JacobianFrame::kMeasurement, J.data());
      A.middleRows(3 * t, 3) = J.topRows<3>();
      e.segment<3>(3 * t) = (t == 0 ? a : b) - f.p;
    }
    if (e.norm() < 1e-13) return true;
    q += A.transpose() *
         (A * A.transpose() + 1e-9 * Eigen::MatrixXd::Identity(6, 6)).ldlt().solve(e);
  }
  return false;
}

// Two hands in sockets: each row the left hand in one of three sockets and the
// right in one of three others, at varied postures (the torso and the arms'
// redundancy), read as point1 (the left's socket) and point2. calibrate --tip
// A,B with the sockets unknown and one distance between two of them given
// fits the tree to the readings, and calibrated.urdf gives it back to 1e-9 m.
TEST(Tree, CalibratesWithBothHandsInSockets) {
  const std::string dir = urdf_folder("tree_fixture");
  const DeviceModel truth = truth_model(51);
  const PreparedModel prepared(truth);
  std::mt19937_64 rng(52);
  std::uniform_real_distribution<double> uniform(-0.8, 0.8);
  // The sockets: where the hands are at three postures.
  std::vector<Eigen::Vector3d> left, right;
  for (int k = 0; k < 3; ++k) {
    Eigen::VectorXd q(truth.dof());
    for (int j = 0; j < truth.dof(); ++j) q[j] = uniform(rng);
    left.push_back(prepared.forward(q.data(), 0).p);
    right.push_back(prepared.forward(q.data(), 1).p);
  }
  Log log = testing::blank_marker_log("sockets.csv", 0, truth.dof(), 0);
  log.has_point = true;
  std::vector<Eigen::VectorXd> rows;
  while (rows.size() < 180) {
    const size_t i = rows.size() % 3, j = (rows.size() / 3) % 3;
    Eigen::VectorXd q(truth.dof());
    for (int k = 0; k < truth.dof(); ++k) q[k] = uniform(rng);
    if (!reach_both(truth, q, left[i], right[j])) continue;
    rows.push_back(q);
    log.label.push_back(fmt::format("L{},R{}", i + 1, j + 1));
  }
  log.rows = static_cast<int>(rows.size());
  log.q.resize(log.rows, truth.dof());
  for (int r = 0; r < log.rows; ++r) log.q.row(r) = rows[static_cast<size_t>(r)].transpose();
  log.ext.setZero(log.rows, truth.dof());
  log.direction.setZero(log.rows, truth.dof());
  for (int r = 0; r < log.rows; ++r) log.line.push_back(r + 2);
  const std::string csv = log_to_csv(log);
  ASSERT_NE(csv.find("point1,point2"), std::string::npos) << csv.substr(0, 200);
  std::ofstream(dir + "/sockets.csv") << csv;
  CalibrateRequest request;
  request.model = dir + "/two_arm.urdf";
  request.tip = "left_hand,right_hand";
  request.log = dir + "/sockets.csv";
  request.point_distances = {fmt::format("L1:R1={:.17g}", (left[0] - right[0]).norm())};
  request.out = dir + "/cal";
  const CalibrateJob job = run_calibrate_job(request);
  ASSERT_TRUE(job.usable()) << job.result.status_reason;
  std::printf("tree in sockets: %d parameters identified, RMS %.3g mm before, %.3g mm after\n",
              job.result.kinematics.identified, 1e3 * job.result.kinematics.rms_before,
              1e3 * job.result.kinematics.rms_after);
  EXPECT_LT(job.result.kinematics.rms_after, 1e-7);
  EXPECT_GT(job.result.kinematics.rms_before, 1e-4);
  // The hands' distance at other readings (free of the frame, which the
  // sockets leave open) is the truth's.
  const PreparedModel fitted(job.result.calibrated), nominal(nominal_model());
  const Eigen::MatrixXd other = random_readings(truth, 50, 53);
  double worst = 0, worst_nominal = 0;
  for (Eigen::Index r = 0; r < other.rows(); ++r) {
    const Eigen::VectorXd q = other.row(r).transpose();
    const auto span = [&](const PreparedModel& m) {
      return (m.forward(q.data(), 0).p - m.forward(q.data(), 1).p).norm();
    };
    worst = std::max(worst, std::abs(span(fitted) - span(prepared)));
    worst_nominal = std::max(worst_nominal, std::abs(span(nominal) - span(prepared)));
  }
  std::printf("tree in sockets: hands' distance off by %.3g mm at most (nominal %.3g mm)\n",
              1e3 * worst, 1e3 * worst_nominal);
  EXPECT_LT(worst, 1e-6);
  EXPECT_LT(urdf_round_trip_gap(job.result.calibrated, dir + "/cal/calibrated.urdf"), 1e-9);
  std::filesystem::remove_all(dir);
}

// Three markers on each hand (one plate layout, x1 .. x3 the left's, x4 .. x6
// the right's), 0.1 mm noise, the hands' tools turned and moved and the frame
// unknown: calibrate --tip A,B --markers fits each hand's pose (the body's,
// from its markers), and calibrated.urdf gives back each hand's frame to 1e-9 m.
TEST(Tree, CalibratesFromSeveralMarkersOnEachHand) {
  const std::string dir = urdf_folder("tree_markers");
  DeviceModel truth = truth_model(61);
  for (int t = 0; t < 2; ++t) {  // each plate turned on its hand
    std::array<double, 6>& tool = truth.tip_tool(t);
    tool[3] += 0.2;
    tool[4] -= 0.1 * (t + 1);
    tool[5] += 0.3;
  }
  Eigen::Matrix3Xd plate(3, 3);
  plate << 0.03, -0.02, 0.0, 0.0, 0.025, -0.02, 0.0, 0.0, 0.015;
  const PreparedModel prepared(truth);
  std::mt19937_64 rng(62);
  std::normal_distribution<double> gauss(0.0, 1e-4);
  const Eigen::MatrixXd q = random_readings(truth, 300, 63);
  Log log = testing::blank_marker_log("plates.csv", 300, truth.dof(), 6);
  log.q = q;
  for (int r = 0; r < 300; ++r) {
    const Eigen::VectorXd x = q.row(r).transpose();
    for (int t = 0; t < 2; ++t) {
      const Frame<double> f = prepared.forward(x.data(), t);
      for (int k = 0; k < 3; ++k) {
        const Eigen::Vector3d p = f.R * plate.col(k) + f.p;
        for (int c = 0; c < 3; ++c) log.markers(r, 9 * t + 3 * k + c) = p[c] + gauss(rng);
      }
    }
  }
  std::ofstream(dir + "/plates.csv") << log_to_csv(log);
  CalibrateRequest request;
  request.model = dir + "/two_arm.urdf";
  request.tip = "left_hand,right_hand";
  request.log = dir + "/plates.csv";
  request.options.marker_body = plate;
  request.out = dir + "/cal";
  const CalibrateJob job = run_calibrate_job(request);
  ASSERT_TRUE(job.usable()) << job.result.status_reason;
  EXPECT_EQ(job.result.kinematics.type, MeasurementType::kPose);
  // Each hand's frame at other readings against the truth's (the frame fitted:
  // the calibrated base is the tracker's).
  const PreparedModel fitted(job.result.calibrated);
  const Eigen::MatrixXd other = random_readings(truth, 50, 64);
  double position = 0, angle = 0;
  for (Eigen::Index r = 0; r < other.rows(); ++r) {
    const Eigen::VectorXd x = other.row(r).transpose();
    for (int t = 0; t < 2; ++t) {
      const Frame<double> a = fitted.forward(x.data(), t), b = prepared.forward(x.data(), t);
      position += (a.p - b.p).squaredNorm();
      angle += std::pow(Eigen::AngleAxisd(a.R.transpose() * b.R).angle(), 2);
    }
  }
  position = std::sqrt(position / (2.0 * other.rows()));
  angle = std::sqrt(angle / (2.0 * other.rows()));
  std::printf("tree with marker plates: hands %.4f mm and %.4f mrad RMS from the truth\n",
              1e3 * position, 1e3 * angle);
  EXPECT_LT(position, 2.5e-4);
  EXPECT_LT(angle, 1e-3);
  // evaluate --tip A,B --markers of calibrated.urdf: each hand's pose error on the log.
  EvaluateRequest check;
  check.model = dir + "/cal/calibrated.urdf";
  check.root = "hapticcal_measurement";
  check.tip = request.tip;
  check.log = request.log;
  check.marker_body = plate;
  const EvaluateJob evaluated = run_evaluate_job(check);
  ASSERT_EQ(evaluated.tip_evaluations.size(), 2u);
  for (const Evaluation& e : evaluated.tip_evaluations) {
    ASSERT_TRUE(e.figure("position"));
    EXPECT_LT(e.figure("position")->stats.rms, 5e-4);
  }
  EXPECT_LT(urdf_round_trip_gap(job.result.calibrated, dir + "/cal/calibrated.urdf"), 1e-9);
  std::filesystem::remove_all(dir);
}

// The command line: calibrate --tip A,B on the URDF writes the tree's
// calibrated.urdf and results.json; evaluate --tip A,B of that URDF (from its
// measurement frame) predicts held-out points as the fit does; bad requests
// exit 2 with one line.
TEST(Tree, CalibrateAndEvaluateOnTheCommandLine) {
  const std::string dir = urdf_folder("tree_cli");
  const DeviceModel truth = truth_model(21);
  const Log fit = hands_log(truth, 350, 1e-4, 22);
  const Log held = hands_log(truth, 150, 1e-4, 23);
  std::ofstream(dir + "/fit.csv") << log_to_csv(fit);
  std::ofstream(dir + "/held.csv") << log_to_csv(held);
  const testing::CliResult c =
      testing::run_cli({"calibrate", "--model", dir + "/two_arm.urdf", "--tip",
                        "left_hand,right_hand", "--log", dir + "/fit.csv", "--out", dir + "/cal"});
  ASSERT_EQ(c.exit_code, 0) << c.err << c.out;
  EXPECT_NE(c.out.find("right_hand: "), std::string::npos) << c.out;
  const auto j = nlohmann::json::parse(read_file(dir + "/cal/results.json"));
  // Each tip's joints: the torso's on both paths, an elbow on its arm's only.
  const auto& left = j["tips"]["left_hand"]["joints"];
  const auto& right = j["tips"]["right_hand"]["joints"];
  EXPECT_EQ(left.size(), 7u);
  EXPECT_EQ(left[1], "torso_pitch");
  EXPECT_EQ(right[1], "torso_pitch");
  EXPECT_NE(std::find(left.begin(), left.end(), "l_elbow"), left.end());
  EXPECT_EQ(std::find(right.begin(), right.end(), "l_elbow"), right.end());
  EXPECT_LT(j["tips"]["right_hand"]["rms_after"].get<double>(), 2e-4);
  EXPECT_TRUE(std::filesystem::exists(dir + "/cal/calibrated.yaml"));  // the whole tree
  // The calibrated URDF from its measurement frame predicts the held-out
  // points as the fit's tree does (tip by tip, on the command line's fit).
  CalibrateRequest request;
  request.model = dir + "/two_arm.urdf";
  request.tip = "left_hand,right_hand";
  request.log = dir + "/fit.csv";
  const CalibrateJob in_process = run_calibrate_job(request);
  ASSERT_TRUE(in_process.usable());
  // Each tip's RMS after is the calibrated tree's error on that tip's samples.
  for (int t = 0; t < 2; ++t) {
    const double rms =
        evaluate(in_process.result.calibrated, tip_samples(in_process.result.calibrated, fit, t))
            .figure("position")
            ->stats.rms;
    EXPECT_NEAR(in_process.result.kinematics.tip_rms_after[static_cast<size_t>(t)], rms, 1e-9 * rms)
        << t;
    EXPECT_NEAR(j["tips"][kTips[static_cast<size_t>(t)]]["rms_after"].get<double>(), rms,
                1e-9 * rms);
  }
  const Log held_samples = tip_samples(in_process.result.calibrated, held);
  std::vector<double> expected(2, 0.0), count(2, 0.0);
  const PreparedModel fitted(in_process.result.calibrated);
  for (int r = 0; r < held_samples.rows; ++r) {
    const int t = held_samples.tip[static_cast<size_t>(r)];
    const Eigen::VectorXd q = held_samples.q.row(r).transpose();
    expected[t] +=
        (fitted.forward(q.data(), t).p - held_samples.position.row(r).transpose()).squaredNorm();
    count[t] += 1;
  }
  const testing::CliResult e = testing::run_cli(
      {"evaluate", "--model", dir + "/cal/calibrated.urdf", "--root", "hapticcal_measurement",
       "--tip", "left_hand,right_hand", "--log", dir + "/held.csv", "--json"});
  ASSERT_EQ(e.exit_code, 0) << e.err;
  const auto ev = nlohmann::json::parse(e.out);
  EXPECT_NEAR(ev["tips"]["left_hand"]["rms_position"].get<double>(),
              std::sqrt(expected[0] / count[0]), 1e-9);
  EXPECT_NEAR(ev["tips"]["right_hand"]["rms_position"].get<double>(),
              std::sqrt(expected[1] / count[1]), 1e-9);
  // Bad requests.
  Log one = fit;
  one.marker_count = 1;
  one.markers.conservativeResize(Eigen::NoChange, 3);
  std::ofstream(dir + "/one.csv") << log_to_csv(one);
  testing::expect_input_error(
      testing::run_cli({"calibrate", "--model", dir + "/two_arm.urdf", "--tip",
                        "left_hand,right_hand", "--log", dir + "/one.csv", "--out", dir + "/b"}),
      "2 tips (left_hand, right_hand) need the points x1, y1, z1 .. x2, y2, z2");
  // The tips in another order than the log's: refused, the order that fits named.
  testing::expect_input_error(
      testing::run_cli({"calibrate", "--model", dir + "/two_arm.urdf", "--tip",
                        "right_hand,left_hand", "--log", dir + "/fit.csv", "--out", dir + "/b"}),
      "The log fits the tips in the order left_hand, right_hand: give --tip left_hand,right_hand.");
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
  EXPECT_LT(pj["predicted_rms_sd"]["planned"].get<double>(),
            pj["predicted_rms_sd"]["random_median"].get<double>());
  testing::expect_input_error(
      testing::run_cli({"plan", "--model", dir + "/two_arm.urdf", "--tip", "left_hand,right_hand",
                        "--measurement", "distance", "--poses", "20", "--out", dir + "/b"}),
      "a tree's plan measures its tips' points: position");
  std::filesystem::remove_all(dir);
}

// A row of a tree's log holds every tip's point: the terminal counts rows as
// rows (and says how many points they give), never one a point.
TEST(Tree, ALogsRowsAreCountedAsRowsNotPoints) {
  const std::string dir = urdf_folder("tree_rows");
  const DeviceModel truth = truth_model(31);
  std::ofstream(dir + "/five.csv") << log_to_csv(hands_log(truth, 5, 1e-4, 32));
  testing::expect_input_error(
      testing::run_cli({"calibrate", "--model", dir + "/two_arm.urdf", "--tip",
                        "left_hand,right_hand", "--log", dir + "/five.csv", "--out", dir + "/b"}),
      "too few measurements: 5 poses of 2 tips, 10 points give 30 residuals");
  std::ofstream(dir + "/forty.csv") << log_to_csv(hands_log(truth, 40, 1e-4, 33));
  const testing::CliResult c =
      testing::run_cli({"calibrate", "--model", dir + "/two_arm.urdf", "--tip",
                        "left_hand,right_hand", "--log", dir + "/forty.csv", "--out", dir + "/c"});
  ASSERT_EQ(c.exit_code, 0) << c.err;
  EXPECT_NE(c.out.find("Step 2: kinematic parameters from positions (40 rows of 2 tips, 80 "
                       "points)"),
            std::string::npos)
      << c.out;
  EXPECT_NE(read_file(dir + "/c/report.html").find("<p>40 rows of 2 tips, 80 points, "),
            std::string::npos);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace hapticcal
