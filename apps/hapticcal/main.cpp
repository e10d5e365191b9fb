// hapticcal command-line tool: argument parsing and printing over the library.
// Exit codes: 0 success, 1 unexpected failure, 2 bad input (file, log or argument).
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>

#include "hapticcal/error.hpp"
#include "hapticcal/evaluate.hpp"
#include "hapticcal/io.hpp"

namespace {

constexpr int kExitBadInput = 2;
constexpr int kExitNotImplemented = 3;

struct EvaluateOptions {
  std::string model, log, columns;
  bool json = false;
};

int run_evaluate(const EvaluateOptions& o) {
  const hapticcal::DeviceModel model = hapticcal::load_device(o.model);
  const hapticcal::Log log = hapticcal::read_log(
      o.log, o.columns.empty() ? std::vector<std::string>{} : hapticcal::split_columns(o.columns));
  const hapticcal::Evaluation ev = hapticcal::evaluate(model, log);
  if (o.json) {
    nlohmann::ordered_json j;
    j["n"] = ev.n;
    if (ev.distance) {
      j["rms_distance"] = ev.distance->rms;
      j["max_distance"] = ev.distance->max;
    }
    if (ev.position) {
      j["rms_position"] = ev.position->rms;
      j["max_position"] = ev.position->max;
    }
    fmt::print("{}\n", j.dump());
    return 0;
  }
  fmt::print("model: {} ({}, {} joints)\n", o.model, model.name, model.dof());
  fmt::print("log:   {} ({} rows)\n", o.log, ev.n);
  if (ev.distance) {
    fmt::print("distance error: RMS {:.4f} mm, max {:.4f} mm\n", ev.distance->rms * 1e3,
               ev.distance->max * 1e3);
  }
  if (ev.position) {
    fmt::print("position error: RMS {:.4f} mm, max {:.4f} mm\n", ev.position->rms * 1e3,
               ev.position->max * 1e3);
  }
  return 0;
}

int not_implemented(const char* command, int issue) {
  fmt::print(stderr, "hapticcal {}: not implemented yet (tracked in issue {})\n", command, issue);
  return kExitNotImplemented;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"hapticcal: kinematic calibration of haptic devices and robots with transmissions"};
  app.set_version_flag("--version", "hapticcal 0.1.0");
  app.require_subcommand(1);

  std::string scenario, out;
  int trials = 1;
  unsigned long long seed = 1;
  auto* simulate = app.add_subcommand("simulate", "Run the paper's simulation study (main job)");
  simulate->add_option("--scenario", scenario, "Scenario file (YAML)")->check(CLI::ExistingFile);
  simulate->add_option("--trials", trials, "Monte Carlo trials")->check(CLI::PositiveNumber);
  simulate->add_option("--seed", seed, "Random seed");
  simulate->add_option("--out", out, "Output directory");

  std::string cal_model, cal_log;
  auto* calibrate = app.add_subcommand("calibrate", "Two-step identification from a log");
  calibrate->add_option("--model", cal_model, "Device file")->required();
  calibrate->add_option("--log", cal_log, "Measurement log")->required();

  EvaluateOptions eval;
  auto* evaluate = app.add_subcommand("evaluate", "RMS and max error of a model on a log");
  evaluate->add_option("--model", eval.model, "Device file (YAML)")->required();
  evaluate->add_option("--log", eval.log, "Measurement log (CSV)")->required();
  evaluate->add_flag("--json", eval.json, "Print one JSON object (metres)");
  evaluate->add_option("--columns", eval.columns,
                       "Column names of a log without header, comma separated, _ skips one "
                       "(e.g. q1[deg],q2[deg],x,y,z,_)");

  std::string actual, nominal, calibrated;
  auto* force = app.add_subcommand("force", "Force-control study (virtual wall)");
  force->add_option("--actual", actual, "Device file of the true device")->required();
  force->add_option("--nominal", nominal, "Nominal device file")->required();
  force->add_option("--calibrated", calibrated, "Calibrated device file")->required();
  force->add_option("--out", out, "Output directory");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    fmt::print(stderr, "hapticcal: {}\n", e.what());
    return kExitBadInput;
  }

  try {
    if (*evaluate) return run_evaluate(eval);
    if (*simulate) return not_implemented("simulate", 4);
    if (*calibrate) return not_implemented("calibrate", 3);
    if (*force) return not_implemented("force", 5);
  } catch (const hapticcal::InputError& e) {
    fmt::print(stderr, "hapticcal: {}\n", e.what());
    return kExitBadInput;
  } catch (const std::exception& e) {
    fmt::print(stderr, "hapticcal: internal error: {}\n", e.what());
    return 1;
  }
  return 1;
}
