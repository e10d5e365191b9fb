// Every command's report opens in headless Chromium without console messages
// and holds its figures; without gnuplot the commands still succeed.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
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

TEST(Report, EveryReportLoadsInChromiumWithItsFigures) {
  if (!chromium_available()) {
    if (std::getenv("CI")) FAIL() << "CI must install Debian's chromium (.ci/run does)";
    GTEST_SKIP() << "no /usr/bin/chromium";
  }
  const std::string dir = ::testing::TempDir() + "/reports";
  fs::remove_all(dir);
  const std::string shots = std::string(HAPTICCAL_BINARY_DIR) + "/report_screenshots";
  fs::create_directories(shots);
  ASSERT_EQ(testing::run_cli("simulate --trials 3 --out " + dir + "/simulate").exit_code, 0);
  ASSERT_EQ(
      testing::run_cli("calibrate --model " + testing::source_path("data/devices/baser-7dof.yaml") +
                       " --log " + dir + "/simulate/identification.csv --out " + dir + "/calibrate")
          .exit_code,
      0);
  ASSERT_EQ(testing::run_cli("force --actual " + dir + "/simulate/actual.yaml --nominal " + dir +
                             "/simulate/nominal.yaml --calibrated " + dir +
                             "/simulate/calibrated.yaml --out " + dir + "/force")
                .exit_code,
            0);
  // simulate: Figs 7, 8 (2), 9-like (3 joints: j4's is Fig. 7), 10, Monte Carlo (2);
  // calibrate: 4 joints x (fit, residual), errors per sample, correlations, model selection;
  // force: Fig. 12's normal and transverse force.
  const std::vector<std::pair<std::string, int>> expected = {
      {"simulate", 9}, {"calibrate", 11}, {"force", 2}};
  for (const auto& [name, figures] : expected) {
    SCOPED_TRACE(name);
    const std::string shot = shots + "/" + name + ".png";
    fs::remove(shot);
    const Page page = open_page(dir + "/" + name + "/report.html", shot);
    EXPECT_EQ(page.exit_code, 0);
    EXPECT_EQ(count(page.dom, "<figure"), figures);
    EXPECT_EQ(count(page.dom, "<figcaption>"), figures);
    EXPECT_EQ(count(page.log, ":CONSOLE"), 0) << page.log;
    EXPECT_TRUE(fs::exists(shot) && fs::file_size(shot) > 10000) << shot;
    // Every figure is gnuplot's, with a title and axis labels.
    EXPECT_EQ(count(page.dom, "Produced by GNUPLOT"), figures);
    int png = 0, svg = 0;  // each figure also as files for papers
    for (const auto& e : fs::directory_iterator(dir + "/" + name + "/figures")) {
      png += e.path().extension() == ".png";
      svg += e.path().extension() == ".svg";
    }
    EXPECT_EQ(png, figures);
    EXPECT_EQ(svg, figures);
  }
  fs::remove_all(dir);
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

}  // namespace
}  // namespace hapticcal
