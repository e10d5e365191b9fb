// `simulate` as one job (jobs/simulate_job.hpp).
#include "hapticcal/jobs/simulate_job.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <thread>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/model_io/model_source.hpp"
#include "hapticcal/report/report.hpp"
#include "hapticcal/report/results_json.hpp"

namespace hapticcal {

SimulateJob run_simulate_job(const SimulateRequest& request) {
  const std::string device = request.device.empty() ? builtin_device_path() : request.device;
  if (request.scenario.empty() && (!request.tip.empty() || !request.root.empty()) &&
      !is_urdf_path(device)) {
    throw InputError(fmt::format("{}: applies to URDF models (.urdf); none is given",
                                 request.tip.empty() ? "--root" : "--tip"));
  }
  SimulateJob job;
  Scenario& sc = job.scenario;
  sc = request.scenario.empty()
           ? default_scenario(device, request.tip, request.root)
           : load_scenario(request.scenario, device, request.tip, request.root);
  if (request.trials) sc.trials = *request.trials;
  if (sc.session && sc.trials > 1) {
    const std::string why =
        "a hand-guided session study runs one session (give each session a seed of its own)";
    if (request.trials) throw InputError(fmt::format("--trials {}: {}", sc.trials, why));
    throw InputError(request.scenario, 0, "trials", fmt::format("{} trials: {}", sc.trials, why));
  }
  if (request.seed) sc.seed = *request.seed;
  const int threads = request.threads > 0
                          ? request.threads
                          : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  if (request.started) request.started(sc, std::min(threads, sc.trials));
  job.out = std::make_unique<OutputSet>(request.out, "simulate");
  if (sc.session) {
    job.session = run_session_study(sc, job.out->dir(), request.progress);
    job.results_json = job.session->json;
    // The offset-aware calibration's report (its clocks' figure among them),
    // opened by the session's own lines.
    Report report = calibration_report(job.session->aware, sc.nominal, job.session->aware_poses);
    report.title = fmt::format("hapticcal simulate: a hand-guided session on {}", sc.nominal.name);
    report.outcome.headline.insert(report.outcome.headline.begin(), job.session->lines.begin(),
                                   job.session->lines.end());
    // The session's calibration runs without step 1 (its device stream has no
    // external encoders): said so, not as an option the user never gave nor
    // as the paper's kinematic-only calibration.
    const std::string said =
        "--no-transmission: transmissions kept as in the device file (kinematic-only calibration)";
    const std::string meant =
        "the session's device stream has no external encoders: the transmissions are kept as "
        "in the device file";
    for (std::string& note : report.outcome.notes) note = replace_all(note, said, meant);
    for (std::string& section : report.sections) section = replace_all(section, said, meant);
    job.figures = write_report(report, job.out->dir(), job.report_note);
    job.out->commit();
    return job;
  }
  job.result = run_study(sc, job.out->dir(), threads, request.progress);
  job.results_json = study_json(sc, job.result);
  write_file_atomically(job.out->dir() + "/results.json", job.results_json);
  job.figures = write_report(study_report(sc, job.result), job.out->dir(), job.report_note);
  job.out->commit();
  return job;
}

}  // namespace hapticcal
