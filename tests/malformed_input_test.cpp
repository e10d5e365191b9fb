// Every malformed device file, log and scenario of tests/malformed/cases.txt
// makes the command line exit with code 2 and one line naming the file, line
// and key (a scenario: before any output).
// The sanitizer build (make test) runs this under AddressSanitizer and UBSan.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "hapticcal/core/files.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

struct Case {
  std::string kind, file, extra, expected;
};

std::vector<Case> cases() {
  std::ifstream in(testing::source_path("tests/malformed/cases.txt"));
  std::vector<Case> out;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::stringstream ss(line);
    Case c;
    std::getline(ss, c.kind, '|');
    std::getline(ss, c.file, '|');
    std::getline(ss, c.extra, '|');
    std::getline(ss, c.expected);
    out.push_back(c);
  }
  return out;
}

TEST(MalformedInput, EachCaseGivesItsOneLineErrorAndExitCode2) {
  const std::string dir = testing::source_path("tests/malformed");
  const std::vector<Case> all = cases();
  const std::string out = ::testing::TempDir() + "/malformed_cases_out";
  std::filesystem::remove_all(out);
  int models = 0, logs = 0, scenarios = 0, fixtures = 0;
  for (const Case& c : all) {
    SCOPED_TRACE(c.file);
    const bool model = c.kind == "model", scenario = c.kind == "scenario";
    const bool fixture = c.kind == "fixture";  // a fixture file for the good points log
    (model ? models : scenario ? scenarios : fixture ? fixtures : logs)++;
    const std::string log = model     ? dir + "/good-2dof.csv"
                            : fixture ? dir + "/good-2dof-points.csv"
                                      : dir + "/" + c.file;
    std::vector<std::string> args =
        scenario
            ? std::vector<std::string>{"simulate", "--scenario", dir + "/" + c.file, "--out", out}
            : std::vector<std::string>{"evaluate", "--model",
                                       model ? dir + "/" + c.file : dir + "/good-2dof.yaml",
                                       "--log", log};
    if (fixture) args.insert(args.end(), {"--fixture", dir + "/" + c.file});
    for (const std::string& a : testing::split_arguments(c.extra)) args.push_back(a);
    const testing::CliResult r = testing::run_cli(args);
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(r.out, "");
    ASSERT_FALSE(r.err.empty());
    EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "not one line: " << r.err;
    EXPECT_NE(r.err.find(c.expected), std::string::npos)
        << "expected \"" << c.expected << "\" in: " << r.err;
    EXPECT_EQ(r.err.rfind("hapticcal: ", 0), 0u) << r.err;
    EXPECT_FALSE(std::filesystem::exists(out)) << "a refused scenario wrote output";
  }
  EXPECT_GE(models, 15);
  EXPECT_GE(logs, 15);
  EXPECT_GE(scenarios, 10);
  EXPECT_GE(fixtures, 10);
}

TEST(MalformedInput, GoodFilesOfTheSuitePass) {
  const std::string dir = testing::source_path("tests/malformed");
  const auto r = testing::run_cli("evaluate --model " + dir + "/good-2dof.yaml --log " + dir +
                                  "/good-2dof.csv");
  EXPECT_EQ(r.exit_code, 0) << r.err;
}

// Poses: orientation columns as a quaternion or a rotation vector beside x, y, z.
TEST(MalformedInput, GoodPoseLogsOfTheSuitePass) {
  const std::string dir = testing::source_path("tests/malformed");
  for (const char* log : {"good-2dof-quaternion.csv", "good-2dof-rotation-vector.csv"}) {
    SCOPED_TRACE(log);
    const auto r = testing::run_cli(std::vector<std::string>{
        "evaluate", "--model", dir + "/good-2dof.yaml", "--log", dir + "/" + log});
    EXPECT_EQ(r.exit_code, 0) << r.err;
  }
}

TEST(MalformedInput, BadArgumentsExitWith2AndHelpWith0) {
  EXPECT_EQ(testing::run_cli("evaluate --model").exit_code, 2);
  EXPECT_EQ(testing::run_cli("no-such-command").exit_code, 2);
  EXPECT_EQ(testing::run_cli("").exit_code, 2);
  EXPECT_EQ(testing::run_cli("--help").exit_code, 0);
  EXPECT_EQ(testing::run_cli("evaluate --help").exit_code, 0);
}

// The error of a rejected input: exit code 2, nothing on standard output, and
// one short line on standard error that holds `expected`.
void expect_one_short_line(const testing::CliResult& r, const std::string& expected) {
  EXPECT_EQ(r.exit_code, 2) << r.err.substr(0, 300);
  EXPECT_EQ(r.out, "");
  ASSERT_FALSE(r.err.empty());
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "not one line: " << r.err.substr(0, 300);
  EXPECT_LT(r.err.size(), 400u) << "long message: " << r.err.substr(0, 300);
  EXPECT_NE(r.err.find(expected), std::string::npos)
      << "expected \"" << expected << "\" in: " << r.err.substr(0, 300);
}

std::string temp_folder(const std::string& name) {
  return testing::fresh_folder("malformed_" + name);
}

// A 30,000-character header field or link name overflowed std::regex's
// recursion (SIGSEGV); now each is one short line and exit code 2.
TEST(MalformedInput, HugeNamesAndValuesGiveOneShortLine) {
  const std::string src = testing::source_path("tests/malformed");
  const std::string good_model = testing::slurp(src + "/good-2dof.yaml");
  const std::string good_log = testing::slurp(src + "/good-2dof.csv");
  const std::string dir = temp_folder("huge");
  const std::string huge(30000, 'a');
  auto replaced = [](std::string text, const std::string& from, const std::string& to) {
    const size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return text.replace(at, from.size(), to);
  };
  struct Generated {
    std::string file, text, expected;
  };
  const std::string dots = std::string(39, 'a') + "...";
  const std::vector<Generated> logs = {
      {"header-letters.csv", replaced(good_log, "q2,", huge + ","),
       ":1: a" + dots + ": unknown column"},
      {"header-unit.csv", replaced(good_log, "q2,", "q2[" + huge + "],"),
       ":1: q2[aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa...: unit 'aaaa"},
      {"header-punctuation.csv", replaced(good_log, "q2,", std::string(30000, '(') + ","),
       ":1: ((((((((((((((((((((((((((((((((((((((((...: not a column name"},
      {"header-digits.csv", replaced(good_log, "q2,", "q" + std::string(30000, '9') + ","),
       ":1: q" + std::string(39, '9') + "...: joint number too large"},
      {"field.csv", replaced(good_log, "0.1,0.2,", "0.1," + huge + ","),
       ":3: q2: 'a" + dots + "' is not a number"},
  };
  for (const Generated& g : logs) {
    SCOPED_TRACE(g.file);
    std::ofstream(dir + "/" + g.file) << g.text;
    expect_one_short_line(
        testing::run_cli(std::vector<std::string>{"evaluate", "--model", src + "/good-2dof.yaml",
                                                  "--log", dir + "/" + g.file}),
        g.file + g.expected);
  }
  const std::vector<Generated> models = {
      {"link-name.yaml", replaced(good_model, "  - name: j2", "  - name: " + huge),
       ":14: links[1].name: 'a" + dots + "' is not a usable link name"},
      {"device-name.yaml", replaced(good_model, "name: two-link", "name: " + huge),
       ":2: name: longer than 200 bytes (30000)"},
      // YAML allows 1024 characters in a simple key; an explicit key (?) has no limit.
      {"key.yaml", replaced(good_model, "    d: 0\n", "    d: 0\n    ? " + huge + "\n    : 1\n"),
       ":18: links[1].a" + dots + ": unknown key"},
      {"value.yaml", replaced(good_model, "    a: 0.15", "    a: " + huge),
       ":15: links[1].a: 'a" + dots + "' is not a number"},
  };
  for (const Generated& g : models) {
    SCOPED_TRACE(g.file);
    std::ofstream(dir + "/" + g.file) << g.text;
    expect_one_short_line(
        testing::run_cli(std::vector<std::string>{"evaluate", "--model", dir + "/" + g.file,
                                                  "--log", src + "/good-2dof.csv"}),
        g.file + g.expected);
  }
  // --columns goes through the same scanner.
  expect_one_short_line(testing::run_cli(std::vector<std::string>{
                            "evaluate", "--model", src + "/good-2dof.yaml", "--log",
                            src + "/good-2dof.csv", "--columns", "q1," + huge + ",x,y,z"}),
                        "--columns: a" + dots + ": unknown column");
  std::filesystem::remove_all(dir);
}

// Fixture files (--fixture) are bounded: a file beyond 256 KiB is refused before
// YAML reads it, and a huge label or value is one short line.
TEST(MalformedInput, HugeFixtureFilesGiveOneShortLine) {
  const std::string src = testing::source_path("tests/malformed");
  const std::string dir = temp_folder("fixture");
  const std::string huge(30000, 'a');
  struct Generated {
    std::string file, text, expected;
  };
  std::string big = "distances:\n";
  while (big.size() <= max_file_bytes(FileKind::kFixture)) {
    big += "  - [a, b, 0.05]   # the same pair, again\n";
  }
  const std::string dots = std::string(39, 'a') + "...";
  const std::vector<Generated> all = {
      {"big.yaml", big,
       fmt::format(": {} bytes, more than the 256 KiB a fixture file may have", big.size())},
      {"label.yaml", "points:\n  ? " + huge + "\n  : [0, 0, 0]\n",
       ":2: points: a label of 30000 characters: at most 64"},
      {"value.yaml", "distances:\n  - [a, b, " + huge + "]\n",
       ":2: distances[0][2]: 'a" + dots + "' is not a number"},
  };
  for (const Generated& g : all) {
    SCOPED_TRACE(g.file);
    std::ofstream(dir + "/" + g.file) << g.text;
    expect_one_short_line(testing::run_cli(std::vector<std::string>{
                              "evaluate", "--model", src + "/good-2dof.yaml", "--log",
                              src + "/good-2dof-points.csv", "--fixture", dir + "/" + g.file}),
                          g.file + g.expected);
  }
  std::filesystem::remove_all(dir);
}

// Scenario files (simulate --scenario): the numbers that size the work or set
// the truth are bounded; each rejection names the file, line, key and limit.
TEST(MalformedInput, ScenarioNumbersAreBounded) {
  const std::string dir = temp_folder("scenario");
  struct Bad {
    std::string body, expected;
  };
  const std::vector<Bad> all = {
      {"trajectory: {seconds: 1e6}", ":2: trajectory.seconds: 1000000 is outside (0, 100000] s"},
      {"trajectory: {seconds: 0}", ":2: trajectory.seconds: 0 is outside (0, 100000] s"},
      {"trajectory: {rate_hz: 2e5}", ":2: trajectory.rate_hz: 200000 is outside (0, 100000] Hz"},
      {"trajectory: {seconds: 1e5, rate_hz: 1e5}",
       ":2: trajectory: seconds * rate_hz = 10000000000 samples, more than the 10000000 allowed"},
      {"trials: 1000000", ":2: trials: expected an integer in [1, 100000]"},
      {"poses: {identification: 2000000}",
       ":2: poses.identification: expected an integer in [1, 1000000]"},
      {"poses: {validation: 1.5}", ":2: poses.validation: expected an integer in [1, 1000000]"},
      {"noise: {sigma_e: -1e-4}", ":2: noise.sigma_e: -0.0001 is outside [0, 1] rad"},
      {"noise: {sigma_e: .nan}", ":2: noise.sigma_e: '.nan' is not finite"},
      {"noise: {sigma_m: 5}", ":2: noise.sigma_m: 5 is outside [0, 1] m"},
      {"noise: {sigma_m: -.inf}", ":2: noise.sigma_m: '-.inf' is not finite"},
      {"noise: {motor_counts_per_rev: -4096}",
       ":2: noise.motor_counts_per_rev: -4096 is outside [0, 1000000000] counts"},
      {"deviations: {j2.a: 2}", ":2: deviations.j2.a: |2| is more than the 1 m a deviation may be"},
      {"deviations: {j2.alpha: -4}",
       ":2: deviations.j2.alpha: |-4| is more than the 3.141592653589793 rad (pi)"},
      {"deviations: {\"j2\\x07\": 0.1}", ":2: deviations.j2\\x07: not a kinematic parameter"},
      {"format: \"x\\ny\"", ":1: format: 'x\\x0ay' is not 'hapticcal-scenario/1'"},
  };
  for (size_t i = 0; i < all.size(); ++i) {
    SCOPED_TRACE(all[i].body);
    const std::string file = dir + "/bad" + std::to_string(i) + ".yaml";
    const bool has_format = all[i].body.rfind("format", 0) == 0;
    std::ofstream(file) << (has_format ? "" : "format: hapticcal-scenario/1\n") << all[i].body
                        << "\n";
    expect_one_short_line(testing::run_cli(std::vector<std::string>{"simulate", "--scenario", file,
                                                                    "--out", dir + "/out"}),
                          "bad" + std::to_string(i) + ".yaml" + all[i].expected);
    EXPECT_FALSE(std::filesystem::exists(dir + "/out"));
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace hapticcal
