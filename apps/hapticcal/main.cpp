// hapticcal command-line tool: argument parsing and printing over the library.
// Exit codes: 0 success; 2 bad input (file, log or argument); 3 the calibration
// ran but did not converge or is unusable (no calibrated model replaced); 1
// anything else, I/O errors included, with the system's reason.
#include <CLI/CLI.hpp>
#include <stdexcept>

#include "commands.hpp"
#include "hapticcal/core/error.hpp"
#include "hapticcal/core/output_set.hpp"
#include "plan_command.hpp"
#include "terminal.hpp"

using hapticcal::cli::kExitBadInput;

int main(int argc, char** argv) {
  hapticcal::cli::guard_standard_streams();
  hapticcal::remove_staging_on_signals();
  CLI::App app{"hapticcal: kinematic calibration of haptic devices and robots with transmissions"};
  app.set_version_flag("--version", "hapticcal 0.1.0");
  app.require_subcommand(1);
  app.footer(
      "Exit codes: 0 success; 2 bad input; 3 calibration not usable (the previous "
      "calibrated.yaml is kept); 1 anything else (I/O errors with the system's reason).");

  hapticcal::cli::SimulateOptions sim;
  CLI::App* simulate = hapticcal::cli::add_simulate_command(app, sim);
  hapticcal::cli::CalibrateOptions cal;
  CLI::App* calibrate = hapticcal::cli::add_calibrate_command(app, cal);
  hapticcal::cli::EvaluateOptions eval;
  CLI::App* evaluate = hapticcal::cli::add_evaluate_command(app, eval);
  hapticcal::cli::ForceOptions fo;
  CLI::App* force = hapticcal::cli::add_force_command(app, fo);
  hapticcal::cli::ConvertOptions conv;
  CLI::App* convert = hapticcal::cli::add_convert_command(app, conv);
  hapticcal::cli::PlanCommandOptions plan_options;
  CLI::App* plan = hapticcal::cli::add_plan_command(app, plan_options);
  hapticcal::cli::ImportOptions import_options;
  CLI::App* import_command = hapticcal::cli::add_import_command(app, import_options);
  hapticcal::cli::CompensateOptions compensate_options;
  CLI::App* compensate = hapticcal::cli::add_compensate_command(app, compensate_options);
  CLI::App* devices = hapticcal::cli::add_devices_command(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) {  // --help, --version
      return hapticcal::cli::finish_streams(app.exit(e));
    }
    if (dynamic_cast<const CLI::RequiredError*>(&e) && app.get_subcommands().empty()) {
      hapticcal::cli::say(stderr,
                          "hapticcal: give a command (calibrate, evaluate, simulate, plan, force, "
                          "convert, import, compensate, devices); see hapticcal --help\n");
      return kExitBadInput;
    }
    // One line, whatever the argument held (a newline, a control byte).
    hapticcal::cli::say(stderr, "hapticcal: {}\n", hapticcal::printable(e.what(), 400));
    return hapticcal::cli::finish_streams(kExitBadInput);
  }

  int code = 1;
  try {
    if (*evaluate) code = hapticcal::cli::run_evaluate(eval);
    if (*simulate) code = hapticcal::cli::run_simulate(sim);
    if (*calibrate) code = hapticcal::cli::run_calibrate(cal);
    if (*force) code = hapticcal::cli::run_force(fo);
    if (*convert) code = hapticcal::cli::run_convert(conv);
    if (*plan) code = hapticcal::cli::run_plan(plan_options);
    if (*devices) code = hapticcal::cli::run_devices();
    if (*compensate) code = hapticcal::cli::run_compensate(compensate_options);
    if (*import_command) code = hapticcal::cli::run_import(import_options);
  } catch (const hapticcal::InputError& e) {
    hapticcal::finish_if_interrupted();
    hapticcal::cli::say(stderr, "hapticcal: {}\n", e.what());
    code = kExitBadInput;
  } catch (const hapticcal::IoError& e) {
    hapticcal::finish_if_interrupted();
    hapticcal::cli::say(stderr, "hapticcal: {}\n", e.what());
    code = 1;
  } catch (const std::runtime_error& e) {  // the system's: a write to stdout failed (a closed
                                           // pipe), a file system error
    hapticcal::finish_if_interrupted();
    hapticcal::cli::say(stderr, "hapticcal: {}\n", e.what());
    code = 1;
  } catch (const std::exception& e) {
    hapticcal::finish_if_interrupted();
    hapticcal::cli::say(stderr, "hapticcal: internal error: {}\n", e.what());
    code = 1;
  }
  hapticcal::finish_if_interrupted();
  return hapticcal::cli::finish_streams(code);
}
