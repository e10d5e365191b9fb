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
  force->add_option("--actual", o.actual, "Device file of the true device")->required();
  force->add_option("--nominal", o.nominal, "Controller model before calibration")->required();
  force
      ->add_option("--calibrated", o.calibrated,
                   "Controller model after calibration (the actual file: the truth as the model)")
      ->required();
  force->add_option("--out", o.out, "Output directory (default hapticcal-out/force)");
  force->add_option("--gain", o.scenario.gain, "Force-loop gain G (default 0.5)")
      ->check(within(option_range::kForceGain));
  force->add_option("--noise", o.scenario.sensor_noise, "Force sensor noise sd [N] (default 0)")
      ->check(within(option_range::kForceNoise));
  force->add_option("--stiffness", o.scenario.stiffness, "Wall stiffness [N/m] (default 100)")
      ->check(within(option_range::kWallStiffness));
  force
      ->add_option("--travel", o.scenario.travel,
                   "Wall travel along the handle's z [m] (default 0.02)")
      ->check(within(option_range::kWallTravel));
  force
      ->add_option("--seconds", o.scenario.move_seconds,
                   "Time the wall takes (default 2 s; at most 600 s at the 1 kHz loop rate)")
      ->check(within(option_range::kWallSeconds));
  force->add_option("--posture", o.posture,
                    "Readings q of the fixed handle, comma separated (default: home, j6 = 0.3 rad "
                    "on a 7-joint device)");
  force->add_option("--seed", o.scenario.seed, "Seed of the sensor noise")->check(whole_number(0));
  force
      ->add_option("--lock", o.lock,
                   "Joint to lock, 1-based; 0: none (default: joint 3 on a 7-joint device, none "
                   "on a 6-joint one; 6 joints must remain)")
      ->check(whole_number(option_range::kLockedJoint));
  add_chain_options(force, o.chain);
  force->footer(
      "Examples:\n"
      "  hapticcal force --actual actual.yaml --nominal baser-7dof --calibrated calibrated.yaml\n"
      "  hapticcal force --actual actual.yaml --nominal baser-7dof --out force-study");
  return force;
}

int run_force(ForceOptions o) {
  hapticcal::ForceRequest request;
  request.actual = o.actual;
  request.nominal = o.nominal;
  request.calibrated = o.calibrated;
  request.tip = o.chain.tip;
  request.root = o.chain.root;
  request.lock = o.lock;
  request.scenario = o.scenario;
  request.out = o.out;
  if (!o.posture.empty()) {
    std::vector<double> q;
    for (const std::string& v : names(o.posture)) {
      try {
        q.push_back(std::stod(v));
      } catch (const std::exception&) {
        throw hapticcal::InputError(fmt::format("--posture: '{}' is not a number", v));
      }
    }
    request.posture = q;
  }
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
      o.posture.empty() && job.actual.dof() == 7
          ? " (home with j6 = 0.3 rad: home is a wrist singularity of this model)"
          : "");
  fmt::print(
      "  transverse force (|Fx, Fy|) RMS: nominal model {:.4f} N, calibrated model {:.4f} N, "
      "reduction {:.1f} %\n",
      before.transverse_rms, after.transverse_rms, job.study.reduction_pct);
  fmt::print("  at the end: Fz {:.4f} N desired, {:.4f} N nominal, {:.4f} N calibrated\n",
             before.desired.back()[2], before.measured.back()[2], after.measured.back()[2]);
  fmt::print("{}", report_said(job.figures, job.report_note, o.out));
  fmt::print("{}", hapticcal::cli::output_summary(*job.out, o.out));
  return 0;
}

}  // namespace hapticcal::cli
