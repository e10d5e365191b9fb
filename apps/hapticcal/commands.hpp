// The commands of the hapticcal tool besides plan (plan_command.hpp): each
// registers its subcommand and options on the app, returning the subcommand
// (true when given), and runs from the options parsed. Parsing and printing
// only; the work is the library's. Bad input throws hapticcal::InputError
// (exit 2).
#pragma once

#include <CLI/CLI.hpp>
#include <optional>
#include <string>
#include <vector>

#include "command_support.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/identification/stream.hpp"
#include "hapticcal/study/control.hpp"

namespace hapticcal::cli {

// `hapticcal calibrate`: two-step identification from a log. The defaults are
// the library's (CalibrationOptions, StreamOptions), as Python's keywords are.
struct CalibrateOptions {
  std::string fixture;
  std::vector<std::string> point_distance;
  std::string model, log, columns, out = "hapticcal-out/calibrate", fix, free, joint_errors;
  ChainOptions chain;
  bool no_transmission = false, force = false, keep_all = false, select = false, strict = false;
  bool prior = false, no_search = false;
  std::vector<std::string> tolerances;  // NAME=SD
  double prior_scale = 0;               // 0: by the evidence
  std::string loss = to_string(CalibrationOptions{}.loss);
  int samples = CalibrationOptions{}.samples, folds = CalibrationOptions{}.folds;
  int threads = CalibrationOptions{}.threads;  // the model search's; 0: one a core
  unsigned long long seed = CalibrationOptions{}.seed;
  double sigma = 0;
  int polynomial_order = 0;
  double encoder_resolution = 0;  // 0: not given
  double tolerance = CalibrationOptions{}.dependency_tolerance;
  std::string tracker;  // a tracker's stream on its own clock
  std::string markers;  // X1,Y1,Z1,...: a marker body in the tool frame
  double clock_search = StreamOptions{}.search_range;  // s
  bool clock_drift = false;
  std::string tool_point;  // X,Y,Z or "nominal": device.yaml's tool ("": the measured point)
};
CLI::App* add_calibrate_command(CLI::App& app, CalibrateOptions& options);
// 0, or kExitUnusable when the calibration is not usable (no calibrated model replaced).
int run_calibrate(const CalibrateOptions& options);

// `hapticcal evaluate`: RMS and max error of a model on a log.
struct EvaluateOptions {
  std::string fixture;
  std::vector<std::string> point_distance;
  std::string model, log, columns, reference, out = "hapticcal-out/evaluate";
  std::string tracker;  // a second session's tracker stream (--log is the device's)
  double clock_search = StreamOptions{}.search_range;
  bool clock_drift = false;
  std::string register_what;    // --register: frame or frame,tool
  bool register_given = false;  // --register "" is refused, not taken as absent
  ChainOptions chain;
  bool json = false;
  bool out_given = false;  // --json writes no files unless --out is given
  std::string markers;     // X1,Y1,Z1,...: a marker body in the tool frame
  std::string iso9283;     // an ISO 9283 test plan's plan.csv the log follows
  std::string conditions;  // its test conditions, as the user states them
};
CLI::App* add_evaluate_command(CLI::App& app, EvaluateOptions& options);
// register_given and out_given are set from the parsed command first.
int run_evaluate(const EvaluateOptions& options);

// `hapticcal simulate`: the paper's simulation study, or one on any device.
struct SimulateOptions {
  std::string scenario, out = "hapticcal-out/simulate", device;
  ChainOptions chain;
  int trials = 0, threads = 0;
  long long seed = -1;
};
CLI::App* add_simulate_command(CLI::App& app, SimulateOptions& options);
int run_simulate(const SimulateOptions& options);

// `hapticcal force`: the force-control study (virtual wall, paper Figs 11-12).
struct ForceOptions {
  std::string actual, nominal, calibrated, out = "hapticcal-out/force", posture;
  int lock = -1;  // 1-based; 0: none; -1: the default (ForceScenario::kLockRedundant)
  ChainOptions chain;
  hapticcal::ForceScenario scenario;
};
CLI::App* add_force_command(CLI::App& app, ForceOptions& options);
int run_force(ForceOptions options);

// `hapticcal convert`: a device file to URDF or a URDF to a device file.
struct ConvertOptions {
  std::string in, out;
  ChainOptions chain;
};
CLI::App* add_convert_command(CLI::App& app, ConvertOptions& options);
// kExitBadInput, with a line on stderr, when the files are not a pair to convert.
int run_convert(const ConvertOptions& options);

// `hapticcal compensate`: a program's targets for a controller running the nominal model.
struct CompensateOptions {
  std::string model, nominal, targets, columns, out = "hapticcal-out/compensate";
  double load = 0;  // kg at the tool point
  ChainOptions chain;
};
CLI::App* add_compensate_command(CLI::App& app, CompensateOptions& options);
int run_compensate(const CompensateOptions& options);

// `hapticcal import`: a recording or a tracker's export in, hapticcal's streams out.
struct ImportOptions {
  std::string recording, joints, tracker_topic, frames, time = "header", model, convention;
  std::vector<std::string> fields;
  std::string tracker_export, body, markers, column_map, length_unit, time_unit;
  std::string out;  // empty: recording::kDefaultImportOut
  bool list = false;
  double still_seconds = 0, clock_offset = 0;
  std::optional<double> still_tolerance, tracker_still;  // unset: the library's defaults
};
CLI::App* add_import_command(CLI::App& app, ImportOptions& options);
int run_import(const ImportOptions& options);

// `hapticcal devices`: the built-in devices, usable by name as a model.
CLI::App* add_devices_command(CLI::App& app);
int run_devices();

}  // namespace hapticcal::cli
