// `simulate` as one job (issue 24): the request the command line and the
// Python module fill in, and what they print or return.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "hapticcal/core/output_set.hpp"
#include "hapticcal/jobs/command_options.hpp"
#include "hapticcal/study/study.hpp"

namespace hapticcal {

struct SimulateRequest {
  std::string scenario;  // a scenario file ("": the paper's study on `device`)
  std::string device;    // the device file or URDF ("": the built-in device)
  std::string tip, root;
  std::optional<int> trials;          // none: the scenario's
  std::optional<std::uint64_t> seed;  // none: the scenario's
  int threads = 0;                    // 0: one per core
  std::string out = "hapticcal-out/simulate";
  // Called once the scenario is read, before the trials run (threads: used).
  std::function<void(const Scenario&, int threads)> started;
  std::function<void(int, int)> progress;  // trials done, of all (a session: percent done)
};

struct SimulateJob {
  Scenario scenario;
  StudyResult result;
  std::optional<SessionStudy> session;  // a hand-guided session's study instead
  std::string results_json;
  std::unique_ptr<OutputSet> out;  // committed
  int figures = 0;                 // drawn into its report
  std::string report_note;         // write_report's note, or empty
};

// Reads the scenario, runs the study into the output set (its CSV files,
// results.json, report.html) and commits it. --tip / --root without a URDF
// device (and no scenario) is bad input (InputError).
SimulateJob run_simulate_job(const SimulateRequest& request);

// simulate's options, bound by the command line and the Python module alike.
const CommandOptions<SimulateRequest>& simulate_options();

}  // namespace hapticcal
