// The files a command leaves (issue 15): each command its own default folder,
// figure scripts that name their data relative to the figures folder (copied
// elsewhere, they still draw), no empty gnuplot logs, a rerun that replaces its
// previous outputs completely and says so, and a "wrote" line that names every
// entry of the folder.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "hapticcal/core/output_set.hpp"
#include "report/process.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

namespace fs = std::filesystem;

bool gnuplot_on_path() {
  const char* path = std::getenv("PATH");
  if (!path) return false;
  const std::string p = path;
  for (size_t start = 0; start <= p.size();) {
    const size_t end = std::min(p.find(':', start), p.size());
    if (end > start && fs::exists(fs::path(p.substr(start, end - start)) / "gnuplot")) return true;
    start = end + 1;
  }
  return false;
}

fs::path scratch(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("output_files_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// Every file below `dir` whose name ends with `suffix`.
std::vector<fs::path> files_ending(const fs::path& dir, const std::string& suffix) {
  std::vector<fs::path> out;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (e.is_regular_file() && e.path().filename().string().ends_with(suffix)) {
      out.push_back(e.path());
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

// The line of `text` that starts with `prefix`, or empty.
std::string line_starting(const std::string& text, const std::string& prefix) {
  for (size_t start = 0; start < text.size();) {
    const size_t end = std::min(text.find('\n', start), text.size());
    const std::string line = text.substr(start, end - start);
    if (line.rfind(prefix, 0) == 0) return line;
    start = end + 1;
  }
  return {};
}

// calibrate on the small Meca500 log and a two-trial simulate, each run once
// with no --out in a scratch working folder: their default folders.
class OutputFiles : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    cwd_ = new fs::path(scratch("defaults"));
    const std::string meca = testing::source_path("examples/meca500/");
    calibrate_ = new testing::CliResult(
        testing::run_cli_in(cwd_->string(), {"calibrate", "--model", meca + "meca500.yaml", "--log",
                                             meca + "cal-norm_dist_data_0deg_160cube.csv"}));
    simulate_ = new testing::CliResult(
        testing::run_cli_in(cwd_->string(), {"simulate", "--trials", "2", "--threads", "2"}));
  }
  static void TearDownTestSuite() {
    fs::remove_all(*cwd_);
    delete calibrate_;
    delete simulate_;
    delete cwd_;
  }
  void SetUp() override {
    ASSERT_EQ(calibrate_->exit_code, 0) << calibrate_->err;
    ASSERT_EQ(simulate_->exit_code, 0) << simulate_->err;
  }
  static fs::path calibrate_dir() { return *cwd_ / "hapticcal-out/calibrate"; }
  static fs::path simulate_dir() { return *cwd_ / "hapticcal-out/simulate"; }

  static fs::path* cwd_;
  static testing::CliResult *calibrate_, *simulate_;
};
fs::path* OutputFiles::cwd_ = nullptr;
testing::CliResult* OutputFiles::calibrate_ = nullptr;
testing::CliResult* OutputFiles::simulate_ = nullptr;

TEST_F(OutputFiles, EachCommandHasItsOwnDefaultFolder) {
  std::set<std::string> folders;
  for (const auto& e : fs::directory_iterator(*cwd_ / "hapticcal-out")) {
    folders.insert(e.path().filename().string());
  }
  EXPECT_EQ(folders, (std::set<std::string>{"calibrate", "simulate"}));
  EXPECT_TRUE(fs::exists(calibrate_dir() / "results.json"));
  EXPECT_TRUE(fs::exists(simulate_dir() / "results.json"));
  // evaluate, force and plan, not run here, name theirs in --help: in the help
  // text, or as the default --out shows (--out TEXT=hapticcal-out/force).
  for (const std::string command : {"evaluate", "force", "plan"}) {
    const testing::CliResult help = testing::run_cli({command, "--help"});
    const bool said = help.out.find("default hapticcal-out/" + command + ")") != std::string::npos;
    const bool shown =
        help.out.find("--out TEXT=hapticcal-out/" + command + "\n") != std::string::npos;
    EXPECT_TRUE(said || shown) << help.out;
  }
}

TEST_F(OutputFiles, FigureScriptsHoldNoAbsolutePath) {
  if (!gnuplot_on_path()) GTEST_SKIP() << "gnuplot not on PATH: no figure scripts are written";
  // A quoted string that starts at the root, or any part of the folders' paths.
  const std::regex absolute(R"(["']/)");
  for (const fs::path& dir : {calibrate_dir(), simulate_dir()}) {
    const std::vector<fs::path> scripts = files_ending(dir / "figures", ".gp");
    EXPECT_GE(scripts.size(), 2u) << dir;
    for (const fs::path& gp : scripts) {
      const std::string text = testing::slurp(gp.string());
      EXPECT_FALSE(std::regex_search(text, absolute)) << gp << ":\n" << text;
      EXPECT_EQ(text.find(cwd_->string()), std::string::npos) << gp;
      EXPECT_EQ(text.find(".tmp-"), std::string::npos) << gp << " names a staging file";
    }
  }
  const std::vector<fs::path> mc = files_ending(simulate_dir(), "monte_carlo_efficiency.gp");
  EXPECT_EQ(mc.size(), 1u) << "two trials draw the Monte Carlo figures";
}

// The figures folder copied elsewhere, its figures deleted and the original
// moved away: gnuplot X.gp, run in the copy, draws X.svg and X.png again.
TEST_F(OutputFiles, CopiedFiguresFolderRedrawsWithGnuplot) {
  if (!gnuplot_on_path()) GTEST_SKIP() << "gnuplot not on PATH";
  const fs::path base = scratch("copied");
  for (const fs::path& dir : {calibrate_dir(), simulate_dir()}) {
    const fs::path copy = base / dir.filename() / "figs";
    fs::create_directories(copy.parent_path());
    fs::copy(dir / "figures", copy, fs::copy_options::recursive);
    for (const std::string ext : {".svg", ".png"}) {
      for (const fs::path& f : files_ending(copy, ext)) fs::remove(f);
    }
    fs::rename(dir / "figures", dir / "figures.away");
    const std::vector<fs::path> scripts = files_ending(copy, ".gp");
    EXPECT_GE(scripts.size(), 2u);
    for (const fs::path& gp : scripts) {
      const std::string stem = gp.stem().string();
      const detail::ProcessStatus run = detail::run_program(
          {"gnuplot", gp.filename().string()}, (base / "gnuplot.txt").string(), copy.string());
      EXPECT_EQ(run.exit_code, 0) << gp << ": " << run.error
                                  << testing::slurp(base / "gnuplot.txt");
      for (const std::string ext : {".svg", ".png"}) {
        const fs::path drawn = copy / (stem + ext);
        EXPECT_TRUE(fs::exists(drawn) && fs::file_size(drawn) > 100) << drawn;
      }
    }
    fs::rename(dir / "figures.away", dir / "figures");
  }
  fs::remove_all(base);
}

// gnuplot's log is kept only when gnuplot said something (process_test checks
// that a failing gnuplot's words are kept).
TEST_F(OutputFiles, NoEmptyGnuplotLogIsLeft) {
  if (!gnuplot_on_path()) GTEST_SKIP() << "gnuplot not on PATH";
  for (const fs::path& dir : {calibrate_dir(), simulate_dir()}) {
    EXPECT_FALSE(files_ending(dir / "figures", ".gp").empty()) << "gnuplot never ran in " << dir;
    for (const fs::path& log : files_ending(dir, ".log")) {
      EXPECT_GT(fs::file_size(log), 0u) << log;
    }
  }
}

// "wrote DIR/: a, b, figures/ (N files)" against the folder's listing (all but
// the marker), folders with their file counts.
void expect_wrote_line_lists(const std::string& stdout_text, const std::string& shown,
                             const fs::path& dir) {
  const std::string prefix = "wrote " + shown + "/: ";
  const std::string line = line_starting(stdout_text, prefix);
  ASSERT_FALSE(line.empty()) << "no line starting '" << prefix << "' in\n" << stdout_text;
  std::map<std::string, int> said;  // entry -> file count said (-1 for a file)
  const std::regex entry(R"(([^ ,]+)( \((\d+) files?\))?(, |$| \())");
  const std::string listed = line.substr(prefix.size());
  for (std::sregex_iterator it(listed.begin(), listed.end(), entry), end; it != end; ++it) {
    said[(*it)[1]] = (*it)[3].matched ? std::stoi((*it)[3]) : -1;
    if ((*it)[4] == " (") break;  // the tail: "(seed 1)"
  }
  std::map<std::string, int> present;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (name == kOutputMarker) continue;
    if (!e.is_directory()) {
      present[name] = -1;
      continue;
    }
    int files = 0;
    for (const auto& f : fs::recursive_directory_iterator(e.path())) files += f.is_regular_file();
    present[name + "/"] = files;
  }
  EXPECT_EQ(said, present) << line;
}

TEST_F(OutputFiles, WroteLineListsEveryEntryOfTheFolder) {
  expect_wrote_line_lists(calibrate_->out, "hapticcal-out/calibrate", calibrate_dir());
  expect_wrote_line_lists(simulate_->out, "hapticcal-out/simulate", simulate_dir());
  EXPECT_NE(line_starting(calibrate_->out, "wrote ").find("calibrated.yaml, "), std::string::npos);
  EXPECT_NE(line_starting(calibrate_->out, "wrote ").find(" (seed 1)"), std::string::npos);
  // A first run into a new folder replaced nothing and says nothing of it.
  EXPECT_EQ(calibrate_->out.find("replaced"), std::string::npos) << calibrate_->out;
}

// A one-trial rerun into a 20-trial folder: the Monte Carlo figures, their data
// and scripts are gone, and the terminal says the outputs were replaced.
TEST(OutputFilesRerun, ReplacesThePreviousOutputsCompletely) {
  if (!gnuplot_on_path()) GTEST_SKIP() << "gnuplot not on PATH: no figures to go stale";
  const fs::path base = scratch("rerun");
  const std::string out = (base / "sim").string();
  const testing::CliResult first =
      testing::run_cli({"simulate", "--trials", "20", "--threads", "2", "--out", out});
  ASSERT_EQ(first.exit_code, 0) << first.err;
  ASSERT_EQ(files_ending(out, ".gp").size(), files_ending(out, ".svg").size());
  const std::vector<std::string> monte_carlo{"monte_carlo_improvement", "monte_carlo_efficiency"};
  for (const std::string& stem : monte_carlo) {
    for (const std::string ext : {".csv", ".gp", ".svg", ".png"}) {
      ASSERT_TRUE(fs::exists(fs::path(out) / "figures" / (stem + ext))) << stem << ext;
    }
  }
  EXPECT_EQ(first.out.find("replaced"), std::string::npos) << first.out;

  const testing::CliResult second =
      testing::run_cli({"simulate", "--trials", "1", "--threads", "2", "--out", out});
  ASSERT_EQ(second.exit_code, 0) << second.err;
  for (const auto& e : fs::recursive_directory_iterator(out)) {
    EXPECT_EQ(e.path().filename().string().find("monte_carlo"), std::string::npos)
        << e.path() << " is the first run's";
  }
  EXPECT_NE(second.out.find("replaced the previous run's outputs in " + out +
                            "/ (written by hapticcal simulate)\n"),
            std::string::npos)
      << second.out;
  expect_wrote_line_lists(second.out, out, out);
  // Nothing is left beside the folder either (no staging folder, no old set).
  std::set<std::string> beside;
  for (const auto& e : fs::directory_iterator(base)) beside.insert(e.path().filename().string());
  EXPECT_EQ(beside, std::set<std::string>{"sim"});
  fs::remove_all(base);
}

}  // namespace
}  // namespace hapticcal
