// `hapticcal evaluate` on real data (Meca500 laser tracker) and on synthetic
// distance logs, checked against independent computations.
#include "hapticcal/study/evaluate.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>

#include "hapticcal/kinematics/kinematics.hpp"
#include "kdl_chain.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

const char* kMecaColumns = "'q1[deg],q2[deg],q3[deg],q4[deg],q5[deg],q6[deg],x,y,z,_,_,_'";

std::vector<std::vector<double>> read_numbers(const std::string& path, char sep) {
  std::ifstream in(path);
  std::vector<std::vector<double>> rows;
  std::string line;
  while (std::getline(in, line)) {
    std::vector<double> row;
    std::stringstream ss(line);
    std::string field;
    if (sep == ' ') {
      double v;
      while (ss >> v) row.push_back(v);
    } else {
      while (std::getline(ss, field, sep)) row.push_back(std::stod(field));
    }
    if (!row.empty()) rows.push_back(row);
  }
  return rows;
}

// The data README's model, straight from the raw files with KDL:
// p_tracker = T_base * A_1 ... A_6 * p_tool (mm), modified DH.
double independent_meca500_rms_mm(const std::string& dir, const std::string& log) {
  const auto base = read_numbers(dir + "/T_base.txt", ' ');
  const auto tool = read_numbers(dir + "/T_tool.txt", ' ');
  const auto mdh = read_numbers(dir + "/mdh_nominal.csv", ',');
  KDL::Frame T_base;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) T_base.M(r, c) = base[r][c];
    T_base.p[r] = base[r][3];
  }
  KDL::Chain chain;
  chain.addSegment(KDL::Segment(KDL::Joint(KDL::Joint::None), T_base));
  for (const auto& row : mdh) {  // alpha, a, theta_offset, d
    chain.addSegment(
        KDL::Segment(KDL::Joint(KDL::Joint::None), KDL::Frame::DH_Craig1989(row[1], row[0], 0, 0)));
    chain.addSegment(
        KDL::Segment(KDL::Joint(KDL::Joint::RotZ), KDL::Frame::DH_Craig1989(0, 0, row[3], row[2])));
  }
  chain.addSegment(KDL::Segment(KDL::Joint(KDL::Joint::None),
                                KDL::Frame(KDL::Vector(tool[0][3], tool[1][3], tool[2][3]))));
  KDL::ChainFkSolverPos_recursive fk(chain);
  double sum = 0;
  const auto rows = read_numbers(dir + "/" + log, ',');
  for (const auto& row : rows) {
    KDL::JntArray q(6);
    for (int i = 0; i < 6; ++i) q(i) = row[i] * M_PI / 180;
    KDL::Frame f;
    fk.JntToCart(q, f);
    const KDL::Vector e = f.p - KDL::Vector(row[6] * 1e3, row[7] * 1e3, row[8] * 1e3);
    sum += KDL::dot(e, e);
  }
  return std::sqrt(sum / rows.size());
}

TEST(Evaluate, Meca500ValidationRmsIs0837MillimetresAsTheRawDataGive) {
  const std::string dir = testing::real_data_path("meca500");
  const std::string log = "val-norm_dist_data_0deg_160cube.csv";
  ASSERT_TRUE(std::filesystem::exists(dir + "/" + log)) << "missing from the repository: " << dir;
  const testing::CliResult r = testing::run_cli(
      "evaluate --json --model " +
      testing::write_meca500_on_tracker(::testing::TempDir() + "/meca500-on-tracker.yaml") +
      " --log " + dir + "/" + log + " --columns " + kMecaColumns);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["n"], 30);
  EXPECT_FALSE(j.contains("rms_distance"));
  const double rms_mm = j["rms_position"].get<double>() * 1e3;
  EXPECT_NEAR(rms_mm, 0.837, 0.0005);
  EXPECT_NEAR(rms_mm, independent_meca500_rms_mm(dir, log), 1e-8);
  EXPECT_GE(j["max_position"].get<double>(), j["rms_position"].get<double>());
}

TEST(Evaluate, ShippedConvertedLogsGiveTheSameAsRawLogsWithColumns) {
  const std::string dir = testing::real_data_path("meca500");
  const std::string model = testing::source_path("examples/meca500/meca500.yaml");
  for (const auto& e :
       std::filesystem::directory_iterator(testing::source_path("examples/meca500"))) {
    const std::string name = e.path().filename().string();
    if (!name.ends_with(".csv")) continue;
    const auto shipped =
        testing::run_cli("evaluate --json --model " + model + " --log " + e.path().string());
    const auto raw = testing::run_cli("evaluate --json --model " + model + " --log " + dir + "/" +
                                      name + " --columns " + kMecaColumns);
    ASSERT_EQ(shipped.exit_code, 0) << shipped.err;
    EXPECT_EQ(shipped.out, raw.out) << name;
  }
}

TEST(Evaluate, DistanceLogReportsDistanceKeysOnly) {
  const DeviceModel model = testing::builtin("baser-7dof");
  const PreparedModel prepared(model);
  std::mt19937_64 rng(4);
  std::string csv = "q1,q2,q3,q4,q5,q6,q7,distance[mm]\n";
  std::vector<double> errors;
  for (int r = 0; r < 50; ++r) {
    const Eigen::VectorXd q = testing::random_readings(model, rng);
    const double err = (r % 2 ? 1 : -1) * 1e-4 * (r + 1);  // known errors
    errors.push_back(err);
    const double measured_mm = (prepared.forward(q.data()).p.norm() - err) * 1e3;
    for (int i = 0; i < 7; ++i) csv += fmt::format("{},", q[i]);
    csv += fmt::format("{}\n", measured_mm);
  }
  const std::string path = ::testing::TempDir() + "/distance_log.csv";
  std::ofstream(path) << csv;
  const auto r =
      testing::run_cli("evaluate --json --model " +
                       testing::source_path("data/devices/baser-7dof.yaml") + " --log " + path);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  double sum = 0, max = 0;
  for (double e : errors) {
    sum += e * e;
    max = std::max(max, std::abs(e));
  }
  EXPECT_NEAR(j["rms_distance"].get<double>(), std::sqrt(sum / errors.size()), 1e-12);
  EXPECT_NEAR(j["max_distance"].get<double>(), max, 1e-12);
  EXPECT_FALSE(j.contains("rms_position"));
  std::filesystem::remove(path);
}

TEST(Evaluate, HumanReadableOutputGivesMillimetres) {
  const auto r = testing::run_cli(
      "evaluate --model " +
      testing::write_meca500_on_tracker(::testing::TempDir() + "/meca500-on-tracker.yaml") +
      " --log " + testing::source_path("examples/meca500/val-norm_dist_data_0deg_160cube.csv"));
  ASSERT_EQ(r.exit_code, 0);
  EXPECT_NE(r.out.find("position error: RMS 0.837"), std::string::npos) << r.out;
}

TEST(Evaluate, ImprovementFollowsPaperEquation9) {
  EXPECT_NEAR(rms_improvement_pct(0.034, 1.0), 96.6, 1e-12);
  EXPECT_NEAR(rms_improvement_pct(0.5531, 1.0), 44.69, 1e-12);
  EXPECT_NEAR(rms_improvement_pct(2.0, 1.0), -100.0, 1e-12);  // worse: negative, not hidden
}

// Pose logs: the orientation error is the angle between predicted and measured
// tool rotations. A tool turned by 0.01 rad about its own z axis (no position
// change for a tool point on that axis) shows 0.01 rad on every row.
TEST(Evaluate, PoseLogsReportTheOrientationError) {
  DeviceModel truth = testing::meca500();
  truth.tool = {0, 0, 0.05, 0, 0, 0};
  std::mt19937_64 rng(4);
  const Log log = testing::pose_log(truth, 20, rng);
  EXPECT_LT(evaluate(truth, log).figure("orientation")->stats.max, 1e-12);
  DeviceModel turned = truth;
  turned.tool[5] = 0.01;
  const Evaluation e = evaluate(turned, log);
  ASSERT_TRUE(e.figure("orientation") && e.figure("position"));
  EXPECT_NEAR(e.figure("orientation")->stats.rms, 0.01, 1e-12);
  EXPECT_NEAR(e.figure("orientation")->stats.max, 0.01, 1e-12);
  EXPECT_LT(e.figure("position")->stats.max, 1e-12);
}

// Without --register nothing is fitted: stdout is byte for byte what evaluate
// printed before the option existed (tests/reference/evaluate-*, written by
// that version, when the example's device file held the tracker's placement:
// it is written again here, under the same relative name), JSON and terminal
// lines alike.
TEST(Evaluate, OutputWithoutRegisterIsUnchanged) {
  const std::string meca = "examples/meca500/meca500.yaml";
  const std::string val = "examples/meca500/val-norm_dist_data_0deg_160cube.csv";
  const std::string cal = "examples/meca500/cal-norm_dist_data_0deg_160cube.csv";
  const std::string dir = testing::fresh_folder("evaluate_unchanged_in");
  std::filesystem::create_directories(dir + "/examples/meca500");
  testing::write_meca500_on_tracker(dir + "/" + meca);
  for (const std::string& log : {val, cal})
    std::filesystem::copy_file(testing::source_path(log), dir + "/" + log);
  const auto json = testing::run_cli_in(dir, {"evaluate", "--json", "--model", meca, "--log", val});
  EXPECT_EQ(json.out,
            testing::slurp(testing::source_path("tests/reference/evaluate-meca500-val.json")));
  const auto ref = testing::run_cli_in(
      dir, {"evaluate", "--json", "--model", meca, "--log", val, "--reference", meca});
  EXPECT_EQ(
      ref.out,
      testing::slurp(testing::source_path("tests/reference/evaluate-meca500-val-reference.json")));
  const auto text =
      testing::run_cli_in(dir, {"evaluate", "--model", meca, "--log", cal, "--reference", meca,
                                "--out", testing::fresh_folder("evaluate_unchanged")});
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_EQ(
      text.out.substr(0, text.out.find("report: ")),
      testing::slurp(testing::source_path("tests/reference/evaluate-meca500-cal-reference.txt")));
}

}  // namespace
}  // namespace hapticcal
