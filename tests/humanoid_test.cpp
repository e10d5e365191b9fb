// A humanoid upper body calibrated as one tree (examples/humanoid/upper_body.urdf):
// two 7-joint arms on a torso whose third joint is passive, driven by the two
// torso readings (chest_level = -(torso_lower + torso_upper)); link masses,
// joint and lateral compliance of a realistic size; one mocap marker a hand at
// 0.2 mm, its offset and the mocap frame unknown; 350 poses fitted, 150 held
// out. The points come from the prepared (runtime) model of the truth, whose
// tree kinematics tests/tree_model_test.cpp checks against KDL and a composition
// by hand; the fit forms its rows through the calibration's own stages.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <random>

#include "hapticcal/core/files.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/identification/tree.hpp"
#include "hapticcal/jobs/calibrate_job.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/model_io/urdf.hpp"
#include "held_out.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

const std::string kUpperBody = HAPTICCAL_SOURCE_DIR "/examples/humanoid/upper_body.urdf";
const std::vector<std::string> kHands{"left_hand", "right_hand"};

int link_named(const DeviceModel& m, const std::string& name) {
  for (size_t i = 0; i < m.links.size(); ++i) {
    if (m.links[i].name == name) return static_cast<int>(i);
  }
  ADD_FAILURE() << "no link " << name;
  return 0;
}

// The actual robot: every joint's geometry off by 1 mm / 2 mrad (sd), the mocap
// frame 1.5 m away and turned, each marker 2-3 cm from the hand's nominal
// point, and the compliances below.
struct Compliance {
  std::string joint;
  bool lateral;
  double value;  // rad / N m
};
const std::vector<Compliance> kCompliance{
    {"torso_lower", false, 3e-4},      {"torso_upper", false, 4e-4},
    {"l_shoulder_pitch", false, 1e-3}, {"r_shoulder_pitch", false, 8e-4},
    {"torso_upper", true, -3e-4},      {"r_shoulder_yaw", true, 6e-4}};

DeviceModel actual_robot(const DeviceModel& nominal) {
  DeviceModel m = nominal;
  Eigen::VectorXd v = m.kinematic_parameters();
  std::mt19937_64 rng(51);
  std::normal_distribution<double> gauss(0.0, 1.0);
  for (const ParameterInfo& p : m.parameter_info()) {
    if (p.block == ParameterBlock::kBase) continue;
    v[p.slot] += (p.unit == ParameterUnit::kLength ? 1e-3 : 2e-3) * gauss(rng);
  }
  v.head<6>() << 1.5, -0.3, 0.4, 0.04, -0.08, 2.2;
  for (int t = 0; t < m.tips(); ++t)
    v.segment<3>(m.tool_slot(t)) += Eigen::Vector3d(0.02, -0.015, 0.03);
  m.set_kinematic_parameters(v);
  for (const Compliance& c : kCompliance) {
    Link& l = m.links[static_cast<size_t>(link_named(m, c.joint))];
    (c.lateral ? l.lateral_compliance : l.compliance) = c.value;
  }
  return m;
}

// `rows` poses within the joint limits, each hand's marker with noise `sigma`
// a coordinate (x1, y1, z1 the left hand's, x2, ... the right's).
Log marker_log(const DeviceModel& actual, int rows, double sigma, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  Log log = testing::blank_marker_log("mocap.csv", rows, actual.dof(), actual.tips());
  const PreparedModel prepared(actual);
  for (int r = 0; r < rows; ++r) {
    for (int j = 0; j < actual.dof(); ++j) {
      const Link& l = actual.links[static_cast<size_t>(j)];
      log.q(r, j) = std::uniform_real_distribution<double>(l.lower, l.upper)(rng);
    }
    const Eigen::VectorXd q = log.q.row(r).transpose();
    for (int t = 0; t < actual.tips(); ++t) {
      const Eigen::Vector3d p = prepared.forward(q.data(), t).p;
      for (int x = 0; x < 3; ++x) log.markers(r, 3 * t + x) = p[x] + sigma * gauss(rng);
    }
  }
  return log;
}

// The same as one sample a tip (tip_samples).
Log marker_samples(const DeviceModel& actual, int rows, double sigma, std::uint64_t seed) {
  return tip_samples(actual, marker_log(actual, rows, sigma, seed));
}

// RMS of |predicted - measured| over a tree's samples.
double held_out(const DeviceModel& m, const Log& samples) {
  const PreparedModel prepared(m);
  double sum = 0;
  for (int r = 0; r < samples.rows; ++r) {
    const Eigen::VectorXd q = samples.q.row(r).transpose();
    sum += (prepared.forward(q.data(), samples.tip[static_cast<size_t>(r)]).p -
            samples.position.row(r).transpose())
               .squaredNorm();
  }
  return std::sqrt(sum / samples.rows);
}

// Tip k's samples as its own chain's log: the readings of its path.
Log arm_log(const DeviceModel& tree, const Log& samples, int tip) {
  const std::vector<int> path = tree.path(tip);
  Log out = testing::blank_marker_log("arm.csv", 0, static_cast<int>(path.size()), 0);
  std::vector<int> rows;
  for (int r = 0; r < samples.rows; ++r) {
    if (samples.tip[static_cast<size_t>(r)] == tip) rows.push_back(r);
  }
  out.rows = static_cast<int>(rows.size());
  out.q.resize(out.rows, static_cast<Eigen::Index>(path.size()));
  out.position.resize(out.rows, 3);
  out.has_position = true;
  out.ext.setZero(out.rows, out.q.cols());
  out.direction.setZero(out.rows, out.q.cols());
  for (int i = 0; i < out.rows; ++i) {
    for (size_t j = 0; j < path.size(); ++j)
      out.q(i, static_cast<Eigen::Index>(j)) = samples.q(rows[static_cast<size_t>(i)], path[j]);
    out.position.row(i) = samples.position.row(rows[static_cast<size_t>(i)]);
    out.line.push_back(i + 2);
  }
  return out;
}

TEST(Humanoid, UpperBodyWithComplianceCalibratesAsOneTree) {
  const std::string text = read_file(kUpperBody, FileKind::kUrdf);
  const DeviceModel nominal = tree_model(parse_tree(text, kUpperBody, kHands));
  ASSERT_EQ(nominal.dof(), 17);
  ASSERT_TRUE(nominal.coupled());
  const int chest = link_named(nominal, "chest_level");
  EXPECT_EQ(nominal.coupling(chest, 0), -1.0);
  EXPECT_EQ(nominal.coupling(chest, 1), -1.0);
  EXPECT_FALSE(nominal.reading_used(chest));
  const DeviceModel actual = actual_robot(nominal);
  const double sigma = 2e-4;
  const Log fit_log = marker_samples(actual, 350, sigma, 52);
  const Log test = marker_samples(actual, 150, sigma, 53);
  const double floor = held_out(actual, test);

  CalibrationOptions both;
  both.joint_errors = {"compliance", "lateral"};
  const CalibrationResult tree = calibrate(nominal, fit_log, both);
  ASSERT_EQ(tree.status, CalibrationStatus::kConverged) << tree.status_reason;
  const double with = held_out(tree.calibrated, test);
  EXPECT_LT(with, 1.1 * floor) << with << " floor " << floor;
  for (const Compliance& c : kCompliance) {
    const std::string name = c.joint + (c.lateral ? ".kx" : ".k");
    const ParameterEstimate* e = testing::find_parameter(tree.kinematics, name);
    ASSERT_NE(e, nullptr) << name;
    EXPECT_LT(std::abs(e->value - c.value), 3 * e->sd)
        << name << " " << e->value << " +- " << e->sd;
    std::printf("%s: %.4g +- %.2g (truth %.4g)\n", name.c_str(), e->value, e->sd, c.value);
  }
  // The tree without compliance.
  CalibrationOptions none;
  none.joint_errors = {"none"};
  const double rigid = held_out(calibrate(nominal, fit_log, none).calibrated, test);
  EXPECT_GT(rigid, 2 * with) << rigid;
  // Each arm alone, with both families: its torso carries one arm, not two.
  std::array<double, 2> arm_rms{};
  for (int tip = 0; tip < 2; ++tip) {
    const DeviceModel arm = parse_urdf(text, kUpperBody, kHands[static_cast<size_t>(tip)]);
    ASSERT_TRUE(arm.coupled());
    const CalibrationResult alone = calibrate(arm, arm_log(nominal, fit_log, tip), both);
    const Log arm_test = arm_log(nominal, test, tip);
    const PreparedModel prepared(alone.calibrated);
    double sum = 0;
    for (int r = 0; r < arm_test.rows; ++r) {
      const Eigen::VectorXd q = arm_test.q.row(r).transpose();
      sum += (prepared.forward(q.data()).p - arm_test.position.row(r).transpose()).squaredNorm();
    }
    arm_rms[static_cast<size_t>(tip)] = std::sqrt(sum / arm_test.rows);
    EXPECT_GT(arm_rms[static_cast<size_t>(tip)], 2 * with) << kHands[static_cast<size_t>(tip)];
  }
  // The default (the model search) finds both families without flags.
  const CalibrationResult found = calibrate(nominal, fit_log, CalibrationOptions{});
  const ModelSearch& search = found.kinematics.search;
  ASSERT_GE(search.kept, 0) << search.note;
  EXPECT_EQ(search.candidates[static_cast<size_t>(search.kept)].families,
            (std::vector<std::string>{"compliance", "lateral"}));
  EXPECT_LT(held_out(found.calibrated, test), 1.1 * floor);
  std::printf(
      "humanoid, held-out RMS [mm]: floor %.4f, tree + both families %.4f, tree rigid %.4f, left "
      "arm alone %.4f, right arm alone %.4f, default %.4f\n",
      1e3 * floor, 1e3 * with, 1e3 * rigid, 1e3 * arm_rms[0], 1e3 * arm_rms[1],
      1e3 * held_out(found.calibrated, test));
}

// The tree's whole model (both families) in calibrated.yaml, read back to the
// in-memory model's error to 1e-9 m by evaluate (which takes a device file's
// own tips); calibrated.urdf, the geometry alone fitted as such, read by
// evaluate from its measurement frame without --root, to the geometry-only
// model's error.
TEST(Humanoid, WholeTreeIsWrittenAndReadBack) {
  const DeviceModel nominal = tree_model(load_tree(kUpperBody, kHands));
  const DeviceModel actual = actual_robot(nominal);
  const std::string dir = testing::fresh_folder("humanoid_whole");
  write_file_atomically(dir + "/fit.csv", log_to_csv(marker_log(actual, 350, 2e-4, 52)));
  write_file_atomically(dir + "/test.csv", log_to_csv(marker_log(actual, 150, 2e-4, 53)));
  const Log test = marker_samples(actual, 150, 2e-4, 53);
  CalibrateRequest request;
  request.model = kUpperBody;
  request.tip = "left_hand,right_hand";
  request.log = dir + "/fit.csv";
  request.options.joint_errors = {"compliance", "lateral"};
  const CalibrateJob job = run_calibrate_job(request);
  ASSERT_TRUE(job.usable()) << job.result.status_reason;
  ASSERT_TRUE(job.result.geometry);  // the URDF's model: the geometry fitted alone
  const testing::CliResult c = testing::run_cli(
      {"calibrate", "--model", kUpperBody, "--tip", "left_hand,right_hand", "--log",
       dir + "/fit.csv", "--joint-errors", "compliance,lateral", "--out", dir + "/cal"});
  ASSERT_EQ(c.exit_code, 0) << c.out << c.err;
  const DeviceModel whole = load_device(dir + "/cal/calibrated.yaml");
  ASSERT_EQ(whole.tips(), 2);
  EXPECT_EQ(whole.tip_name(1), "right_hand");
  EXPECT_NE(
      whole.links[static_cast<size_t>(link_named(whole, "r_shoulder_yaw"))].lateral_compliance,
      0.0);
  const CalibrationResult& urdf_model = geometry_model(job.result);
  const auto per_tip = [&](const DeviceModel& m, int tip) {
    Log only = test;
    std::vector<int> rows;
    for (int r = 0; r < test.rows; ++r) {
      if (test.tip[static_cast<size_t>(r)] == tip) rows.push_back(r);
    }
    double sum = 0;
    const PreparedModel prepared(m);
    for (int r : rows) {
      const Eigen::VectorXd q = test.q.row(r).transpose();
      sum += (prepared.forward(q.data(), tip).p - test.position.row(r).transpose()).squaredNorm();
    }
    return std::sqrt(sum / static_cast<double>(rows.size()));
  };
  const testing::CliResult e = testing::run_cli(
      {"evaluate", "--model", dir + "/cal/calibrated.yaml", "--log", dir + "/test.csv", "--json"});
  ASSERT_EQ(e.exit_code, 0) << e.err;
  const testing::CliResult u =
      testing::run_cli({"evaluate", "--model", dir + "/cal/calibrated.urdf", "--tip",
                        "left_hand,right_hand", "--log", dir + "/test.csv", "--json"});
  ASSERT_EQ(u.exit_code, 0) << u.err;
  // plan reads the tree's device file: its poses measure both hands (17 readings).
  const testing::CliResult p =
      testing::run_cli({"plan", "--model", dir + "/cal/calibrated.yaml", "--measurement",
                        "position", "--poses", "20", "--out", dir + "/plan"});
  ASSERT_EQ(p.exit_code, 0) << p.err;
  EXPECT_EQ(testing::slurp(dir + "/plan/plan.csv").rfind("q1,", 0), 0u);
  EXPECT_NE(testing::slurp(dir + "/plan/plan.csv").find("q17"), std::string::npos);
  const nlohmann::json yaml_rms = nlohmann::json::parse(e.out)["tips"];
  const nlohmann::json urdf_rms = nlohmann::json::parse(u.out)["tips"];
  for (int t = 0; t < 2; ++t) {
    const std::string& hand = kHands[static_cast<size_t>(t)];
    const double in_memory = per_tip(job.result.calibrated, t);
    EXPECT_NEAR(yaml_rms[hand]["rms_position"].get<double>(), in_memory, 1e-9) << hand;
    EXPECT_NEAR(urdf_rms[hand]["rms_position"].get<double>(), per_tip(urdf_model.calibrated, t),
                1e-9)
        << hand;
    std::printf("%s held out: calibrated.yaml %.4f mm, calibrated.urdf %.4f mm\n", hand.c_str(),
                1e3 * yaml_rms[hand]["rms_position"].get<double>(),
                1e3 * urdf_rms[hand]["rms_position"].get<double>());
  }
}

}  // namespace
}  // namespace hapticcal
