// Every report opens with its outcome and carries what the terminal printed,
// in the terminal's units; results.json agrees with both (SI).
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

namespace fs = std::filesystem;

// One run of every command, shared by the tests (a Monte Carlo study of 3
// trials, its calibration, a force study, an evaluation and a plan).
class ReportOutcome : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new std::string(testing::fresh_folder("report_outcome"));
    runs_ = new std::map<std::string, testing::CliResult>;
    const std::string& d = *dir_;
    const std::string device = testing::source_path("data/devices/baser-7dof.yaml");
    (*runs_)["simulate"] = testing::run_cli("simulate --trials 3 --out " + d + "/simulate");
    (*runs_)["calibrate"] =
        testing::run_cli("calibrate --model " + device + " --log " + d +
                         "/simulate/identification.csv --out " + d + "/calibrate");
    (*runs_)["force"] =
        testing::run_cli("force --actual " + d + "/simulate/actual.yaml --nominal " + d +
                         "/simulate/nominal.yaml --calibrated " + d +
                         "/simulate/calibrated.yaml --out " + d + "/force");
    (*runs_)["evaluate"] =
        testing::run_cli("evaluate --model " + d + "/calibrate/calibrated.yaml --log " + d +
                         "/simulate/validation.csv --reference " + d +
                         "/simulate/nominal.yaml --out " + d + "/evaluate");
    (*runs_)["plan"] = testing::run_cli("plan --model " + device +
                                        " --measurement distance --poses 40 --pool 500 --seed 3 "
                                        "--refine-passes 0 --out " +
                                        d + "/plan");
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dir_;
    delete runs_;
  }
  static const testing::CliResult& run(const std::string& command) {
    const testing::CliResult& r = runs_->at(command);
    EXPECT_EQ(r.exit_code, 0) << command << ": " << r.err;
    return r;
  }
  static std::string html(const std::string& command) {
    return testing::slurp(*dir_ + "/" + command + "/report.html");
  }
  static nlohmann::json results(const std::string& command) {
    return nlohmann::json::parse(testing::slurp(*dir_ + "/" + command + "/results.json"));
  }
  static std::string* dir_;
  static std::map<std::string, testing::CliResult>* runs_;
};
std::string* ReportOutcome::dir_ = nullptr;
std::map<std::string, testing::CliResult>* ReportOutcome::runs_ = nullptr;

std::string unescape(std::string s) {
  for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
           {"&gt;", ">"}, {"&lt;", "<"}, {"&quot;", "\""}, {"&amp;", "&"}}) {
    for (size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size()))
      s.replace(at, from.size(), to);
  }
  return s;
}

// The report's outcome section, unescaped; empty if there is none.
std::string outcome(const std::string& html) {
  const size_t start = html.find("<section id=\"outcome\"");
  if (start == std::string::npos) return {};
  return unescape(html.substr(start, html.find("</section>", start) - start));
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

std::vector<std::string> numbers_in(const std::string& line) {
  static const std::regex number(R"(-?\d+\.\d+)");
  std::vector<std::string> found;
  for (auto it = std::sregex_iterator(line.begin(), line.end(), number);
       it != std::sregex_iterator(); ++it)
    found.push_back(it->str());
  return found;
}

// Every number of every terminal line containing one of `markers` is in `block`.
int expect_numbers_carried(const std::string& terminal, const std::vector<std::string>& markers,
                           const std::string& block) {
  int carried = 0;
  for (const std::string& line : lines_of(terminal)) {
    bool wanted = false;
    for (const std::string& m : markers) wanted = wanted || line.find(m) != std::string::npos;
    if (!wanted) continue;
    for (const std::string& n : numbers_in(line)) {
      EXPECT_NE(block.find(n), std::string::npos) << "'" << n << "' of: " << line;
      ++carried;
    }
  }
  return carried;
}

// The cells of the report's table row whose first cell is `name`.
std::vector<std::string> table_row(const std::string& html, const std::string& name) {
  const std::string start = "<tr><td>" + name + "</td>";
  const size_t at = html.find(start);
  if (at == std::string::npos) return {};
  const std::string row = html.substr(at, html.find("</tr>", at) - at);
  static const std::regex cell("<td[^>]*>([^<]*)</td>");
  std::vector<std::string> cells;
  for (auto it = std::sregex_iterator(row.begin(), row.end(), cell); it != std::sregex_iterator();
       ++it)
    cells.push_back(unescape((*it)[1].str()));
  return cells;
}

std::vector<std::string> words(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> w;
  for (std::string s; in >> s;) w.push_back(s);
  return w;
}

TEST_F(ReportOutcome, EveryReportOpensWithItsOutcome) {
  for (const char* command : {"simulate", "calibrate", "force", "evaluate", "plan"}) {
    SCOPED_TRACE(command);
    run(command);
    const std::string page = html(command);
    const size_t title = page.find("<h1>"), block = page.find("<section id=\"outcome\"");
    ASSERT_NE(block, std::string::npos);
    EXPECT_LT(title, block);
    // Nothing but the title before it: no table, section heading or figure.
    for (const char* later : {"<h2", "<table", "<figure", "<p>"}) {
      const size_t at = page.find(later);
      if (at != std::string::npos) EXPECT_LT(block, at) << later;
    }
    const std::string o = outcome(page);
    EXPECT_NE(o.find("Status: "), std::string::npos) << o;
    EXPECT_NE(o.find("<ul class=\"headline\">"), std::string::npos) << o;
  }
}

TEST_F(ReportOutcome, CalibrateCarriesWhatTheTerminalShows) {
  const testing::CliResult& r = run("calibrate");
  const std::string o = outcome(html("calibrate"));
  EXPECT_NE(o.find("Status: converged"), std::string::npos) << o;
  // Step 1 (RMS before and after, the encoder zero c of all 7 joints), the
  // solver, the RMS residual, the held-out error, notes and warnings.
  const int carried =
      expect_numbers_carried(r.out,
                             {"RMS of ext - q - c", "c (encoder zero",
                              "solver:", "RMS residual:", "held-out RMS", "note:", "warning:"},
                             o);
  // Four step-1 joints (three capstans and j4's polynomial) of four numbers
  // each, and the solver, residual and held-out lines.
  EXPECT_GE(carried, 4 * 4 + 3) << r.out;
  EXPECT_NE(o.find("held-out RMS"), std::string::npos);
  EXPECT_NE(o.find("solver: converged"), std::string::npos);
}

TEST_F(ReportOutcome, CalibrateTablesUseTheTerminalsUnits) {
  const testing::CliResult& r = run("calibrate");
  const std::string page = html("calibrate");
  const std::map<std::string, std::string> capstan = {{"Re", "ratio_error"},
                                                      {"ro", "r_out"},
                                                      {"bo", "beta_out"},
                                                      {"ri", "r_in"},
                                                      {"bi", "beta_in"}};
  std::string joint;
  int step1 = 0, step2 = 0;
  bool in_step2 = false;
  for (const std::string& line : lines_of(r.out)) {
    const std::vector<std::string> w = words(line);
    if (w.empty()) continue;
    if (line.starts_with("Step 2")) in_step2 = true;
    if (line.starts_with("  held at nominal")) in_step2 = false;
    if (!in_step2 && line.find("RMS of ext - q - c") != std::string::npos) joint = w[0];
    if (!in_step2 && capstan.count(w[0]) && w.size() >= 4) {
      // "    ro   12.345678 +- 0.000123 mm": nominal, identified, sd and unit as printed.
      SCOPED_TRACE(line);
      const std::vector<std::string> cells = table_row(page, joint + "." + capstan.at(w[0]));
      ASSERT_EQ(cells.size(), 5u);
      EXPECT_EQ(cells[2], w[1]);
      EXPECT_EQ(cells[3], w[3]);
      EXPECT_EQ(cells[4], w.size() > 4 ? w[4] : "-");
      ++step1;
    }
    if (!in_step2 && line.find("c (encoder zero") != std::string::npos) {
      const std::vector<std::string> cells = table_row(page, joint + ".c (encoder zero, nuisance)");
      ASSERT_EQ(cells.size(), 5u) << line;
      EXPECT_EQ(cells[2], w[4]) << line;
      EXPECT_EQ(cells[4], "mrad");
    }
    // "  j1.a  nominal identified unit deviation +- sd unit corr with"
    if (in_step2 && w.size() >= 9 && w[5] == "+-") {
      SCOPED_TRACE(line);
      const std::vector<std::string> cells = table_row(page, w[0]);
      ASSERT_GE(cells.size(), 8u);
      for (int k : {1, 2, 3, 4}) EXPECT_EQ(cells[k], w[k]);
      EXPECT_EQ(cells[5], w[6]);  // sd
      EXPECT_EQ(cells[6], w[7]);  // its unit
      ++step2;
    }
  }
  EXPECT_EQ(step1, 3 * 5) << "three capstan joints of five parameters";
  EXPECT_EQ(step2, results("calibrate")["identified"].get<int>());
}

TEST_F(ReportOutcome, SimulateTablesAgreeAcrossTerminalReportAndJson) {
  const testing::CliResult& r = run("simulate");
  const std::string page = html("simulate");
  const nlohmann::json params = results("simulate")["parameters"];
  int table2 = 0, table3 = 0;
  int table = 0;
  for (const std::string& line : lines_of(r.out)) {
    if (line.starts_with("Table 2")) table = 2;
    if (line.starts_with("Table 3")) table = 3;
    if (line.starts_with("Validation")) table = 0;
    const std::vector<std::string> w = words(line);
    if (table == 0 || w.size() < 4 || !params.contains(w[0])) continue;
    SCOPED_TRACE(line);
    const nlohmann::json& p = params[w[0]];
    const std::vector<std::string> cells = table_row(page, w[0]);
    ASSERT_GE(cells.size(), 8u);
    // The same numbers, to the terminal's precision, and the same unit.
    const double tolerance = table == 2 ? 1e-6 : 6e-4;
    EXPECT_NEAR(std::stod(cells[1]), std::stod(w[1]), tolerance);
    EXPECT_NEAR(std::stod(cells[2]), std::stod(w[2]), tolerance);
    // results.json: SI, `assigned` the truth's value and `assigned_deviation`
    // what Table 3 prints (in mm or mrad).
    EXPECT_NEAR(p["assigned_deviation"].get<double>(),
                p["assigned"].get<double>() - p["nominal"].get<double>(), 1e-15);
    if (table == 3) {
      EXPECT_NEAR(p["assigned_deviation"].get<double>() * 1e3, std::stod(w[1]), tolerance);
      EXPECT_NEAR(p["identified_deviation"].get<double>() * 1e3, std::stod(w[2]), tolerance);
      EXPECT_TRUE(cells.back() == "mm" || cells.back() == "mrad") << cells.back();
      ++table3;
    } else {
      const std::string unit = cells.back();
      EXPECT_EQ(unit, line.ends_with(" mm") ? "mm" : line.ends_with(" deg") ? "deg" : "-");
      const double scale = unit == "mm" ? 1e3 : unit == "deg" ? 180 / M_PI : 1;
      EXPECT_NEAR(p["assigned"].get<double>() * scale, std::stod(w[1]), tolerance);
      ++table2;
    }
  }
  EXPECT_EQ(table2, 3 * 5);  // three capstans
  EXPECT_EQ(table2 + table3, static_cast<int>(params.size()));
}

TEST_F(ReportOutcome, SimulateOutcomeHasTheValidationAndWhyPositionStays) {
  const testing::CliResult& r = run("simulate");
  const std::string o = outcome(html("simulate"));
  EXPECT_GE(expect_numbers_carried(r.out, {"Validation (", "Trajectory ("}, o), 6 + 7);
  EXPECT_NE(o.find("RMSE / CRLB median"), std::string::npos) << o;
  // The distance measurement cannot see the base's turn about the anchor: the
  // note names what it held for that reason, as results.json's held list does.
  const nlohmann::json held = results("simulate")["held"];
  int unseen = 0;
  for (const auto& [name, why] : held.items()) {
    if (why.get<std::string>().starts_with("no effect")) {
      EXPECT_NE(o.find(name), std::string::npos) << name;
      ++unseen;
    }
  }
  EXPECT_GE(unseen, 2);
  EXPECT_NE(o.find("The distance error is what the calibration reached"), std::string::npos);
}

TEST_F(ReportOutcome, ForceOutcomeHasTheForcesAndTheSetUp) {
  const testing::CliResult& r = run("force");
  const std::string o = outcome(html("force"));
  EXPECT_GE(expect_numbers_carried(r.out, {"transverse force", "at the end:"}, o), 6);
  const nlohmann::json j = results("force");
  EXPECT_NE(o.find(fmt::format("stable for |G| < {:.4f}", j["stable_gain_limit"].get<double>())),
            std::string::npos)
      << o;
  EXPECT_NE(o.find("posture q = ["), std::string::npos) << o;
}

TEST_F(ReportOutcome, EvaluateWritesAReportWithTheTerminalsLines) {
  const testing::CliResult& r = run("evaluate");
  const std::string o = outcome(html("evaluate"));
  int lines = 0;
  for (const std::string& line : lines_of(r.out)) {
    if (line.starts_with("model:") || line.starts_with("log:") || line.starts_with("report:") ||
        line.starts_with("wrote ") || line.starts_with("replaced "))
      continue;
    EXPECT_NE(o.find("<li>" + line + "</li>"), std::string::npos) << line;
    ++lines;
  }
  EXPECT_EQ(lines, 4) << r.out;  // distance, position and both against the reference
  const nlohmann::json j = results("evaluate");
  EXPECT_EQ(j["n"], 200);
  EXPECT_NE(r.out.find("report: " + *dir_ + "/evaluate/report.html"), std::string::npos) << r.out;
}

TEST_F(ReportOutcome, EvaluateJsonWritesFilesOnlyWithOut) {
  const std::string cwd = testing::fresh_folder("report_outcome_json");
  const std::vector<std::string> args = {"evaluate",
                                         "--model",
                                         testing::source_path("data/devices/baser-7dof.yaml"),
                                         "--log",
                                         *dir_ + "/simulate/validation.csv",
                                         "--json"};
  const testing::CliResult bare = testing::run_cli_in(cwd, args);
  ASSERT_EQ(bare.exit_code, 0) << bare.err;
  EXPECT_FALSE(fs::exists(cwd + "/hapticcal-out")) << "--json without --out writes no files";
  std::vector<std::string> with_out = args;
  with_out.insert(with_out.end(), {"--out", "ev"});
  const testing::CliResult written = testing::run_cli_in(cwd, with_out);
  ASSERT_EQ(written.exit_code, 0) << written.err;
  EXPECT_EQ(written.out, bare.out) << "stdout stays the JSON object alone";
  EXPECT_NO_THROW(nlohmann::json::parse(written.out));
  EXPECT_TRUE(fs::exists(cwd + "/ev/report.html"));
  EXPECT_NE(written.err.find("report: ev/report.html"), std::string::npos) << written.err;
  fs::remove_all(cwd);
}

TEST_F(ReportOutcome, PlanOutcomeHasThePredictedErrors) {
  const testing::CliResult& r = run("plan");
  const std::string o = outcome(html("plan"));
  for (const std::string& line : lines_of(r.out)) {
    if (line.find("predicted RMS") == std::string::npos) continue;
    const std::vector<std::string> n = numbers_in(line);
    ASSERT_GE(n.size(), 2u);
    EXPECT_NE(o.find(n[0] + " um with the 40 planned poses"), std::string::npos) << o;
    EXPECT_NE(o.find(n[1] + " um"), std::string::npos) << o;
  }
}

// Units on every table column: a column of numbers has its unit in its header
// ("[mm]"), or its table has a unit column, or it is a count, a percentage or
// a ratio by name.
TEST_F(ReportOutcome, EveryColumnOfNumbersHasItsUnit) {
  const std::set<std::string> dimensionless = {"parameters",
                                               "samples",
                                               "I %",
                                               "paper I %",
                                               "mean I %",
                                               "RMSE / CRLB",
                                               "largest correlation",
                                               "condition number",
                                               "O1",
                                               "O2",
                                               "O3",
                                               "O4",
                                               "ratio"};
  static const std::regex header_cell("<th>([^<]*)</th>"), cell("<td[^>]*>([^<]*)</td>");
  int columns = 0;
  for (const char* command : {"simulate", "calibrate", "force", "evaluate", "plan"}) {
    const std::string page = html(command);
    for (size_t at = page.find("<table>"); at != std::string::npos;
         at = page.find("<table>", at + 1)) {
      const std::string table = page.substr(at, page.find("</table>", at) - at);
      std::vector<std::string> header;
      for (auto it = std::sregex_iterator(table.begin(), table.end(), header_cell);
           it != std::sregex_iterator(); ++it)
        header.push_back(unescape((*it)[1].str()));
      const bool unit_column = std::find(header.begin(), header.end(), "unit") != header.end();
      std::vector<bool> numeric(header.size(), true);
      size_t rows = 0;
      for (size_t r = table.find("<tr><td"); r != std::string::npos;
           r = table.find("<tr><td", r + 1)) {
        const std::string row = table.substr(r, table.find("</tr>", r) - r);
        size_t c = 0;
        for (auto it = std::sregex_iterator(row.begin(), row.end(), cell);
             it != std::sregex_iterator() && c < header.size(); ++it, ++c) {
          const std::string v = (*it)[1].str();
          char* end = nullptr;
          std::strtod(v.c_str(), &end);
          if (v != "-" && (v.empty() || end != v.c_str() + v.size())) numeric[c] = false;
        }
        ++rows;
      }
      if (rows == 0) continue;
      for (size_t c = 0; c < header.size(); ++c) {
        if (!numeric[c]) continue;
        ++columns;
        EXPECT_TRUE(unit_column || header[c].find('[') != std::string::npos ||
                    dimensionless.count(header[c]))
            << command << ": column '" << header[c] << "' has no unit";
      }
    }
  }
  EXPECT_GE(columns, 20);
}

// plan's table: the sd in the units of calibrate's tables, with a unit column;
// plan.json keeps SI.
TEST_F(ReportOutcome, PlanTableUsesTheTerminalsUnits) {
  run("plan");
  const std::string page = html("plan");
  const nlohmann::json sd =
      nlohmann::json::parse(testing::slurp(*dir_ + "/plan/plan.json"))["parameter_sd"];
  const std::map<std::string, std::pair<double, std::string>> expected = {
      {"j1.a", {1e3, "mm"}},        {"j2.alpha", {1e3, "mrad"}},
      {"j1.r_out", {1e3, "mm"}},    {"j1.beta_out", {180 / M_PI, "deg"}},
      {"j1.ratio_error", {1, "-"}}, {"j4.c1", {1, "rad"}}};
  for (const auto& [name, unit] : expected) {
    SCOPED_TRACE(name);
    const std::vector<std::string> cells = table_row(page, name);
    ASSERT_EQ(cells.size(), 5u);
    EXPECT_EQ(cells[4], unit.second);
    const double planned = sd[name]["planned"].get<double>() * unit.first;
    EXPECT_NEAR(std::stod(cells[1]), planned, 1e-3 * planned);
  }
}

// A pose's angles print in deg, their small changes and sd in mrad, in the
// terminal's table and the report's alike: the paper's device's twists of
// -pi/2 are -90.0000 deg, never -1570.7963 mrad.
TEST_F(ReportOutcome, CalibratePoseAnglesInDegreesTheirChangesInMrad) {
  const testing::CliResult& r = run("calibrate");
  const std::string page = html("calibrate");
  for (const std::string& text : {r.out, page}) {
    EXPECT_EQ(text.find("1570.7963"), std::string::npos);
    EXPECT_EQ(text.find("1570.8"), std::string::npos);
  }
  int angles = 0;
  for (const std::string& line : lines_of(r.out)) {
    const std::vector<std::string> w = words(line);
    if (w.size() < 9 || w[5] != "+-") continue;
    SCOPED_TRACE(line);
    const bool angle =
        w[0].find("alpha") != std::string::npos || w[0].find("theta") != std::string::npos;
    EXPECT_EQ(w[3], angle ? "deg" : "mm");
    EXPECT_EQ(w[7], angle ? "mrad" : "mm");
    if (!angle) continue;
    // The deviation is identified - nominal, in mrad.
    EXPECT_NEAR((std::stod(w[2]) - std::stod(w[1])) * M_PI / 180 * 1e3, std::stod(w[4]), 2e-3);
    EXPECT_LE(std::abs(std::stod(w[1])), 360.0);
    ++angles;
  }
  EXPECT_GE(angles, 10);
  const std::vector<std::string> twist = table_row(page, "j1.alpha");
  ASSERT_GE(twist.size(), 7u);
  EXPECT_EQ(twist[1], "-90.0000");
  EXPECT_EQ(twist[3], "deg");
  EXPECT_EQ(twist[6], "mrad");
}

// The paper's own lines stay in the paper's study.
TEST_F(ReportOutcome, SimulateOfThePapersDeviceKeepsThePapersLines) {
  const testing::CliResult& r = run("simulate");
  const std::string page = html("simulate");
  for (const char* text : {"sigma_e", "kinematic-only", "the paper measured", "paper I %",
                           "Fig. 8: position error", "fig8_orientation", "fig10_trajectory"}) {
    EXPECT_NE(page.find(text), std::string::npos) << text;
  }
  EXPECT_NE(r.out.find("paper: "), std::string::npos);
}

// The shipped scenarios on other devices (the MTM and the Touch with a
// tracker's poses, the PHANToM with a two-socket fixture): every ratio a
// number or "n/a" with its reason, never a fake 0.000; no line of the paper's
// study; no orientation where the measurement has none; no figure that
// failed; the staging folder named nowhere.
class ScenarioReports : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new std::string(testing::fresh_folder("scenario_reports"));
    runs_ = new std::map<std::string, testing::CliResult>;
    for (const char* name : {"phantom-two-socket", "mtm-tracker", "touch-tracker"}) {
      (*runs_)[name] = testing::run_cli(std::vector<std::string>{
          "simulate", "--scenario",
          testing::source_path(std::string("data/scenarios/") + name + ".yaml"), "--threads", "2",
          "--out", *dir_ + "/" + name});
    }
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dir_;
    delete runs_;
  }
  static const testing::CliResult& run(const std::string& name) {
    const testing::CliResult& r = runs_->at(name);
    EXPECT_EQ(r.exit_code, 0) << name << ": " << r.err;
    return r;
  }
  static std::string html(const std::string& name) {
    return testing::slurp(*dir_ + "/" + name + "/report.html");
  }
  static std::set<std::string> figure_names(const std::string& name) {
    std::set<std::string> out;
    const fs::path figures = *dir_ + "/" + name + "/figures";
    if (!fs::exists(figures)) return out;
    for (const auto& e : fs::directory_iterator(figures))
      if (e.path().extension() == ".gp") out.insert(e.path().stem().string());
    return out;
  }
  static std::string* dir_;
  static std::map<std::string, testing::CliResult>* runs_;
};
std::string* ScenarioReports::dir_ = nullptr;
std::map<std::string, testing::CliResult>* ScenarioReports::runs_ = nullptr;

// The column's cells of every row of the report's tables whose header has `column`.
std::vector<std::string> column_cells(const std::string& page, const std::string& column) {
  static const std::regex header_cell("<th>([^<]*)</th>"), cell("<td[^>]*>([^<]*)</td>");
  std::vector<std::string> cells;
  for (size_t at = page.find("<table>"); at != std::string::npos;
       at = page.find("<table>", at + 1)) {
    const std::string table = page.substr(at, page.find("</table>", at) - at);
    int index = -1, c = 0;
    for (auto it = std::sregex_iterator(table.begin(), table.end(), header_cell);
         it != std::sregex_iterator(); ++it, ++c)
      if (unescape((*it)[1].str()) == column) index = c;
    if (index < 0) continue;
    for (size_t r = table.find("<tr><td"); r != std::string::npos;
         r = table.find("<tr><td", r + 1)) {
      const std::string row = table.substr(r, table.find("</tr>", r) - r);
      int k = 0;
      for (auto it = std::sregex_iterator(row.begin(), row.end(), cell);
           it != std::sregex_iterator(); ++it, ++k)
        if (k == index) cells.push_back(unescape((*it)[1].str()));
    }
  }
  return cells;
}

TEST_F(ScenarioReports, TwoSocketStudyHasItsCramerRaoRatios) {
  const testing::CliResult& r = run("phantom-two-socket");
  const std::string page = html("phantom-two-socket");
  const std::vector<std::string> ratios = column_cells(page, "RMSE / CRLB");
  ASSERT_GE(ratios.size(), 5u) << page;
  for (const std::string& v : ratios) {
    SCOPED_TRACE(v);
    if (v == "n/a") {
      EXPECT_NE(page.find("RMSE / CRLB n/a: "), std::string::npos) << "n/a without its reason";
      continue;
    }
    // A ratio of an estimator to its bound, never the 0.000 of a missing
    // bound: near 1, or below it where the model search held the parameter in
    // some trials (j1.a, seen only through the 50 mm: 0.15).
    EXPECT_NE(v, "0.000");
    EXPECT_GT(std::stod(v), 0.05);
    EXPECT_LT(std::stod(v), 3.0);
  }
  const std::string o = outcome(page);
  EXPECT_NE(o.find("RMSE / CRLB median"), std::string::npos) << o;
  EXPECT_EQ(o.find("median 0.000"), std::string::npos) << o;
  EXPECT_TRUE(figure_names("phantom-two-socket").count("monte_carlo_efficiency"));
  // The terminal's error in bound sd too: a number, not "-".
  int numbers = 0;
  for (const std::string& line : lines_of(r.out)) {
    const std::vector<std::string> w = words(line);
    if (w.size() == 5 && w[0].find('.') != std::string::npos && w[4] != "-") ++numbers;
  }
  EXPECT_GE(numbers, 5) << r.out;
}

TEST_F(ScenarioReports, NoPaperLinesOutsideThePapersDevice) {
  for (const char* name : {"phantom-two-socket", "mtm-tracker", "touch-tracker"}) {
    SCOPED_TRACE(name);
    run(name);
    const std::string page = html(name);
    for (const char* text :
         {"sigma_e", "kinematic-only", "paper", "Fig. 8", "Fig. 10", "Table 2", "Table 3"}) {
      EXPECT_EQ(page.find(text), std::string::npos) << text;
    }
    const std::set<std::string> figures = figure_names(name);
    EXPECT_FALSE(figures.empty());
    EXPECT_FALSE(figures.count("fig10_trajectory"));
    EXPECT_FALSE(figures.count("fig10_trajectory_full"));
  }
}

TEST_F(ScenarioReports, OrientationOnlyWhereTheMeasurementHasIt) {
  const std::string fixture = html("phantom-two-socket");
  EXPECT_EQ(outcome(fixture).find("orientation"), std::string::npos) << outcome(fixture);
  EXPECT_FALSE(figure_names("phantom-two-socket").count("fig8_orientation"));
  EXPECT_TRUE(figure_names("phantom-two-socket").count("fig8_position"));
  // Poses have orientations: their errors are shown.
  for (const char* name : {"mtm-tracker", "touch-tracker"}) {
    EXPECT_NE(outcome(html(name)).find("orientation RMS"), std::string::npos) << name;
    EXPECT_TRUE(figure_names(name).count("fig8_orientation")) << name;
  }
}

TEST_F(ScenarioReports, EveryFigureDrawnAndNoStagingFolderNamed) {
  for (const char* name : {"phantom-two-socket", "mtm-tracker", "touch-tracker"}) {
    SCOPED_TRACE(name);
    const testing::CliResult& r = run(name);
    EXPECT_EQ(r.out.find("failed"), std::string::npos) << r.out;
    const fs::path folder = *dir_ + "/" + name;
    // The staging folder is "<parent>/.<name>.tmp-XXXXXX" (OutputSet).
    const std::string staging = "/." + std::string(name) + ".tmp-";
    EXPECT_EQ(r.out.find(staging), std::string::npos) << r.out;
    for (const auto& e : fs::recursive_directory_iterator(folder)) {
      if (!e.is_regular_file()) continue;
      const std::string ext = e.path().extension().string();
      if (ext != ".html" && ext != ".gp" && ext != ".svg" && ext != ".log" && ext != ".json")
        continue;
      const std::string text = testing::slurp(e.path().string());
      EXPECT_EQ(text.find(".tmp-"), std::string::npos) << e.path();
      EXPECT_EQ(text.find(staging), std::string::npos) << e.path();
    }
    EXPECT_EQ(html(name).find("failed"), std::string::npos);
    EXPECT_FALSE(fs::exists(folder / "figures" / "fig8_orientation.gp.log"));
  }
}

}  // namespace
}  // namespace hapticcal
