// Every command's report opens in headless Chromium without console messages
// and holds its figures; without gnuplot the commands still succeed.
#include "hapticcal/report/report.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <vector>

#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

namespace fs = std::filesystem;

bool chromium_available() { return fs::exists("/usr/bin/chromium"); }

struct Page {
  int exit_code = 0;
  std::string dom, log;
};

// Loads a page headless (flags of the workplace's probe: no network, no sandbox
// as root, a fresh profile), dumps its DOM and takes a screenshot.
Page open_page(const std::string& html, const std::string& screenshot) {
  const std::string base =
      ::testing::TempDir() + "/chromium_" + fs::path(screenshot).stem().string();
  const std::vector<std::string> flags = {"--headless",
                                          "--no-sandbox",
                                          "--disable-gpu",
                                          "--disable-quic",
                                          "--no-first-run",
                                          "--disable-background-networking",
                                          "--disable-component-update",
                                          "--disable-sync",
                                          "--enable-logging=stderr",
                                          "--v=0",
                                          "--user-data-dir=" + base + "_profile"};
  const std::string url = "file://" + fs::absolute(html).string();
  std::vector<std::string> dump = flags, shoot = flags;
  dump.insert(dump.end(), {"--dump-dom", url});
  shoot.insert(shoot.end(), {"--window-size=1200,3000", "--screenshot=" + screenshot, url});
  const testing::CliResult dumped = testing::run_program("/usr/bin/chromium", dump);
  Page page;
  page.exit_code = dumped.exit_code;
  page.dom = dumped.out;
  page.log = dumped.err;
  testing::run_program("/usr/bin/chromium", shoot);
  fs::remove_all(base + "_profile");
  return page;
}

int count(const std::string& text, const std::string& what) {
  int n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

// The page's figures in order: id, inline SVG and caption (plain search: a
// std::regex over a page of SVGs overflows the stack).
struct PageFigure {
  std::string id, svg, caption;
};
std::vector<PageFigure> figures_of(const std::string& dom) {
  std::vector<PageFigure> figures;
  const std::string open = "<figure id=\"", caption = "<figcaption>";
  for (size_t at = dom.find(open); at != std::string::npos; at = dom.find(open, at + 1)) {
    const size_t id_end = dom.find('"', at + open.size());
    const size_t end = dom.find("</figure>", at);
    const size_t cap = dom.find(caption, at);
    if (id_end == std::string::npos || end == std::string::npos || cap > end) break;
    const size_t cap_end = dom.find("</figcaption>", cap);
    figures.push_back({dom.substr(at + open.size(), id_end - at - open.size()),
                       dom.substr(id_end, cap - id_end),
                       dom.substr(cap + caption.size(), cap_end - cap - caption.size())});
  }
  return figures;
}

std::set<std::string> files_in(const fs::path& dir, const std::string& extension) {
  std::set<std::string> stems;
  if (!fs::exists(dir)) return stems;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.path().extension() == extension) stems.insert(e.path().stem().string());
  }
  return stems;
}

// The checks of issue 15 on one report as Chromium renders it: it loads without
// console messages; the outcome block comes first after the title; every figure
// of the folder is on the page once, with one title (its caption: the plot
// itself draws none); the screenshot is written.
// Returns the number of figures on the page.
int check_page(const std::string& folder, const std::string& screenshot) {
  SCOPED_TRACE(folder);
  fs::remove(screenshot);
  const Page page = open_page(folder + "/report.html", screenshot);
  EXPECT_EQ(page.exit_code, 0);
  EXPECT_EQ(count(page.log, ":CONSOLE"), 0) << page.log;
  EXPECT_TRUE(fs::exists(screenshot) && fs::file_size(screenshot) > 10000) << screenshot;
  const std::string& dom = page.dom;
  const size_t h1 = dom.find("</h1>"), outcome = dom.find("<section id=\"outcome\"");
  EXPECT_NE(outcome, std::string::npos);
  if (outcome == std::string::npos) return 0;
  EXPECT_EQ(dom.find_first_not_of(" \n", h1 + 5), outcome) << "the outcome follows the title";
  for (const char* later : {"<h2", "<table", "<figure", "<p>", "<p "}) {
    const size_t at = dom.find(later);
    if (at != std::string::npos) EXPECT_LT(outcome, at) << later;
  }
  const std::vector<PageFigure> figures = figures_of(dom);
  std::set<std::string> unique;
  for (const PageFigure& f : figures) unique.insert(f.id);
  EXPECT_EQ(unique.size(), figures.size()) << "a figure is on the page twice";
  EXPECT_EQ(unique, files_in(folder + "/figures", ".svg")) << "the page and the folder differ";
  EXPECT_EQ(unique, files_in(folder + "/figures", ".png"));
  EXPECT_EQ(count(dom, "<figure"), static_cast<int>(figures.size()));
  EXPECT_EQ(count(dom, "<figcaption>"), static_cast<int>(figures.size()));
  EXPECT_EQ(count(dom, "Produced by GNUPLOT"), static_cast<int>(figures.size()));
  EXPECT_FALSE(figures.empty());
  // One title: the caption's text is not also drawn in the plot.
  for (const PageFigure& f : figures) {
    EXPECT_FALSE(f.caption.empty()) << f.id;
    EXPECT_EQ(f.svg.find(">" + f.caption + "<"), std::string::npos) << "drawn twice: " << f.caption;
  }
  return static_cast<int>(figures.size());
}

// Every command's report, and the fixture and URDF paths; the screenshots are
// kept in build/report_screenshots (docs/screenshots holds a copy: the README
// shows them).
TEST(Report, EveryReportLoadsInChromiumWithItsFigures) {
  if (!chromium_available()) {
    if (std::getenv("CI")) FAIL() << "CI must install Debian's chromium (.ci/run does)";
    GTEST_SKIP() << "no /usr/bin/chromium";
  }
  const std::string dir = testing::fresh_folder("chromium_reports");
  const std::string shots = std::string(HAPTICCAL_BINARY_DIR) + "/report_screenshots";
  fs::create_directories(shots);
  const std::string device = testing::source_path("data/devices/baser-7dof.yaml");
  auto ok = [](const testing::CliResult& r) {
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return r.exit_code == 0;
  };
  ASSERT_TRUE(ok(testing::run_cli("simulate --trials 3 --out " + dir + "/simulate")));
  ASSERT_TRUE(ok(testing::run_cli("calibrate --model " + device + " --log " + dir +
                                  "/simulate/identification.csv --out " + dir + "/calibrate")));
  ASSERT_TRUE(ok(testing::run_cli("evaluate --model " + dir + "/calibrate/calibrated.yaml --log " +
                                  dir + "/simulate/validation.csv --reference " + device +
                                  " --out " + dir + "/evaluate")));
  ASSERT_TRUE(ok(testing::run_cli("force --actual " + dir + "/simulate/actual.yaml --nominal " +
                                  dir + "/simulate/nominal.yaml --calibrated " + dir +
                                  "/simulate/calibrated.yaml --out " + dir + "/force")));
  ASSERT_TRUE(ok(testing::run_cli("plan --model " + device +
                                  " --measurement distance --poses 30 --pool 400 --refine-passes 0 "
                                  "--out " +
                                  dir + "/plan")));
  // The fixture and URDF paths: the Panda's URDF calibrated with MUKCa's two
  // sockets in two placements, evaluated on the third.
  std::ofstream(dir + "/sockets.csv") << testing::mukca_csv({"front", "right"});
  std::ofstream(dir + "/held-out.csv") << testing::mukca_csv({"back-high"});
  std::ofstream(dir + "/fixture.yaml") << "distances:\n  - [back-high_0, back-high_1, 0.05]\n";
  const std::string urdf = testing::real_data_path("mukca/panda.urdf");
  ASSERT_TRUE(ok(testing::run_cli({"calibrate", "--model", urdf, "--tip", "ball_link", "--log",
                                   dir + "/sockets.csv", "--point-distance", "front_0:front_1=0.05",
                                   "--point-distance", "right_0:right_1=0.05", "--out",
                                   dir + "/calibrate-fixture"})));
  ASSERT_TRUE(ok(testing::run_cli(
      {"evaluate", "--model", dir + "/calibrate-fixture/calibrated.urdf", "--tip", "ball_link",
       "--log", dir + "/held-out.csv", "--fixture", dir + "/fixture.yaml", "--reference", urdf,
       "--out", dir + "/evaluate-fixture"})));
  // simulate: Figs 7, 8 (2), 9-like (3 joints: j4's is Fig. 7), 10 (and its detail), Monte Carlo
  // (2); calibrate: 4 joints x (fit, residual), errors per sample, correlations, model selection;
  // evaluate: distance and position error per sample; force: Fig. 12's normal and transverse force;
  // plan: sd per parameter; the fixture's evaluation: each sample's distance from its point;
  // calibrate and plan: the poses in the workspace.
  const std::vector<std::pair<std::string, int>> expected = {
      {"simulate", 10}, {"calibrate", 12},         {"evaluate", 2},        {"force", 2},
      {"plan", 2},      {"calibrate-fixture", -1}, {"evaluate-fixture", 1}};
  for (const auto& [name, figures] : expected) {
    const int shown = check_page(dir + "/" + name, shots + "/" + name + ".png");
    if (figures >= 0) EXPECT_EQ(shown, figures) << name;
  }
  // No stale figure: a 1-trial rerun into the 3-trial folder has no Monte Carlo figure.
  const std::set<std::string> before = files_in(dir + "/simulate/figures", ".svg");
  EXPECT_TRUE(before.count("monte_carlo_efficiency"));
  ASSERT_TRUE(ok(testing::run_cli("simulate --trials 1 --out " + dir + "/simulate")));
  check_page(dir + "/simulate", dir + "/simulate-rerun.png");
  const std::set<std::string> after = files_in(dir + "/simulate/figures", ".svg");
  EXPECT_FALSE(after.count("monte_carlo_efficiency"));
  EXPECT_FALSE(after.count("monte_carlo_improvement"));
  EXPECT_EQ(after.size() + 2, before.size());
  fs::remove_all(dir);
}

// The README shows a screenshot of every report, from docs/screenshots.
TEST(Report, TheReadmeShowsAScreenshotOfEveryReport) {
  const std::string readme = testing::slurp(testing::source_path("README.md"));
  for (const char* name : {"simulate", "calibrate", "evaluate", "force", "plan",
                           "calibrate-fixture", "evaluate-fixture"}) {
    const std::string path = std::string("docs/screenshots/") + name + ".png";
    EXPECT_NE(readme.find("(" + path + ")"), std::string::npos) << path;
    EXPECT_TRUE(fs::exists(testing::source_path(path))) << path;
  }
}

TEST(Report, WithoutGnuplotTheCommandsSucceedAndSaySo) {
  const std::string dir = ::testing::TempDir() + "/reports_no_gnuplot";
  fs::remove_all(dir);
  // The command run with a PATH where no gnuplot can be found.
  const std::string device = testing::source_path("data/devices/baser-7dof.yaml");
  const testing::CliResult r = testing::run_program(
      "/usr/bin/env",
      std::vector<std::string>{"PATH=/nonexistent", HAPTICCAL_CLI, "force", "--actual", device,
                               "--nominal", device, "--calibrated", device, "--out", dir});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  const std::string out = r.out + r.err;
  EXPECT_NE(out.find("figures skipped: gnuplot not found"), std::string::npos) << out;
  const std::string html = testing::slurp(dir + "/report.html");
  EXPECT_NE(html.find("figures skipped"), std::string::npos);
  EXPECT_EQ(count(html, "<figure"), 0);
  EXPECT_TRUE(fs::exists(dir + "/results.json"));
  fs::remove_all(dir);
}

// A figure gnuplot cannot draw (a log axis of zeros): the note names its log
// within the output folder, never the folder the report was written in, which
// for a command is the staging folder renamed to --out once it is done.
TEST(Report, AFailedFigureNamesItsLogWithinTheOutputFolder) {
  const std::string parent = testing::fresh_folder("report_failed_figure");
  const std::string staging = parent + "/.out.tmp-Ab12Cd";
  fs::create_directories(staging);
  Report report;
  report.title = "failing figure";
  report.outcome.status = "done";
  FigureSpec zeros;
  zeros.name = "zeros";
  zeros.title = "zeros on a log axis";
  zeros.xlabel = "pose";
  zeros.ylabel = "error [mm]";
  zeros.columns = {{1, 2, 3}, {0, 0, 0}};
  zeros.series = {{"zeros", 0, 1, "points"}};
  zeros.log_y = true;
  report.figures.push_back(zeros);
  std::string note;
  const int drawn = write_report(report, staging, note);
  if (note.find("gnuplot not found") != std::string::npos) GTEST_SKIP() << note;
  EXPECT_EQ(drawn, 0);
  EXPECT_NE(note.find("figure zeros failed"), std::string::npos) << note;
  EXPECT_NE(note.find("see figures/zeros.gp.log"), std::string::npos) << note;
  EXPECT_EQ(note.find(parent), std::string::npos) << note;
  EXPECT_EQ(note.find(".tmp-"), std::string::npos) << note;
  const std::string html = testing::slurp(staging + "/report.html");
  EXPECT_EQ(html.find(parent), std::string::npos);
  EXPECT_EQ(html.find(".tmp-"), std::string::npos);
  EXPECT_TRUE(fs::exists(staging + "/figures/zeros.gp.log"));
  fs::remove_all(parent);
}

}  // namespace
}  // namespace hapticcal
