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

#include "bound_options.hpp"
#include "command_support.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/identification/stream.hpp"
#include "hapticcal/jobs/calibrate_job.hpp"
#include "hapticcal/jobs/compensate_job.hpp"
#include "hapticcal/jobs/evaluate_job.hpp"
#include "hapticcal/jobs/force_job.hpp"
#include "hapticcal/jobs/import_job.hpp"
#include "hapticcal/jobs/simulate_job.hpp"
#include "hapticcal/study/control.hpp"

namespace hapticcal::cli {

// `hapticcal calibrate`: two-step identification from a log; its options are
// the library's table (calibrate_options), as Python's keywords are.
struct CalibrateOptions {
  BoundOptions<hapticcal::CalibrateRequest> bound;
};
CLI::App* add_calibrate_command(CLI::App& app, CalibrateOptions& options);
// 0, or kExitUnusable when the calibration is not usable (no calibrated model replaced).
int run_calibrate(const CalibrateOptions& options);

// `hapticcal evaluate`: RMS and max error of a model on a log; its options are
// the library's table (evaluate_options) and --json, the command line's own.
struct EvaluateOptions {
  BoundOptions<hapticcal::EvaluateRequest> bound;
  bool json = false;
};
CLI::App* add_evaluate_command(CLI::App& app, EvaluateOptions& options);
int run_evaluate(const EvaluateOptions& options);

// `hapticcal simulate`: the paper's simulation study, or one on any device; its
// options are the library's table (simulate_options).
struct SimulateOptions {
  BoundOptions<hapticcal::SimulateRequest> bound;
};
CLI::App* add_simulate_command(CLI::App& app, SimulateOptions& options);
int run_simulate(const SimulateOptions& options);

// `hapticcal force`: the force-control study (virtual wall, paper Figs 11-12);
// its options are the library's table (force_options).
struct ForceOptions {
  BoundOptions<hapticcal::ForceRequest> bound;
};
CLI::App* add_force_command(CLI::App& app, ForceOptions& options);
int run_force(const ForceOptions& options);

// `hapticcal convert`: a device file to URDF or a URDF to a device file; its
// options are the library's table (convert_options).
struct ConvertOptions {
  BoundOptions<hapticcal::ConvertRequest> bound;
};
CLI::App* add_convert_command(CLI::App& app, ConvertOptions& options);
// kExitBadInput, with a line on stderr, when the files are not a pair to convert.
int run_convert(const ConvertOptions& options);

// `hapticcal compensate`: a program's targets for a controller running the
// nominal model; its options are the library's table (compensate_options).
struct CompensateOptions {
  BoundOptions<hapticcal::CompensateRequest> bound;
};
CLI::App* add_compensate_command(CLI::App& app, CompensateOptions& options);
int run_compensate(const CompensateOptions& options);

// `hapticcal import`: a recording or a tracker's export in, hapticcal's streams
// out; its options are the library's table (import_options).
struct ImportOptions {
  BoundOptions<hapticcal::recording::ImportRequest> bound;
};
CLI::App* add_import_command(CLI::App& app, ImportOptions& options);
int run_import(const ImportOptions& options);

// `hapticcal devices`: the built-in devices, usable by name as a model.
CLI::App* add_devices_command(CLI::App& app);
int run_devices();

}  // namespace hapticcal::cli
