// `hapticcal plan` on the command line: bad options and inputs exit with code 2
// and one line naming the option, file or line; a plan runs end to end, its
// plan.csv reads back as a log, and `simulate` measures at it through the
// scenario key poses.identification.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "hapticcal/data_io/log.hpp"
#include "hapticcal/model_io/device.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

std::string builtin_file() { return testing::source_path("data/devices/baser-7dof.yaml"); }

TEST(PlanCli, BadOptionsExitWith2AndOneLineNamingTheOption) {
  const std::string out = testing::fresh_folder("plan_cli_bad") + "/out";
  const std::string model = builtin_file();
  const std::string two_joints = testing::source_path("tests/malformed/good-2dof.csv");
  struct Case {
    std::string args, expected;
  };
  const std::vector<Case> cases = {
      {"--measurement distance --poses 0", "--poses"},
      {"--measurement distance --poses 5 --criterion x", "--criterion: x not in {d,a,i,e}"},
      {"--measurement distance --poses 5 --candidates " + two_joints + " --pool 10",
       "--candidates excludes --pool"},
      {"--measurement distance --poses 5 --candidates " + two_joints,
       two_joints + ":2: q: the log has 2 joint readings a row, the model 7 joints"},
      {"--measurement force --poses 5", "--measurement 'force'"},
      {"--measurement distance --poses 5 --distance-range 0.5", "--distance-range '0.5'"},
      {"--measurement distance --poses 5 --distance-range 0.5,0.2", "--distance-range"},
      {"--measurement distance --poses 5 --box 0,1,0,1,0,x", "--box"},
      {"--measurement distance --poses 5 --box 0,1,0,1,0,1e-9 --pool 10",
       "--distance-range / --box"},
      {"--measurement distance --poses 5 --candidates /no/such/file.csv", "/no/such/file.csv"},
      {"--measurement distance --poses 5 --fix j9.a", "j9.a"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.args);
    std::vector<std::string> args = {"plan", "--model", model, "--out", out};
    for (const std::string& a : testing::split_arguments(c.args)) args.push_back(a);
    testing::expect_input_error(testing::run_cli(args), c.expected);
  }
  EXPECT_FALSE(std::filesystem::exists(out + "/plan.csv"));
}

TEST(PlanCli, PlanRunsAndSimulateMeasuresAtThePlannedPoses) {
  const std::string dir = testing::fresh_folder("plan_cli_run");
  const testing::CliResult r = testing::run_cli(std::vector<std::string>{
      "plan", "--model", builtin_file(), "--measurement", "distance", "--poses", "40", "--pool",
      "2000", "--seed", "3", "--refine-passes", "2", "--out", dir + "/plan"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("seed 3"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("predicted RMS distance sd"), std::string::npos) << r.out;
  for (const char* f : {"plan.csv", "plan.json", "report.html"})
    EXPECT_TRUE(std::filesystem::exists(dir + "/plan/" + f)) << f;
  const Log plan = read_log(dir + "/plan/plan.csv");
  ASSERT_EQ(plan.rows, 40);
  ASSERT_EQ(plan.dof(), 7);
  const DeviceModel model = load_device(builtin_file());
  for (int i = 0; i < plan.rows; ++i) {
    for (int j = 0; j < 7; ++j) {
      EXPECT_GE(plan.q(i, j), model.links[j].lower);
      EXPECT_LE(plan.q(i, j), model.links[j].upper);
    }
  }
  std::ofstream(dir + "/scenario.yaml")
      << "format: hapticcal-scenario/1\n"
         "poses: {identification: plan/plan.csv, validation: 50}\n"
         "calibration: {keep_all: true}\n"
         "trajectory: {seconds: 1}\n";
  const testing::CliResult s = testing::run_cli(std::vector<std::string>{
      "simulate", "--scenario", dir + "/scenario.yaml", "--out", dir + "/sim"});
  ASSERT_EQ(s.exit_code, 0) << s.err;
  const Log measured = read_log(dir + "/sim/identification.csv");
  ASSERT_EQ(measured.rows, 40);
  for (int i = 0; i < plan.rows; ++i) {
    for (int j = 0; j < 7; ++j) EXPECT_NEAR(measured.q(i, j), plan.q(i, j), 1e-12);
  }
}

TEST(PlanCli, ScenarioKeysForPlansAreCheckedWithFileAndLine) {
  const std::string dir = testing::fresh_folder("plan_cli_scenario");
  std::ofstream(dir + "/two.csv") << "q1,q2\n0,0\n0.1,0.2\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"poses: {identification: missing.csv}\n", "2: poses.identification"},
      {"poses: {identification: two.csv}\n", "the device 7 joints"},
      {"calibration: {keep_all: maybe}\n", "2: calibration.keep_all: expected true or false"},
      {"calibration: {keepall: true}\n", "2: calibration.keepall: unknown key"},
      {"calibration: {fix: [j9.a]}\n", "2: calibration.fix"},
  };
  for (const auto& [body, expected] : cases) {
    SCOPED_TRACE(body);
    std::ofstream(dir + "/s.yaml") << "format: hapticcal-scenario/1\n" << body;
    testing::expect_input_error(
        testing::run_cli(std::vector<std::string>{"simulate", "--scenario", dir + "/s.yaml",
                                                  "--out", dir + "/o"}),
        expected);
  }
}

TEST(PlanCli, RecordedCandidatesChooseAmongTheLogsDistinctPoses) {
  const std::string dir = testing::fresh_folder("plan_cli_meca");
  const testing::CliResult r = testing::run_cli(std::vector<std::string>{
      "plan", "--model", testing::source_path("examples/meca500/meca500.yaml"), "--measurement",
      "position", "--poses", "20", "--candidates",
      testing::source_path("examples/meca500/cal-norm_dist_data_0deg_80cube.csv"), "--out",
      dir + "/plan"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("candidates: 70 recorded poses"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("chosen poses"), std::string::npos) << r.out;
  EXPECT_EQ(read_log(dir + "/plan/plan.csv").rows, 20);
}

}  // namespace
}  // namespace hapticcal
