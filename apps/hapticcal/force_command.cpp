// `hapticcal force`: the force-control study (virtual wall, paper Figs 11-12)
// of a device rendered through its nominal and its calibrated model.
#include <fmt/format.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "commands.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/core/output_set.hpp"
#include "hapticcal/jobs/force_job.hpp"
#include "hapticcal/report/report.hpp"
#include "hapticcal/study/control.hpp"
#include "number_options.hpp"
#include "output_summary.hpp"

namespace hapticcal::cli {
namespace {

// force_nominal.csv or force_calibrated.csv: the time, the desired force and the
// measured force and moment, one row a control step.

}  // namespace

CLI::App* add_force_command(CLI::App& app, ForceOptions& o) {
  auto* force = app.add_subcommand("force", "Force-control study (virtual wall, paper Figs 11-12)");
  o.bound.bind(force, hapticcal::force_options());
  force->footer(
      "Examples:\n"
      "  hapticcal force --actual actual.yaml --nominal baser-7dof --calibrated calibrated.yaml\n"
      "  hapticcal force --actual actual.yaml --nominal baser-7dof --out force-study");
  return force;
}

int run_force(const ForceOptions& o) {
  hapticcal::ForceRequest request;
  o.bound.apply(request);
  const hapticcal::ForceJob job = hapticcal::run_force_job(request);
  const hapticcal::ForceScenario& sc = job.study.scenario;
  const hapticcal::ForceRun& before = job.study.nominal;
  const hapticcal::ForceRun& after = job.study.calibrated;
  std::string posture;
  for (int i = 0; i < sc.posture.size(); ++i)
    posture += fmt::format("{}{}", i ? "," : "", sc.posture[i]);
  fmt::print(
      "hapticcal force: virtual wall K = {} N/m moved {} mm along the handle's z in {} s, "
      "held {} s, at {} Hz; gain G = {} (stable for |G| < {:.4f}); {}; posture q = "
      "[{}] rad{}\n",
      sc.stiffness, sc.travel * 1e3, sc.move_seconds, sc.hold_seconds, sc.rate_hz, sc.gain,
      job.gain_limit,
      sc.locked_joint >= 0 ? fmt::format("joint {} locked", sc.locked_joint + 1)
                           : "no joint locked",
      posture,
      !request.posture && job.actual.dof() == 7
          ? " (home with j6 = 0.3 rad: home is a wrist singularity of this model)"
          : "");
  fmt::print(
      "  transverse force (|Fx, Fy|) RMS: nominal model {:.4f} N, calibrated model {:.4f} N, "
      "reduction {:.1f} %\n",
      before.transverse_rms, after.transverse_rms, job.study.reduction_pct);
  fmt::print("  at the end: Fz {:.4f} N desired, {:.4f} N nominal, {:.4f} N calibrated\n",
             before.desired.back()[2], before.measured.back()[2], after.measured.back()[2]);
  fmt::print("{}", report_said(job.figures, job.report_note, request.out));
  fmt::print("{}", hapticcal::cli::output_summary(*job.out, request.out));
  return 0;
}

}  // namespace hapticcal::cli
