// Reports: figures drawn by gnuplot (SVG for the page, PNG for papers) and one
// self-contained report.html per command (the SVGs inline: it opens offline).
#pragma once

#include <Eigen/Core>
#include <limits>
#include <string>
#include <vector>

namespace hapticcal {

struct Series {
  std::string label;            // empty: no key entry
  int x = 0, y = 1;             // data columns (zero-based); x = -1: the row number
  std::string style = "lines";  // gnuplot: lines, points, linespoints, impulses, boxes
  int error = -1;               // a column of half error bars (style yerrorbars)
  // Drawing: a gnuplot colour ("black", "#0072b2"; empty: gnuplot's next), dash
  // type (0: solid), line width and point type (0: gnuplot's defaults).
  std::string color;
  int dash = 0;
  double width = 0;
  int point = 0;
  // A third data column (zero-based): the figure is drawn in 3-D (splot) if
  // any series has one.
  int z = -1;
};

// One figure. The title is the HTML caption only: gnuplot draws none.
struct FigureSpec {
  std::string name;  // file stem
  std::string title, xlabel, ylabel;
  std::string zlabel;                        // a 3-D figure's (Series::z)
  std::vector<std::vector<double>> columns;  // the data, column by column
  std::vector<std::string> xtics;            // category labels by row (empty: numeric x)
  std::vector<Series> series;
  Eigen::MatrixXd matrix;  // if non-empty: a heat map of it (with xtics as labels)
  std::string cblabel;     // the heat map's colour bar label
  // Axes: a log y axis, and fixed limits (NaN: gnuplot's autoscale). A quantity
  // that cannot be negative gets y_min = 0 (or a log axis).
  bool log_y = false;
  double x_min = std::numeric_limits<double>::quiet_NaN();
  double x_max = std::numeric_limits<double>::quiet_NaN();
  double y_min = std::numeric_limits<double>::quiet_NaN();
  double y_max = std::numeric_limits<double>::quiet_NaN();
  std::string extra;  // more gnuplot commands
};

// A log y axis over whole decades that hold the positive values of the
// figure's series (zeros and negatives fall below it), at most `decades` wide
// down from the largest value.
void use_log_y(FigureSpec& figure, int decades = 5);

// What a report opens with, before any table or figure: the status and the
// headline numbers a reader needs first (plain text; write_report escapes it).
struct Outcome {
  std::string status;                 // e.g. "converged", "not usable", "done"
  bool usable = true;                 // drawn green, else red
  std::vector<std::string> headline;  // the numbers, one line each
  std::vector<std::string> notes;     // warnings and notes, as the terminal prints them
};

struct Report {
  std::string title;
  Outcome outcome;                    // section#outcome, first after the title
  std::vector<std::string> sections;  // HTML blocks after the outcome, before the figures
  std::vector<FigureSpec> figures;
};

// Writes DIR/figures/<name>.svg and .png with gnuplot and DIR/report.html.
// Returns the number of figures drawn; if gnuplot is missing the report is written
// without them and `note` says so.
int write_report(const Report& report, const std::string& dir, std::string& note);

// An HTML table (its text escaped by markup_escaped, core/error.hpp).
std::string html_table(const std::vector<std::string>& header,
                       const std::vector<std::vector<std::string>>& rows);

}  // namespace hapticcal

#include "hapticcal/core/log.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/study/control.hpp"
#include "hapticcal/study/study.hpp"

namespace hapticcal {

// calibrate: per-transmission fit and residuals, measurement errors before and
// after per sample, the parameter table with sd, the identifiability list and
// the correlation heat map.
Report calibration_report(const CalibrationResult& result, const DeviceModel& nominal,
                          const Log& log, const std::vector<PointDistance>& point_distances = {},
                          const std::vector<KnownPoint>& known_points = {});
// simulate: Figs 7, 8, 9-like fits, 10, and for Monte Carlo the I % spread and
// RMSE / CRLB per parameter, with the Table 2 and 3 analogues, from the series
// the first trial keeps in memory (TrialResult::figures).
Report study_report(const Scenario& scenario, const StudyResult& result);
// What a study shows beyond what every study has (the report and simulate's
// terminal alike). Orientation errors: of a measurement that has them (poses),
// and the paper's Fig. 8; a distance, position, point or plane measurement has
// none (a fixture's truth then moves no angle the validation could see).
bool shows_orientation(const Scenario& scenario);
// The trajectory of Fig. 10 (the distance from the paper's anchor, full against
// kinematic-only calibration): the paper's study, or a distance study whose
// step 1 ran (else the two calibrations are one).
bool shows_trajectory(const Scenario& scenario, const TrialResult& trial);
// The validation's errors before and after a trial's calibration, as the
// report and the terminal print them: the position's RMS, and the
// orientation's and the distance's where the study shows them.
std::string validation_figures(const Scenario& scenario, const TrialResult& trial);
// The instrument's noise beyond sigma_m: ", sigma_r X rad" where the
// measurement has rotation rows, else nothing.
std::string rotation_noise(const Scenario& scenario);
// force: the Fig. 12 analogue for the nominal and the calibrated model.
Report force_report(const ForceRun& nominal, const ForceRun& calibrated);
// force's outcome block: the transverse force before and after, the final Fz
// and the set-up (wall, gain and its stability limit, locked joint, posture).
Outcome force_outcome(const ForceStudy& study);

struct Evaluation;
// evaluate: the lines the terminal prints as the outcome, each error per
// sample (and the reference model's, if given), and the fixture's labels.
// Two streams' clocks (calibrate --tracker, evaluate --tracker): the estimate,
// the samples, and the RMS residual of `model` ("calibrated model", "model
// held") against the offset about it.
void clock_section(const ClockEstimate& clock, const std::string& model, Report& report);

Report evaluation_report(const DeviceModel& model, const std::string& model_path, const Log& log,
                         const Evaluation& ev, const Evaluation* reference,
                         const std::string& reference_path, const std::vector<std::string>& lines);
// A tree's evaluate: each tip's evaluation report in turn under its heading,
// its figures named by tip; `lines` the terminal's, the outcome's headline.
// `references[c]`: tip c's reference evaluation, or null.
Report tree_evaluation_report(const DeviceModel& tree, const std::string& model_path,
                              const std::vector<std::string>& tips, const std::vector<Log>& parts,
                              const std::vector<Evaluation>& evaluations,
                              const std::vector<const Evaluation*>& references,
                              const std::string& reference_path, const std::string& log_origin,
                              const std::vector<std::string>& lines);

class PlanProblem;
struct Plan;
// plan: the predicted sd per parameter and over the workspace, planned against
// random poses of the same count, and the observability indices.
Report plan_report(const PlanProblem& problem, const Plan& plan);

}  // namespace hapticcal
