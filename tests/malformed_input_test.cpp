// Every malformed device file and log of tests/malformed/cases.txt makes the
// command line exit with code 2 and one line naming the file, line and key.
// The sanitizer build (make test) runs this under AddressSanitizer and UBSan.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

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
  int models = 0, logs = 0;
  for (const Case& c : all) {
    SCOPED_TRACE(c.file);
    const bool model = c.kind == "model";
    (model ? models : logs)++;
    const std::string args = "evaluate --model " +
                             (model ? dir + "/" + c.file : dir + "/good-2dof.yaml") + " --log " +
                             (model ? dir + "/good-2dof.csv" : dir + "/" + c.file) + " " + c.extra;
    const testing::CliResult r = testing::run_cli(args);
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(r.out, "");
    ASSERT_FALSE(r.err.empty());
    EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "not one line: " << r.err;
    EXPECT_NE(r.err.find(c.expected), std::string::npos)
        << "expected \"" << c.expected << "\" in: " << r.err;
    EXPECT_EQ(r.err.rfind("hapticcal: ", 0), 0u) << r.err;
  }
  EXPECT_GE(models, 15);
  EXPECT_GE(logs, 15);
}

TEST(MalformedInput, GoodFilesOfTheSuitePass) {
  const std::string dir = testing::source_path("tests/malformed");
  const auto r = testing::run_cli("evaluate --model " + dir + "/good-2dof.yaml --log " + dir +
                                  "/good-2dof.csv");
  EXPECT_EQ(r.exit_code, 0) << r.err;
}

TEST(MalformedInput, BadArgumentsExitWith2AndHelpWith0) {
  EXPECT_EQ(testing::run_cli("evaluate --model").exit_code, 2);
  EXPECT_EQ(testing::run_cli("no-such-command").exit_code, 2);
  EXPECT_EQ(testing::run_cli("").exit_code, 2);
  EXPECT_EQ(testing::run_cli("--help").exit_code, 0);
  EXPECT_EQ(testing::run_cli("evaluate --help").exit_code, 0);
}

}  // namespace
}  // namespace hapticcal
