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
#include "hapticcal/report/report.hpp"
#include "hapticcal/study/control.hpp"
#include "number_options.hpp"
#include "output_summary.hpp"

namespace hapticcal::cli {
namespace {

// force_nominal.csv or force_calibrated.csv: the time, the desired force and the
// measured force and moment, one row a control step.
std::string force_csv(const hapticcal::ForceRun& run) {
  std::string out = "t,Fd_x,Fd_y,Fd_z,F_x,F_y,F_z,M_x,M_y,M_z\n";
  for (size_t k = 0; k < run.t.size(); ++k) {
    const auto& d = run.desired[k];
    const auto& m = run.measured[k];
    out += fmt::format("{},{},{},{},{},{},{},{},{},{}\n", run.t[k], d[0], d[1], d[2], m[0], m[1],
                       m[2], m[3], m[4], m[5]);
  }
  return out;
}

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
      ->check(within(-100, 100));
  force->add_option("--noise", o.scenario.sensor_noise, "Force sensor noise sd [N] (default 0)")
      ->check(within(0, 1000, "N"));
  force->add_option("--stiffness", o.scenario.stiffness, "Wall stiffness [N/m] (default 100)")
      ->check(within(1e-3, 1e6, "N/m"));
  force
      ->add_option("--travel", o.scenario.travel,
                   "Wall travel along the handle's z [m] (default 0.02)")
      ->check(within(-1, 1, "m"));
  force
      ->add_option("--seconds", o.scenario.move_seconds,
                   "Time the wall takes (default 2 s; at most 600 s at the 1 kHz loop rate)")
      ->check(within(0, 600, "s"));
  force->add_option("--posture", o.posture,
                    "Readings q of the fixed handle, comma separated (default: home, j6 = 0.3 rad "
                    "on a 7-joint device)");
  force->add_option("--seed", o.scenario.seed, "Seed of the sensor noise")->check(whole_number(0));
  force
      ->add_option("--lock", o.lock,
                   "Joint to lock, 1-based; 0: none (default: joint 3 on a 7-joint device, none "
                   "on a 6-joint one; 6 joints must remain)")
      ->check(whole_number(0, 1000));
  add_chain_options(force, o.chain);
  return force;
}

int run_force(ForceOptions o) {
  o.chain.check_used({o.actual, o.nominal, o.calibrated});
  const hapticcal::DeviceModel actual = o.chain.load(o.actual);
  const hapticcal::DeviceModel nominal = o.chain.load(o.nominal);
  const hapticcal::DeviceModel calibrated = o.chain.load(o.calibrated);
  hapticcal::ForceScenario& sc = o.scenario;
  if (o.lock >= 0) sc.locked_joint = o.lock - 1;  // 0 -> kNoLock
  sc.locked_joint = hapticcal::resolved_locked_joint(sc, actual.dof());
  hapticcal::OutputSet out(o.out, "force");
  if (!o.posture.empty()) {
    const std::vector<std::string> v = names(o.posture);
    sc.posture.resize(v.size());
    for (size_t i = 0; i < v.size(); ++i) {
      try {
        sc.posture[i] = std::stod(v[i]);
      } catch (const std::exception&) {
        throw hapticcal::InputError(fmt::format("--posture: '{}' is not a number", v[i]));
      }
    }
  }
  const double limit = hapticcal::force_study_gain_limit(actual, nominal, calibrated, sc);
  if (!(std::abs(sc.gain) < limit)) {
    throw hapticcal::InputError(fmt::format(
        "--gain {} is outside the stable range: |G| < {:.4f} for these models (1 / spectral radius "
        "of the rendering map)",
        sc.gain, limit));
  }
  const hapticcal::ForceStudy study = hapticcal::run_force_study(actual, nominal, calibrated, sc);
  sc = study.scenario;
  const hapticcal::ForceRun& before = study.nominal;
  const hapticcal::ForceRun& after = study.calibrated;
  const double reduction = study.reduction_pct;
  std::string posture;
  for (int i = 0; i < sc.posture.size(); ++i)
    posture += fmt::format("{}{}", i ? "," : "", sc.posture[i]);
  fmt::print(
      "hapticcal force: virtual wall K = {} N/m moved {} mm along the handle's z in {} s, "
      "held {} s, at {} Hz; gain G = {} (stable for |G| < {:.4f}); {}; posture q = "
      "[{}] rad{}\n",
      sc.stiffness, sc.travel * 1e3, sc.move_seconds, sc.hold_seconds, sc.rate_hz, sc.gain, limit,
      sc.locked_joint >= 0 ? fmt::format("joint {} locked", sc.locked_joint + 1)
                           : "no joint locked",
      posture,
      o.posture.empty() && actual.dof() == 7
          ? " (home with j6 = 0.3 rad: home is a wrist singularity of this model)"
          : "");
  fmt::print(
      "  transverse force (|Fx, Fy|) RMS: nominal model {:.4f} N, calibrated model {:.4f} N, "
      "reduction {:.1f} %\n",
      before.transverse_rms, after.transverse_rms, reduction);
  fmt::print("  at the end: Fz {:.4f} N desired, {:.4f} N nominal, {:.4f} N calibrated\n",
             before.desired.back()[2], before.measured.back()[2], after.measured.back()[2]);
  hapticcal::write_file_atomically(out.dir() + "/force_nominal.csv", force_csv(before));
  hapticcal::write_file_atomically(out.dir() + "/force_calibrated.csv", force_csv(after));
  nlohmann::ordered_json j;
  j["format"] = "hapticcal-force/1";
  j["actual"] = o.actual;
  j["nominal"] = o.nominal;
  j["calibrated"] = o.calibrated;
  j["stiffness"] = sc.stiffness;
  j["travel"] = sc.travel;
  j["gain"] = sc.gain;
  j["stable_gain_limit"] = limit;
  j["sensor_noise"] = sc.sensor_noise;
  j["seed"] = sc.seed;
  j["posture"] = std::vector<double>(sc.posture.data(), sc.posture.data() + sc.posture.size());
  j["transverse_rms_nominal"] = before.transverse_rms;
  j["transverse_rms_calibrated"] = after.transverse_rms;
  j["reduction_pct"] = reduction;
  hapticcal::write_file_atomically(
      out.dir() + "/results.json",
      j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
  hapticcal::Report force_report = hapticcal::force_report(before, after);
  force_report.outcome = hapticcal::force_outcome(study);
  const std::string reported = report(force_report, out.dir(), o.out);
  out.commit();
  fmt::print("{}", reported);
  fmt::print("{}", hapticcal::cli::output_summary(out, o.out));
  return 0;
}

}  // namespace hapticcal::cli
