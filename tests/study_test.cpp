// The simulation study: reproducibility, the honest pipeline's files, scenario
// files, and the Monte Carlo efficiency against the Cramer-Rao bound.
#include "hapticcal/study/study.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/model_io/device.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

std::string device() { return testing::source_path("data/devices/baser-7dof.yaml"); }

// A parameter by its dotted name ("j4.alpha", "base.a", "j1.r_out") in a device
// file: a kinematic parameter or a transmission's.
double parameter_value(const DeviceModel& m, const std::string& name) {
  const Eigen::VectorXd kinematic = m.kinematic_parameters();
  for (const ParameterInfo& info : m.parameter_info()) {
    if (info.name == name) return kinematic[info.slot];
  }
  for (const Link& link : m.links) {
    const std::vector<std::string> names = link.transmission.parameter_names();
    const Eigen::VectorXd values = link.transmission.parameters();
    for (std::size_t k = 0; k < names.size(); ++k) {
      if (link.name + "." + names[k] == name) return values[static_cast<Eigen::Index>(k)];
    }
  }
  ADD_FAILURE() << "no parameter " << name;
  return std::numeric_limits<double>::quiet_NaN();
}

TEST(Study, SameSeedGivesTheSameResultsByteForByteWhateverTheThreadCount) {
  const std::string a = ::testing::TempDir() + "/study_a", b = ::testing::TempDir() + "/study_b",
                    c = ::testing::TempDir() + "/study_c";
  for (const std::string& d : {a, b, c}) std::filesystem::remove_all(d);
  ASSERT_EQ(testing::run_cli("simulate --trials 6 --threads 1 --out " + a).exit_code, 0);
  ASSERT_EQ(testing::run_cli("simulate --trials 6 --threads 2 --out " + b).exit_code, 0);
  ASSERT_EQ(testing::run_cli("simulate --trials 6 --threads 2 --seed 2 --out " + c).exit_code, 0);
  for (const char* file : {"/results.json", "/identification.csv", "/calibrated.yaml"}) {
    EXPECT_EQ(read_file(a + file), read_file(b + file)) << file;
  }
  EXPECT_NE(read_file(a + "/results.json"), read_file(c + "/results.json"));
  for (const std::string& d : {a, b, c}) std::filesystem::remove_all(d);
}

// Every number of `actual` equals `expected`'s to a relative 1e-9 (keys,
// strings and nulls exactly).
void expect_same_json(const nlohmann::json& expected, const nlohmann::json& actual,
                      const std::string& path) {
  if (expected.is_number() && actual.is_number()) {
    const double e = expected.get<double>(), a = actual.get<double>();
    EXPECT_NEAR(a, e, 1e-9 * std::max(1.0, std::abs(e))) << path;
    return;
  }
  ASSERT_EQ(expected.type(), actual.type()) << path;
  if (expected.is_object()) {
    ASSERT_EQ(expected.size(), actual.size()) << path;
    for (auto it = expected.begin(); it != expected.end(); ++it) {
      ASSERT_TRUE(actual.contains(it.key())) << path << "." << it.key();
      expect_same_json(it.value(), actual[it.key()], path + "." + it.key());
    }
  } else if (expected.is_array()) {
    ASSERT_EQ(expected.size(), actual.size()) << path;
    for (size_t i = 0; i < expected.size(); ++i)
      expect_same_json(expected[i], actual[i], path + "[" + std::to_string(i) + "]");
  } else {
    EXPECT_EQ(expected, actual) << path;
  }
}

// `make run`'s results.json as the release before issue 10 wrote it (commit
// 43b6bb0, its device path removed): the trust changes must not move them.
// Keys added since are checked and removed first.
TEST(Study, MainJobResultsAreUnchangedFromThePreviousRelease) {
  const std::string out = ::testing::TempDir() + "/study_main_job";
  std::filesystem::remove_all(out);
  ASSERT_EQ(testing::run_cli("simulate --out " + out).exit_code, 0);
  nlohmann::json now = nlohmann::json::parse(read_file(out + "/results.json"));
  now.erase("device");
  // Added since (issue 15): each parameter's deviations from nominal, derived.
  for (auto& [name, p] : now["parameters"].items()) {
    EXPECT_EQ(p["assigned_deviation"].get<double>(),
              p["assigned"].get<double>() - p["nominal"].get<double>())
        << name;
    EXPECT_EQ(p["identified_deviation"].get<double>(),
              p["identified"].get<double>() - p["nominal"].get<double>())
        << name;
    p.erase("assigned_deviation");
    p.erase("identified_deviation");
  }
  expect_same_json(nlohmann::json::parse(read_file(
                       testing::source_path("tests/reference/simulate_seed1_results.json"))),
                   now, "results");
}

TEST(Study, PipelineWritesWhatARealExperimentWouldAndScoresAgainstTheTruth) {
  const std::string out = ::testing::TempDir() + "/study_files";
  std::filesystem::remove_all(out);
  const testing::CliResult r = testing::run_cli("simulate --out " + out);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("Table 2 analogue"), std::string::npos);
  EXPECT_NE(r.out.find("Table 3 analogue"), std::string::npos);
  const Log ident = read_log(out + "/identification.csv");
  EXPECT_EQ(ident.rows, 200);
  EXPECT_EQ(ident.dof(), 7);
  EXPECT_TRUE(ident.has_distance);
  EXPECT_TRUE(ident.has_ext[0] && ident.has_ext[3] && !ident.has_ext[4]);
  const Log traj = read_log(out + "/trajectory.csv");
  EXPECT_EQ(traj.rows, 100000);
  EXPECT_NEAR(traj.t[traj.rows - 1], 99.999, 1e-9);
  EXPECT_EQ(traj.q.row(0).norm(), 0.0);  // at rest at home
  for (const char* f : {"/nominal.yaml", "/actual.yaml", "/calibrated.yaml"}) {
    EXPECT_EQ(load_device(out + f).dof(), 7) << f;
  }
  for (const char* f : {"/fig7_j4.csv", "/fig8_validation.csv", "/fig10_trajectory.csv"}) {
    EXPECT_TRUE(std::filesystem::exists(out + f)) << f;
  }
  // Every parameter's row in results.json against the device files the run
  // wrote: assigned from actual.yaml, nominal from nominal.yaml, identified from
  // calibrated.yaml, the improvement I = (1 - |assigned - identified| /
  // |assigned - nominal|) 100 (paper section 5) from those, and the identified
  // value within 5 Cramer-Rao standard deviations of the truth.
  const auto j = nlohmann::json::parse(read_file(out + "/results.json"));
  const DeviceModel nominal = load_device(out + "/nominal.yaml"),
                    actual = load_device(out + "/actual.yaml"),
                    calibrated = load_device(out + "/calibrated.yaml");
  EXPECT_EQ(j["parameters"].size(), 28u + 15u);
  int capstan_rows = 0;
  for (const auto& [name, p] : j["parameters"].items()) {
    SCOPED_TRACE(name);
    const double assigned = parameter_value(actual, name),
                 nominal_value = parameter_value(nominal, name),
                 identified = parameter_value(calibrated, name);
    auto near = [](double a, double b) { return std::abs(a - b) <= 1e-12 * (1 + std::abs(b)); };
    EXPECT_PRED2(near, p["assigned"].get<double>(), assigned);
    EXPECT_PRED2(near, p["nominal"].get<double>(), nominal_value);
    EXPECT_PRED2(near, p["identified"].get<double>(), identified);
    ASSERT_NE(assigned, nominal_value);
    EXPECT_NEAR(p["improvement_pct"].get<double>(),
                (1 - std::abs(assigned - identified) / std::abs(assigned - nominal_value)) * 100,
                1e-6);
    ASSERT_TRUE(p["crlb_sd"].is_number());
    EXPECT_LT(std::abs(identified - assigned), 5 * p["crlb_sd"].get<double>());
    if (name.find("_out") != std::string::npos || name.find("_in") != std::string::npos) {
      ++capstan_rows;
    }
  }
  EXPECT_EQ(capstan_rows, 3 * 4);  // r and beta of both drums of capstans 1-3
  // Fig. 8 and Fig. 10 (eq. 9): calibration helps, the kinematic-only one less.
  EXPECT_LT(j["validation"]["position_rms_after"].get<double>(),
            0.1 * j["validation"]["position_rms_before"].get<double>());
  const double full = j["trajectory"]["improvement_full_pct"],
               kin = j["trajectory"]["improvement_kinematic_only_pct"];
  EXPECT_GT(full, 95.0);
  EXPECT_GT(kin, 20.0);
  EXPECT_LT(kin, 80.0);
  std::filesystem::remove_all(out);
}

TEST(Study, ScenarioFileChangesTheStudyAndRejectsUnknownKeys) {
  const std::string dir = ::testing::TempDir() + "/scenario";
  std::filesystem::create_directories(dir);
  std::ofstream(dir + "/good.yaml") << "format: hapticcal-scenario/1\n"
                                    << "device: " << device() << "\n"
                                    << "seed: 5\ntrials: 3\n"
                                    << "poses: {identification: 150, validation: 50}\n"
                                    << "trajectory: {seconds: 10, rate_hz: 100}\n"
                                    << "noise: {sigma_m: consistent}\n"
                                    << "deviations: {j2.a: 0.002}\n";
  const Scenario sc = load_scenario(dir + "/good.yaml", device());
  EXPECT_EQ(sc.seed, 5u);
  EXPECT_EQ(sc.trials, 3);
  EXPECT_EQ(sc.identification_poses, 150);
  EXPECT_DOUBLE_EQ(sc.noise.sigma_distance, kPaperSigmaMConsistent);
  EXPECT_DOUBLE_EQ(sc.actual.links[1].a - sc.nominal.links[1].a, 0.002);
  std::ofstream(dir + "/bad.yaml")
      << "format: hapticcal-scenario/1\nposes: {identification: 150, colour: 3}\n";
  try {
    load_scenario(dir + "/bad.yaml", device());
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.yaml:2: poses.colour: unknown key"),
              std::string::npos)
        << e.what();
  }
  const auto r = testing::run_cli("simulate --scenario " + dir + "/bad.yaml --out " + dir + "/out");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_FALSE(std::filesystem::exists(dir + "/out"));
  std::filesystem::remove_all(dir);
}

TEST(Study, MotorEncoderQuantisationRoundsTheReadingsOnly) {
  const double step = 2 * M_PI / (4096 * 10.0);
  EXPECT_DOUBLE_EQ(quantized_reading(0.3, 10, 4096), std::round(0.3 / step) * step);
  EXPECT_EQ(quantized_reading(0.3, 10, 0), 0.3);
  const DeviceModel actual = paper_actual_device(testing::builtin("baser-7dof"));
  SimulationNoise noise;
  noise.motor_counts_per_rev = 4096;
  noise.sigma_distance = 0;
  const Log log = simulate_log(actual, 20, noise, 1);
  for (int r = 0; r < log.rows; ++r) {
    EXPECT_NEAR(std::remainder(log.q(r, 0), step), 0.0, 1e-12);  // capstan joint: ratio 10
    EXPECT_NEAR(std::remainder(log.q(r, 5), 2 * M_PI / 4096), 0.0, 1e-12);  // no drive: ratio 1
  }
}

// RMSE / CRLB of every identified kinematic and capstan parameter. With N trials
// the estimate of the ratio has a standard error of about 1 / sqrt(2 N); 1000
// trials make the 0.9-1.1 band 4.5 standard errors wide on each side.
TEST(Study, MonteCarloRmseMatchesTheCramerRaoBound) {
  Scenario sc = default_scenario(device());
  sc.trials = 1000;
  const StudyResult r = run_study(sc, "", 2);
  ASSERT_EQ(r.monte_carlo.size(), 28u + 15u);
  for (const auto& [name, m] : r.monte_carlo) {
    EXPECT_EQ(m.trials, 1000) << name;
    EXPECT_GT(m.efficiency, 0.9) << name;
    EXPECT_LT(m.efficiency, 1.1) << name;
  }
}

}  // namespace
}  // namespace hapticcal
