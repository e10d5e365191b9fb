// The reports' figures carry their message (issue 15): one title (the HTML
// caption), "after" series on a scale where they are visible, physical axis
// limits, distinguishable lines, error bars and bands inside the frame,
// legends inside or under the plot, a sharp correlation map in the table's
// order, and units on every axis. Each test reads the gnuplot script
// (figures/<name>.gp) and data (figures/<name>.csv) that the command line wrote.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "report/figures.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

namespace fs = std::filesystem;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr int kTrials = 20;

// One `plot` clause: "data.csv" using X:Y[:E][:xtic(1)] with STYLE [lc rgb "C"] [dt N] ...
struct Clause {
  int x = 0, y = 0;  // one-based gnuplot columns (x = 0: the row number)
  std::string style, color, title;
  int dash = 1;  // gnuplot's default: solid
};

// The settings of a figure's script that the tests look at (its SVG half; the
// PNG half repeats them for another terminal).
struct Script {
  std::string text;
  std::string xlabel, ylabel;
  bool log_y = false;
  double y_lo = kNaN, y_hi = kNaN, x_lo = kNaN, x_hi = kNaN;
  std::vector<Clause> clauses;
  std::vector<std::string> xtics;  // explicit `set xtics ("name" 0, ...)`
};

std::string quoted_after(const std::string& line, const std::string& key) {
  const size_t at = line.find(key);
  if (at == std::string::npos) return "";
  const size_t open = line.find('"', at + key.size());
  const size_t close = line.find('"', open + 1);
  return open == std::string::npos || close == std::string::npos
             ? ""
             : line.substr(open + 1, close - open - 1);
}

// "[a:b]" -> a, b (NaN for '*').
void parse_range(const std::string& line, double& lo, double& hi) {
  const size_t open = line.find('['), colon = line.find(':', open), close = line.find(']', colon);
  ASSERT_NE(close, std::string::npos) << line;
  const std::string a = line.substr(open + 1, colon - open - 1);
  const std::string b = line.substr(colon + 1, close - colon - 1);
  lo = a == "*" || a.empty() ? kNaN : std::stod(a);
  hi = b == "*" || b.empty() ? kNaN : std::stod(b);
}

Script read_script(const std::string& path) {
  Script s;
  std::string text = testing::slurp(path);
  const size_t second = text.find("set terminal", 1);
  s.text = text.substr(0, second);
  std::istringstream in(s.text);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("set xlabel", 0) == 0) s.xlabel = quoted_after(line, "set xlabel");
    if (line.rfind("set ylabel", 0) == 0) s.ylabel = quoted_after(line, "set ylabel");
    if (line.rfind("set logscale y", 0) == 0) s.log_y = true;
    if (line.rfind("set yrange", 0) == 0) parse_range(line, s.y_lo, s.y_hi);
    if (line.rfind("set xrange", 0) == 0) parse_range(line, s.x_lo, s.x_hi);
    if (line.rfind("set xtics (", 0) == 0) {
      const std::regex tic("\"([^\"]*)\" [0-9]+");
      for (auto it = std::sregex_iterator(line.begin(), line.end(), tic);
           it != std::sregex_iterator(); ++it)
        s.xtics.push_back((*it)[1]);
    }
    if (line.rfind("plot ", 0) != 0 && line.rfind("splot ", 0) != 0) continue;
    const std::regex clause(
        "using ([0-9]+):([0-9]+)[^ ]* with ([a-z]+)((?: (?:lc rgb \"[^\"]*\"|dt [0-9]+|lw [0-9.]+|"
        "pt [0-9]+))*) (notitle|title \"[^\"]*\")");
    for (auto it = std::sregex_iterator(line.begin(), line.end(), clause);
         it != std::sregex_iterator(); ++it) {
      Clause c;
      c.x = std::stoi((*it)[1]);
      c.y = std::stoi((*it)[2]);
      c.style = (*it)[3];
      const std::string look = (*it)[4];
      c.color = quoted_after(look, "lc rgb");
      std::smatch dash;
      if (std::regex_search(look, dash, std::regex("dt ([0-9]+)"))) c.dash = std::stoi(dash[1]);
      c.title = quoted_after((*it)[5].str(), "title");
      s.clauses.push_back(c);
    }
  }
  return s;
}

// The data columns as gnuplot numbers them (column 1: the row label).
std::map<int, std::vector<double>> read_data(const std::string& path) {
  std::map<int, std::vector<double>> columns;
  std::istringstream in(testing::slurp(path));
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream cells(line);
    std::string cell;
    for (int c = 1; std::getline(cells, cell, ','); ++c) {
      if (c > 1) columns[c].push_back(std::stod(cell));
    }
  }
  return columns;
}

const Clause* clause_titled(const Script& s, const std::string& part) {
  for (const Clause& c : s.clauses) {
    if (c.title.find(part) != std::string::npos) return &c;
  }
  return nullptr;
}

// Where a series sits on the y axis, as fractions of the axis (on a log axis
// in decades): `span` from its smallest value (or the axis' lower limit) to its
// largest, `top` its largest value's height. Autoscaled limits are taken as the
// data's.
struct Extent {
  double span = 0, top = 0;
};
Extent extent(const Script& s, const std::map<int, std::vector<double>>& data, const Clause& c) {
  double lo = s.y_lo, hi = s.y_hi;
  double data_lo = std::numeric_limits<double>::infinity(), data_hi = -data_lo;
  for (const Clause& any : s.clauses) {
    for (double v : data.at(any.y)) {
      if (s.log_y && !(v > 0)) continue;
      data_lo = std::min(data_lo, v);
      data_hi = std::max(data_hi, v);
    }
  }
  if (std::isnan(lo)) lo = data_lo;
  if (std::isnan(hi)) hi = data_hi;
  double bottom = std::numeric_limits<double>::infinity(), top = -bottom;
  for (double v : data.at(c.y)) {
    if (s.log_y && !(v > 0)) continue;
    bottom = std::min(bottom, v);
    top = std::max(top, v);
  }
  bottom = std::max(bottom, lo);
  auto axis = [&](double v) { return s.log_y ? std::log10(v) : v; };
  const double range = axis(hi) - axis(lo);
  return {(axis(top) - axis(bottom)) / range, (axis(top) - axis(lo)) / range};
}

class ReportFigures : public ::testing::Test {
 protected:
  static std::string dir_;
  static std::vector<std::string> reports_;

  // simulate (Monte Carlo), calibrate on its log, force on its models, plan:
  // run once for all tests, in folders of their own name.
  static void SetUpTestSuite() {
    dir_ = testing::fresh_folder("report_figures_runs");
    const std::string sim = dir_ + "/simulate";
    const testing::CliResult s =
        testing::run_cli("simulate --trials " + std::to_string(kTrials) + " --out " + sim);
    ASSERT_EQ(s.exit_code, 0) << s.err;
    const testing::CliResult c = testing::run_cli(
        "calibrate --model " + testing::source_path("data/devices/baser-7dof.yaml") + " --log " +
        sim + "/identification.csv --out " + dir_ + "/calibrate");
    ASSERT_EQ(c.exit_code, 0) << c.err;
    const testing::CliResult f = testing::run_cli(
        "force --actual " + sim + "/actual.yaml --nominal " + sim + "/nominal.yaml --calibrated " +
        sim + "/calibrated.yaml --out " + dir_ + "/force");
    ASSERT_EQ(f.exit_code, 0) << f.err;
    const testing::CliResult p = testing::run_cli(
        "plan --model " + testing::source_path("data/devices/baser-7dof.yaml") +
        " --measurement distance --poses 40 --pool 500 --seed 3 --out " + dir_ + "/plan");
    ASSERT_EQ(p.exit_code, 0) << p.err;
    reports_ = {"simulate", "calibrate", "force", "plan"};
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }

  static std::string figure(const std::string& report, const std::string& name,
                            const std::string& ext) {
    return dir_ + "/" + report + "/figures/" + name + ext;
  }
  // The stems of a report's figures.
  static std::vector<std::string> figures(const std::string& report) {
    std::vector<std::string> out;
    for (const auto& e : fs::directory_iterator(dir_ + "/" + report + "/figures"))
      if (e.path().extension() == ".gp") out.push_back(e.path().stem().string());
    std::sort(out.begin(), out.end());
    return out;
  }
  void SetUp() override {
    if (reports_.empty()) GTEST_SKIP() << "the commands did not run";
    if (figures("force").empty()) GTEST_SKIP() << "no gnuplot: no figures";
  }
};
std::string ReportFigures::dir_;
std::vector<std::string> ReportFigures::reports_;

TEST_F(ReportFigures, GnuplotDrawsNoTitleTheCaptionIsTheOne) {
  for (const std::string& report : reports_) {
    const std::vector<std::string> names = figures(report);
    EXPECT_FALSE(names.empty()) << report;
    const std::string html = testing::slurp(dir_ + "/" + report + "/report.html");
    for (const std::string& name : names) {
      SCOPED_TRACE(report + "/" + name);
      const std::string gp = testing::slurp(figure(report, name, ".gp"));
      EXPECT_EQ(gp.find("set title"), std::string::npos);
      const size_t at = html.find("<figure id=\"" + name + "\">");
      ASSERT_NE(at, std::string::npos);
      const size_t caption = html.find("<figcaption>", at);
      ASSERT_NE(caption, std::string::npos);
      EXPECT_GT(html.find("</figcaption>", caption), caption + 12 + 10) << "a caption text";
    }
  }
}

// Fig. 8: the "after" errors (about 0.5 mm against tens of mm before) spread
// over a quarter of the y axis or more, and the "before" ones fit under its top.
TEST_F(ReportFigures, SimulateFig8AfterErrorsAreVisible) {
  for (const std::string name : {"fig8_position", "fig8_orientation"}) {
    SCOPED_TRACE(name);
    const Script s = read_script(figure("simulate", name, ".gp"));
    const auto data = read_data(figure("simulate", name, ".csv"));
    const Clause* after = clause_titled(s, "after");
    const Clause* before = clause_titled(s, "before");
    ASSERT_TRUE(after && before) << s.text;
    EXPECT_GT(extent(s, data, *after).span, 0.25);
    EXPECT_LE(extent(s, data, *before).top, 1.0);
    EXPECT_TRUE(s.log_y || s.y_lo >= 0) << "a norm's axis below zero";
  }
}

// Fig. 10: the full calibration's error (microns) has a figure of its own
// beside the one of all three (millimetres), where it spreads over the axis.
TEST_F(ReportFigures, SimulateFig10FullCalibrationIsVisible) {
  const Script all = read_script(figure("simulate", "fig10_trajectory", ".gp"));
  const auto all_data = read_data(figure("simulate", "fig10_trajectory", ".csv"));
  const Clause* full_in_all = clause_titled(all, "full calibration");
  ASSERT_TRUE(full_in_all) << all.text;
  EXPECT_LT(extent(all, all_data, *full_in_all).span, 0.25) << "not visible among the three";
  const Script s = read_script(figure("simulate", "fig10_trajectory_full", ".gp"));
  const auto data = read_data(figure("simulate", "fig10_trajectory_full", ".csv"));
  ASSERT_EQ(s.clauses.size(), 1u) << s.text;
  const Clause* full = clause_titled(s, "full calibration");
  ASSERT_TRUE(full) << s.text;
  EXPECT_GT(extent(s, data, *full).span, 0.9);
}

// Fig. 12: the transverse force |Fx, Fy| of the nominal and the calibrated
// model on an axis of its own (no Fz of about 2 N on it), the calibrated one
// visible on it.
TEST_F(ReportFigures, ForceTransverseForceHasItsOwnAxis) {
  const Script s = read_script(figure("force", "fig12_transverse", ".gp"));
  const auto data = read_data(figure("force", "fig12_transverse", ".csv"));
  const Clause* nominal = clause_titled(s, "nominal");
  const Clause* calibrated = clause_titled(s, "calibrated");
  ASSERT_TRUE(nominal && calibrated) << s.text;
  EXPECT_EQ(s.clauses.size(), 2u);
  EXPECT_TRUE(s.log_y);
  EXPECT_GT(extent(s, data, *calibrated).span, 0.25);
  EXPECT_LE(extent(s, data, *nominal).top, 1.0);
  // The transverse force is the smaller one by far: Fz is elsewhere.
  const Script z = read_script(figure("force", "fig12_normal", ".gp"));
  const auto fz = read_data(figure("force", "fig12_normal", ".csv"));
  const Clause* desired = clause_titled(z, "desired");
  ASSERT_NE(desired, nullptr) << z.text;
  const double fz_max = *std::max_element(fz.at(desired->y).begin(), fz.at(desired->y).end());
  const std::vector<double>& ft = data.at(nominal->y);
  EXPECT_LT(*std::max_element(ft.begin(), ft.end()), 0.1 * fz_max);
  EXPECT_FALSE(fs::exists(figure("force", "fig12_nominal", ".gp")));
}

// calibrate: the calibrated model's errors per sample (um) beside the nominal
// one's (mm).
TEST_F(ReportFigures, CalibrateErrorsAfterAreVisible) {
  const Script s = read_script(figure("calibrate", "errors_per_sample", ".gp"));
  const auto data = read_data(figure("calibrate", "errors_per_sample", ".csv"));
  const Clause* after = clause_titled(s, "calibrated");
  const Clause* before = clause_titled(s, "nominal");
  ASSERT_TRUE(after && before) << s.text;
  EXPECT_GT(extent(s, data, *after).span, 0.25);
  EXPECT_LE(extent(s, data, *before).top, 1.0);
}

// Quantities that cannot be negative (norms, errors' magnitudes, sd, ratios,
// RMS) never get an axis below zero: a log axis or a fixed lower limit >= 0,
// never gnuplot's autoscale with a margin below.
TEST_F(ReportFigures, NonnegativeQuantitiesHaveNoNegativeAxis) {
  // Signed quantities: transmission errors and residuals, I % (can be < 0),
  // the correlation map (a fixed image range), the distance error along the
  // trajectory. The wall force Fz is not one: the wall pushes.
  const std::regex signed_figure(
      "transmission_.*|fig7_.*|monte_carlo_improvement|correlation|fig10_trajectory.*|poses");
  int checked = 0;
  for (const std::string& report : reports_) {
    for (const std::string& name : figures(report)) {
      if (std::regex_match(name, signed_figure)) continue;
      SCOPED_TRACE(report + "/" + name);
      const Script s = read_script(figure(report, name, ".gp"));
      EXPECT_TRUE(s.log_y || s.y_lo >= 0) << s.text;
      // And no margin below zero from `set offsets` on an autoscaled axis.
      if (!s.log_y && std::isnan(s.y_lo)) {
        EXPECT_EQ(s.text.find("graph 0.05\n"), std::string::npos);
      }
      ++checked;
    }
  }
  EXPECT_GE(checked, 8);
}

// Two figures of a report never show the same data (Fig. 7 and the j4
// transmission fit were one plot twice).
TEST_F(ReportFigures, NoTwoFiguresOfAReportShowTheSameData) {
  auto same = [](const std::vector<double>& a, const std::vector<double>& b) {
    if (a.size() != b.size() || a.empty()) return false;
    for (size_t i = 0; i < a.size(); ++i) {
      if (std::abs(a[i] - b[i]) > 1e-9 * (1 + std::abs(a[i]))) return false;
    }
    return true;
  };
  for (const std::string& report : reports_) {
    const std::vector<std::string> names = figures(report);
    std::map<std::string, std::map<int, std::vector<double>>> data;
    for (const std::string& name : names) {
      if (name != "correlation") data[name] = read_data(figure(report, name, ".csv"));
    }
    for (auto a = data.begin(); a != data.end(); ++a) {
      for (auto b = std::next(a); b != data.end(); ++b) {
        // Duplicates: every y column of one (beyond its first, the x) is one of the other's.
        int shared = 0, columns = 0;
        for (const auto& [ca, va] : a->second) {
          if (ca == 2) continue;
          ++columns;
          for (const auto& [cb, vb] : b->second) shared += cb != 2 && same(va, vb);
        }
        EXPECT_FALSE(columns > 0 && shared >= std::min<int>(columns, 2))
            << report << ": " << a->first << " and " << b->first << " show the same data";
      }
    }
  }
  EXPECT_TRUE(fs::exists(figure("simulate", "fig7_j4", ".gp")));
  EXPECT_FALSE(fs::exists(figure("simulate", "transmission_j4", ".gp")));
  EXPECT_TRUE(fs::exists(figure("simulate", "transmission_j1", ".gp")));
}

// "identified" and "truth" differ in colour and dash; measurements are points.
TEST_F(ReportFigures, TruthIdentifiedAndMeasurementsAreDrawnApart) {
  int checked = 0;
  for (const std::string& name : figures("simulate")) {
    const Script s = read_script(figure("simulate", name, ".gp"));
    const Clause* truth = clause_titled(s, "truth");
    if (!truth) continue;
    SCOPED_TRACE(name);
    const Clause* identified = clause_titled(s, "identified");
    const Clause* measured = clause_titled(s, "measure");
    ASSERT_TRUE(identified && measured) << s.text;
    EXPECT_FALSE(truth->color.empty());
    EXPECT_FALSE(identified->color.empty());
    EXPECT_NE(truth->color, identified->color);
    EXPECT_NE(truth->dash, identified->dash);
    EXPECT_EQ(measured->style, "points");
    EXPECT_NE(measured->color, identified->color);
    EXPECT_NE(measured->color, truth->color);
    ++checked;
  }
  EXPECT_GE(checked, 4);  // Fig. 7 and the three other joints' fits
}

// Monte Carlo: every error bar inside the frame, with some margin, and the
// categories inside the x range.
TEST_F(ReportFigures, MonteCarloErrorBarsAreInsideTheFrame) {
  const Script s = read_script(figure("simulate", "monte_carlo_improvement", ".gp"));
  const auto data = read_data(figure("simulate", "monte_carlo_improvement", ".csv"));
  ASSERT_EQ(s.clauses.size(), 1u) << s.text;
  const std::vector<double>& mean = data.at(s.clauses[0].y);
  const std::vector<double>& half = data.at(s.clauses[0].y + 1);
  ASSERT_GT(mean.size(), 5u);
  EXPECT_DOUBLE_EQ(s.x_lo, -0.5);
  EXPECT_DOUBLE_EQ(s.x_hi, mean.size() - 0.5);
  ASSERT_FALSE(std::isnan(s.y_lo) || std::isnan(s.y_hi)) << s.text;
  const double margin = 0.01 * (s.y_hi - s.y_lo);
  for (size_t i = 0; i < mean.size(); ++i) {
    EXPECT_GT(mean[i] - half[i], s.y_lo + margin) << i;
    EXPECT_LT(mean[i] + half[i], s.y_hi - margin) << i;
  }
}

// RMSE / CRLB: the band that 20 trials of an efficient estimator fall in
// 90 % of the time from sampling alone, sqrt(chi^2_20 quantiles / 20) =
// sqrt(10.851 / 20) .. sqrt(31.410 / 20), not a fixed 0.9 .. 1.1.
TEST_F(ReportFigures, MonteCarloEfficiencyBandIsTheSamplingSpread) {
  const Script s = read_script(figure("simulate", "monte_carlo_efficiency", ".gp"));
  const auto data = read_data(figure("simulate", "monte_carlo_efficiency", ".csv"));
  const Clause* band = clause_titled(s, "5-95 % for 20 trials if efficient");
  ASSERT_NE(band, nullptr) << s.text;
  std::vector<double> lines;
  for (const Clause& c : s.clauses) {
    if (c.style == "lines") lines.push_back(data.at(c.y).front());
  }
  ASSERT_EQ(lines.size(), 2u) << s.text;
  std::sort(lines.begin(), lines.end());
  EXPECT_NEAR(lines[0], std::sqrt(10.851 / 20), 0.005);
  EXPECT_NEAR(lines[1], std::sqrt(31.410 / 20), 0.005);
  EXPECT_TRUE(s.y_lo >= 0);
}

TEST_F(ReportFigures, LegendsAreInsideOrBelowThePlot) {
  for (const std::string& report : reports_) {
    for (const std::string& name : figures(report)) {
      SCOPED_TRACE(report + "/" + name);
      const std::string gp = testing::slurp(figure(report, name, ".gp"));
      EXPECT_EQ(gp.find("key outside"), std::string::npos);
      std::smatch key;
      if (std::regex_search(gp, key, std::regex("set key ([^\n]*)"))) {
        EXPECT_TRUE(key[1].str().find("below") != std::string::npos ||
                    key[1].str().find("inside") != std::string::npos)
            << key[1];
      }
    }
  }
}

// The correlation map: drawn cell by cell (no stretched bitmap in the SVG),
// labelled on its colour bar, in the parameter table's order.
TEST_F(ReportFigures, CorrelationMapIsSharpLabelledAndInTableOrder) {
  const Script s = read_script(figure("calibrate", "correlation", ".gp"));
  EXPECT_NE(s.text.find("with image pixels"), std::string::npos) << s.text;
  EXPECT_NE(s.text.find("set cblabel \"correlation"), std::string::npos) << s.text;
  const std::string svg = testing::slurp(figure("calibrate", "correlation", ".svg"));
  ASSERT_FALSE(svg.empty());
  EXPECT_EQ(svg.find("<image"), std::string::npos);
  // The table's rows, first cells in document order, restricted to the map's names.
  const std::string html = testing::slurp(dir_ + "/calibrate/report.html");
  const std::set<std::string> mapped(s.xtics.begin(), s.xtics.end());
  ASSERT_GT(mapped.size(), 10u);
  std::vector<std::string> table;
  const std::regex first_cell("<tr><td>([^<]*)</td>");
  for (auto it = std::sregex_iterator(html.begin(), html.end(), first_cell);
       it != std::sregex_iterator(); ++it) {
    const std::string name = (*it)[1];
    if (mapped.count(name) && std::find(table.begin(), table.end(), name) == table.end())
      table.push_back(name);
  }
  EXPECT_EQ(table, s.xtics);
}

// The map follows the table (the identifiable parameters in model order) even
// when the fit lists its identified parameters in another order.
TEST(CorrelationFigure, RowsAndColumnsInTheTableOrder) {
  KinematicFit fit;
  for (const char* name : {"j1.a", "j1.alpha", "j1.d", "j2.a"}) {
    ParameterEstimate e;
    e.name = name;
    e.identifiable = e.name != "j1.alpha";
    fit.parameters.push_back(e);
  }
  fit.identified_names = {"j2.a", "j1.a", "j1.d"};
  fit.correlation.resize(3, 3);
  fit.correlation << 1, 0.2, 0.3,  // j2.a
      0.2, 1, 0.4,                 // j1.a
      0.3, 0.4, 1;                 // j1.d
  const FigureSpec f = detail::correlation_figure(fit);
  EXPECT_EQ(f.xtics, (std::vector<std::string>{"j1.a", "j1.d", "j2.a"}));
  ASSERT_EQ(f.matrix.rows(), 3);
  EXPECT_EQ(f.matrix(0, 1), 0.4);  // j1.a - j1.d
  EXPECT_EQ(f.matrix(0, 2), 0.2);  // j1.a - j2.a
  EXPECT_EQ(f.matrix(1, 2), 0.3);  // j1.d - j2.a
  EXPECT_EQ(f.matrix(2, 2), 1);
  EXPECT_FALSE(f.cblabel.empty());
}

// Every axis states its unit, "[unit]", but categories and counts.
TEST_F(ReportFigures, EveryAxisLabelHasAUnit) {
  const std::set<std::string> unitless = {"parameter", "pose", "sample", "parameters fitted",
                                          "candidate model"};
  for (const std::string& report : reports_) {
    for (const std::string& name : figures(report)) {
      SCOPED_TRACE(report + "/" + name);
      const Script s = read_script(figure(report, name, ".gp"));
      for (const std::string& label : {s.xlabel, s.ylabel}) {
        if (unitless.count(label)) continue;
        EXPECT_TRUE(std::regex_search(label, std::regex("\\[[^\\]]+\\]"))) << "'" << label << "'";
      }
    }
  }
}

// calibrate and plan show where their poses are: a 3-D figure (splot) of the
// tool points, x, y and z in mm, one point a pose (calibrate: the log's 200;
// plan: the 40 planned, joined in path order), their shadows on the floor.
TEST_F(ReportFigures, CalibrateAndPlanShowTheirPosesInTheWorkspace) {
  for (const auto& [report, poses] :
       std::vector<std::pair<std::string, size_t>>{{"calibrate", 200}, {"plan", 40}}) {
    SCOPED_TRACE(report);
    const std::string gp = testing::slurp(figure(report, "poses", ".gp"));
    ASSERT_FALSE(gp.empty());
    const Script s = read_script(figure(report, "poses", ".gp"));
    EXPECT_NE(s.text.find("\nsplot "), std::string::npos) << s.text;
    EXPECT_EQ(s.xlabel, "x [mm]");
    EXPECT_EQ(s.ylabel, "y [mm]");
    EXPECT_NE(s.text.find("set zlabel \"z [mm]\""), std::string::npos) << s.text;
    EXPECT_NE(s.text.find("set view equal xyz"), std::string::npos) << s.text;
    const auto data = read_data(figure(report, "poses", ".csv"));
    ASSERT_EQ(data.size(), 4u);  // x, y, z, the floor
    EXPECT_EQ(data.at(2).size(), poses);
    // The points spread over the workspace (not one point), above the floor.
    for (int c : {2, 3, 4}) {
      const auto [lo, hi] = std::minmax_element(data.at(c).begin(), data.at(c).end());
      EXPECT_GT(*hi - *lo, 10.0) << "column " << c;
    }
    EXPECT_LT(*std::max_element(data.at(5).begin(), data.at(5).end()),
              *std::min_element(data.at(4).begin(), data.at(4).end()));
    EXPECT_NE(clause_titled(s, "tool point"), nullptr) << s.text;
    EXPECT_EQ(clause_titled(s, "path order") != nullptr, report == "plan") << s.text;
    const std::string html = testing::slurp(dir_ + "/" + report + "/report.html");
    EXPECT_NE(html.find("<figure id=\"poses\">"), std::string::npos);
  }
}

}  // namespace
}  // namespace hapticcal
