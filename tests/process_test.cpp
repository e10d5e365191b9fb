// No shell anywhere (issue 10): programs run from an argument vector, so the
// characters of a path are never interpreted. Output folders whose names hold
// shell syntax are created as named and nothing in their names runs.
#include "report/process.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

namespace fs = std::filesystem;

// A fresh scratch folder for one test.
fs::path scratch(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("process_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

bool gnuplot_on_path() {
  const char* path = std::getenv("PATH");
  if (!path) return false;
  std::string p = path;
  for (size_t start = 0; start <= p.size();) {
    const size_t end = std::min(p.find(':', start), p.size());
    if (end > start && fs::exists(fs::path(p.substr(start, end - start)) / "gnuplot")) return true;
    start = end + 1;
  }
  return false;
}

// Files in `dir` (below it too when `recursive`) whose name starts with `prefix`.
std::vector<std::string> found(const fs::path& dir, const std::string& prefix, bool recursive) {
  std::vector<std::string> out;
  std::error_code ec;
  auto check = [&](const fs::path& p) {
    if (p.filename().string().rfind(prefix, 0) == 0) out.push_back(p.string());
  };
  if (recursive) {
    for (fs::recursive_directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
      check(it->path());
  } else {
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
      check(it->path());
  }
  return out;
}

TEST(Process, ArgumentsReachTheProgramVerbatim) {
  const fs::path dir = scratch("verbatim");
  const std::string arg = "$(touch M) `touch M` 'q' \"d\" ; | > x \n \\ *";
  const detail::ProcessStatus s =
      detail::run_program({"printf", "%s", arg}, (dir / "out.txt").string());
  ASSERT_EQ(s.exit_code, 0) << s.error;
  EXPECT_EQ(testing::slurp((dir / "out.txt").string()), arg);
  EXPECT_FALSE(fs::exists(dir / "M"));
  EXPECT_FALSE(fs::exists("M"));
}

TEST(Process, ExitStatusSignalAndWorkingFolder) {
  const fs::path dir = scratch("status");
  EXPECT_EQ(detail::run_program({"true"}, "").exit_code, 0);
  EXPECT_EQ(detail::run_program({"false"}, "").exit_code, 1);
  // A program ended by SIGTERM (15) reports 128 + 15, as a shell would.
  EXPECT_EQ(detail::run_program({"sh", "-c", "kill -TERM $$"}, "").exit_code, 128 + 15);
  const fs::path sub = dir / "a 'b' $(c)";
  fs::create_directories(sub);
  const std::string out = (dir / "pwd.txt").string();
  ASSERT_EQ(detail::run_program({"pwd", "-P"}, out, sub.string()).exit_code, 0);
  EXPECT_EQ(testing::slurp(out), fs::canonical(sub).string() + "\n");
  // Standard error goes to the same file.
  ASSERT_EQ(detail::run_program({"sh", "-c", "echo oops >&2"}, out).exit_code, 0);
  EXPECT_EQ(testing::slurp(out), "oops\n");
}

TEST(Process, AProgramThatCannotStartSaysWhy) {
  const detail::ProcessStatus s = detail::run_program({"hapticcal-no-such-program"}, "");
  EXPECT_EQ(s.exit_code, -1);
  EXPECT_NE(s.error.find("cannot run hapticcal-no-such-program: No such file or directory"),
            std::string::npos)
      << s.error;
  const detail::ProcessStatus d = detail::run_program({"true"}, "", "/no/such/folder");
  EXPECT_EQ(d.exit_code, -1);
  EXPECT_NE(d.error.find("No such file or directory"), std::string::npos) << d.error;
}

TEST(Process, ShellSyntaxInOutputFoldersRunsNothing) {
  if (!gnuplot_on_path()) GTEST_SKIP() << "gnuplot is not installed: no figures to check";
  const fs::path base = scratch("shell_syntax");
  const std::string marker = "hapticcal_marker_" + std::to_string(::getpid());
  const std::vector<std::string> names = {
      "o_$(touch " + marker + "_1)",
      "o_`touch " + marker + "_2`",
      "o_'single' \"double\" ;touch " + marker + "_3",
      "o_ space and\nnewline $(touch " + marker + "_4) `touch " + marker + "_5`",
  };
  const std::string meca = testing::source_path("examples/meca500/");
  // simulate (1 trial), force on simulate's files, calibrate (Meca500 example).
  const fs::path sim = base / names[0];
  auto r = testing::run_cli(
      std::vector<std::string>{"simulate", "--trials", "1", "--out", sim.string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const fs::path force = base / names[1];
  r = testing::run_cli(std::vector<std::string>{"force", "--actual", (sim / "actual.yaml").string(),
                                                "--nominal", (sim / "nominal.yaml").string(),
                                                "--calibrated", (sim / "calibrated.yaml").string(),
                                                "--out", force.string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::vector<fs::path> outs = {sim, force};
  for (size_t i = 2; i < names.size(); ++i) {
    outs.push_back(base / names[i]);
    r = testing::run_cli(std::vector<std::string>{
        "calibrate", "--model", meca + "meca500.yaml", "--log",
        meca + "cal-norm_dist_data_0deg_160cube.csv", "--out", outs.back().string()});
    ASSERT_EQ(r.exit_code, 0) << r.err;
  }
  for (const fs::path& out : outs) {
    SCOPED_TRACE(out.string());
    ASSERT_TRUE(fs::is_directory(out));
    EXPECT_TRUE(fs::exists(out / "report.html"));
    int svg = 0, png = 0;
    for (const auto& e : fs::directory_iterator(out / "figures")) {
      const std::string name = e.path().filename().string();
      svg += e.path().extension() == ".svg";
      png += e.path().extension() == ".png";
      EXPECT_EQ(name.find(".tmp-"), std::string::npos) << "temporary file left: " << name;
      if (name.ends_with(".log"))
        ADD_FAILURE() << "gnuplot complained: " << testing::slurp(e.path());
      if (name.ends_with(".png")) {
        EXPECT_EQ(testing::slurp(e.path()).substr(1, 3), "PNG") << name;
      }
    }
    EXPECT_GE(svg, 1);
    EXPECT_EQ(svg, png);
    // The report inlines every figure.
    EXPECT_EQ(testing::slurp((out / "report.html").string()).find("figures skipped"),
              std::string::npos);
  }
  // Nothing ran: no marker anywhere below the scratch folder (gnuplot ran in
  // the figures folders), in it parent, in our folder or its parent.
  EXPECT_EQ(found(base, marker, true), std::vector<std::string>{});
  for (const fs::path& dir :
       {base.parent_path(), fs::current_path(), fs::current_path().parent_path()}) {
    EXPECT_EQ(found(dir, marker, false), std::vector<std::string>{}) << dir;
  }
  fs::remove_all(base);
}

// A gnuplot that fails (as on a full disk) leaves no figure behind, only its
// log, and the report says which figure failed.
TEST(Process, FailingGnuplotLeavesNoFigures) {
  const fs::path base = scratch("failing_gnuplot");
  const fs::path bin = base / "bin";
  fs::create_directories(bin);
  {
    std::ofstream fake(bin / "gnuplot");
    fake << "#!/bin/sh\necho 'gnuplot: No space left on device' >&2\nexit 1\n";
  }
  ::chmod((bin / "gnuplot").c_str(), 0755);
  const std::string saved = std::getenv("PATH") ? std::getenv("PATH") : "";
  ::setenv("PATH", (bin.string() + ":" + saved).c_str(), 1);
  const std::string meca = testing::source_path("examples/meca500/");
  const fs::path out = base / "out";
  const auto r = testing::run_cli(std::vector<std::string>{
      "calibrate", "--model", meca + "meca500.yaml", "--log",
      meca + "cal-norm_dist_data_0deg_160cube.csv", "--out", out.string()});
  ::setenv("PATH", saved.c_str(), 1);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  int logs = 0;
  for (const auto& e : fs::directory_iterator(out / "figures")) {
    const std::string name = e.path().filename().string();
    EXPECT_NE(e.path().extension(), ".svg") << name;
    EXPECT_NE(e.path().extension(), ".png") << name;
    EXPECT_EQ(name.find(".tmp-"), std::string::npos) << name;
    if (name.ends_with(".gp.log")) {
      ++logs;
      EXPECT_EQ(testing::slurp(e.path()), "gnuplot: No space left on device\n");
    }
  }
  EXPECT_GE(logs, 1);
  const std::string html = testing::slurp((out / "report.html").string());
  EXPECT_NE(html.find("failed: gnuplot exit status 1"), std::string::npos);
  fs::remove_all(base);
}

}  // namespace
}  // namespace hapticcal
