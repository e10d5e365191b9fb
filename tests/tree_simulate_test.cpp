// simulate on a tree of several tips (examples/two-arm: a torso and two arms):
// the study's files read back and scored here by the tree's own kinematics,
// its simulated points against the truth's, its Monte Carlo against the
// Cramer-Rao bound, and what a tree cannot be simulated with refused.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "hapticcal/data_io/log.hpp"
#include "hapticcal/identification/tree.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/device.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

const std::string kUrdf = HAPTICCAL_SOURCE_DIR "/examples/two-arm/two_arm.urdf";

std::string scenario(const std::string& dir, const std::string& extra) {
  const std::string path = dir + "/scenario.yaml";
  std::ofstream(path) << "format: hapticcal-scenario/1\ndevice: " << kUrdf
                      << "\ntip: left_hand,right_hand\n"
                      << extra;
  return path;
}

// RMS over a tree's samples of |a's tip point - b's| (the samples' tips).
double rms_between(const DeviceModel& a, const DeviceModel& b, const Log& samples) {
  const PreparedModel pa(a), pb(b);
  double sum = 0;
  for (int r = 0; r < samples.rows; ++r) {
    const Eigen::VectorXd q = samples.q.row(r).transpose();
    const int tip = samples.tip[static_cast<size_t>(r)];
    sum += (pa.forward(q.data(), tip).p - pb.forward(q.data(), tip).p).squaredNorm();
  }
  return std::sqrt(sum / samples.rows);
}

// Least squares on every identifiable parameter (keep_all), 30 trials: the
// first trial's files are the tree's (nominal, truth and calibrated device
// files; a point a hand); its validation figures are what the files give;
// the simulated points scatter about the truth's by the stated noise; and the
// estimates' RMSE over the trials is the Cramer-Rao bound's (median ratio).
TEST(TreeSimulate, StudiesATreeMeasuredByAPointAHand) {
  const std::string dir = testing::fresh_folder("tree_simulate");
  const std::string out = dir + "/out";
  const testing::CliResult r =
      testing::run_cli({"simulate", "--scenario",
                        scenario(dir,
                                 "trials: 30\ncalibration: {keep_all: true}\n"
                                 "poses: {identification: 200, validation: 50}\n"),
                        "--out", out});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(testing::slurp(out + "/results.json"));
  EXPECT_EQ(j["measurement"], "position");

  const DeviceModel nominal = load_device(out + "/nominal.yaml");
  const DeviceModel truth = load_device(out + "/actual.yaml");
  const DeviceModel calibrated = load_device(out + "/calibrated.yaml");
  ASSERT_EQ(truth.tips(), 2);
  ASSERT_EQ(calibrated.tips(), 2);
  const Log validation = tip_samples(truth, read_log(out + "/validation.csv"));
  ASSERT_EQ(validation.rows, 2 * 50);
  const nlohmann::json& v = j["validation"];
  EXPECT_NEAR(v["position_rms_before"].get<double>(), rms_between(nominal, truth, validation),
              1e-12);
  EXPECT_NEAR(v["position_rms_after"].get<double>(), rms_between(calibrated, truth, validation),
              1e-12);
  EXPECT_LT(v["position_rms_after"].get<double>(), v["position_rms_before"].get<double>() / 100);
  // No distance: neither the validation's nor a trajectory's.
  EXPECT_TRUE(v["distance_rms_before"].is_null());
  EXPECT_TRUE(j["trajectory"]["rms_full"].is_null());
  EXPECT_FALSE(std::filesystem::exists(out + "/trajectory.csv"));

  // Each hand's simulated point: the truth's, with the stated noise.
  const Log ident = read_log(out + "/identification.csv");
  ASSERT_EQ(ident.marker_count, 2);
  const PreparedModel actual(truth);
  double sum = 0;
  for (int row = 0; row < ident.rows; ++row) {
    const Eigen::VectorXd q = ident.q.row(row).transpose();
    for (int tip = 0; tip < 2; ++tip) {
      sum +=
          (actual.forward(q.data(), tip).p - ident.markers.row(row).segment<3>(3 * tip).transpose())
              .squaredNorm();
    }
  }
  const double sigma = j["noise"]["sigma_m"].get<double>();
  EXPECT_NEAR(std::sqrt(sum / (3.0 * 2 * ident.rows)), sigma, 0.1 * sigma);

  // RMSE / CRLB over 30 trials: 1 for an efficient estimator; a median over
  // the parameters within 15 % of it.
  std::vector<double> ratio;
  for (const auto& [name, m] : j["monte_carlo"].items()) {
    if (m["efficiency"].is_number()) ratio.push_back(m["efficiency"].get<double>());
  }
  ASSERT_GT(ratio.size(), 40u);
  std::nth_element(ratio.begin(), ratio.begin() + ratio.size() / 2, ratio.end());
  const double median = ratio[ratio.size() / 2];
  std::printf("tree study: %zu parameters, median RMSE / CRLB %.3f\n", ratio.size(), median);
  EXPECT_NEAR(median, 1.0, 0.15);
}

// What a tree is not simulated with: distances (a cable encoder measures one
// tool point), ISO 9283's test of one tool, a hand-guided session.
TEST(TreeSimulate, RefusesWhatATreeIsNotMeasuredBy) {
  const std::string dir = testing::fresh_folder("tree_simulate_refused");
  for (const auto& [extra, expected] : std::vector<std::pair<std::string, std::string>>{
           {"measurement: distance\n", "one point a tip: position, not distance"},
           {"iso9283: {cycles: 3}\n", "a tree of several tips runs none"},
           {"measurement: position\nsession: {seconds: 10}\n", "of one chain, not a tree"}}) {
    const testing::CliResult r =
        testing::run_cli({"simulate", "--scenario", scenario(dir, extra), "--out", dir + "/out"});
    EXPECT_EQ(r.exit_code, 2) << extra;
    EXPECT_NE(r.err.find(expected), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir + "/out"));
  }
}

}  // namespace
}  // namespace hapticcal
