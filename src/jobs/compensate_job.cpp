// `compensate` as one job (jobs/compensate_job.hpp).
#include "hapticcal/jobs/compensate_job.hpp"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/identification/measurement.hpp"
#include "hapticcal/model_io/model_source.hpp"

namespace hapticcal {
namespace {

DeviceModel load_compensated_model(const CompensateRequest& request, const std::string& path) {
  return is_urdf_path(path) ? load_model(path, request.tip, request.root) : load_model(path);
}

bool reached(InverseStatus s) {
  return s == InverseStatus::kConverged || s == InverseStatus::kNear;
}

// The outcome of a target: the first stage that failed (the nominal
// controller's inverse kinematics of a Cartesian target, the calibrated one,
// the controller's of the command), or near a singularity, or converged.
std::string outcome(const CompensatedTarget& t) {
  if (!reached(t.nominal.status)) return to_string(t.nominal.status);
  if (!reached(t.calibrated.status)) return to_string(t.calibrated.status);
  if (!t.usable()) return "controller leaves the configuration";
  return t.near_singularity() ? "near a singularity" : "converged";
}

// Why a target has no command, or is near a singularity.
std::string why_not(const CompensatedTarget& t) {
  if (t.usable())
    return fmt::format(
        "near a singularity (smallest singular value {:.3g} m/rad): the readings move far for a "
        "small change of the target",
        std::min(t.calibrated.smallest_singular_value, t.controller.smallest_singular_value));
  if (t.nominal.status != InverseStatus::kConverged && t.nominal.status != InverseStatus::kNear)
    return fmt::format("the nominal controller's inverse kinematics is {} (position {:.4f} mm)",
                       to_string(t.nominal.status), t.nominal.position_error * 1e3);
  if (t.calibrated.status == InverseStatus::kConverged ||
      t.calibrated.status == InverseStatus::kNear)
    return fmt::format(
        "the nominal controller, given the compensated pose, solves it ({}) at readings {:.3g} "
        "from the compensated ones, where the tool is {:.4f} mm from the target",
        to_string(t.controller.status), t.controller_deviation, t.controller_position * 1e3);
  if (t.calibrated.status == InverseStatus::kOutsideLimits)
    return fmt::format("the compensated reading q{} is outside its limits (or its joint's range)",
                       t.calibrated.outside_limit + 1);
  return fmt::format(
      "the calibrated model does not reach it from the program's configuration "
      "(position {:.4f} mm, rotation {:.4f} mrad after {} iterations)",
      t.calibrated.position_error * 1e3, t.calibrated.rotation_error * 1e3,
      t.calibrated.iterations);
}

std::string compensated_csv(const std::vector<CompensatedTarget>& targets, int n) {
  std::string out = "line";
  for (int i = 1; i <= n; ++i) out += fmt::format(",q{}", i);
  out +=
      ",x,y,z,qw,qx,qy,qz,status,position_error,rotation_error,controller_position,"
      "uncompensated_position,uncompensated_rotation\n";
  for (const CompensatedTarget& t : targets) {
    out += std::to_string(t.line);
    const bool usable = t.usable();
    for (int i = 0; i < n; ++i) out += usable ? fmt::format(",{}", t.readings[i]) : ",";
    const Eigen::Quaterniond turn(t.command.R);
    if (usable) {
      out += fmt::format(",{},{},{},{},{},{},{}", t.command.p.x(), t.command.p.y(), t.command.p.z(),
                         turn.w(), turn.x(), turn.y(), turn.z());
    } else {
      out += ",,,,,,,";
    }
    out += fmt::format(",{},{},{},{},{},{}\n", outcome(t), t.calibrated.position_error,
                       t.calibrated.rotation_error, t.controller_position, t.uncompensated_position,
                       t.uncompensated_rotation);
  }
  return out;
}

double rms(const std::vector<CompensatedTarget>& targets, bool uncompensated) {
  double sum = 0;
  int count = 0;
  for (const CompensatedTarget& t : targets) {
    if (!t.usable()) continue;
    // The compensated program's: where the calibrated model puts the tool at
    // the readings the controller will solve the command to.
    const double e = uncompensated ? t.uncompensated_position : t.controller_position;
    sum += e * e;
    ++count;
  }
  return count ? std::sqrt(sum / count) : std::nan("");
}

}  // namespace

CompensateJob run_compensate_job(const CompensateRequest& request) {
  if ((!request.tip.empty() || !request.root.empty()) && !is_urdf_path(request.model) &&
      !is_urdf_path(request.nominal))
    throw InputError(fmt::format("{}: applies to URDF models (.urdf); none is given",
                                 request.tip.empty() ? "--root" : "--tip"));
  const DeviceModel calibrated = load_compensated_model(request, request.model);
  const DeviceModel nominal = load_compensated_model(request, request.nominal);
  const Log targets =
      read_log(request.targets, request.columns.empty() ? std::vector<std::string>()
                                                        : split_columns(request.columns));
  // Readings, with the tool's positions (and orientations: poses) for Cartesian targets.
  const bool cartesian = holds(targets, MeasurementType::kPosition);
  const size_t tool_kinds = cartesian ? (holds(targets, MeasurementType::kPose) ? 2 : 1) : 0;
  if (targets.marker_count > 0 || kinds_in(targets).size() != tool_kinds)
    throw InputError(targets.origin, 0, "",
                     "a program's targets are readings q1..qn, with x, y, z (and an orientation) "
                     "for Cartesian targets: no distance, markers, points or planes");
  CompensateJob job;
  job.out = std::make_unique<OutputSet>(request.out, "compensate");
  job.targets = compensate_targets(calibrated, nominal, targets, request.options);
  for (const CompensatedTarget& t : job.targets) job.usable += t.usable() ? 1 : 0;
  const int total = static_cast<int>(job.targets.size());
  const double before = rms(job.targets, true), after = rms(job.targets, false);
  job.lines.push_back(fmt::format(
      "{} of {} targets compensated ({}, {}): the calibrated model's tool at the program's "
      "readings is {:.4f} mm RMS from its targets, at the readings the controller solves the "
      "compensated poses to {:.2g} mm",
      job.usable, total, cartesian ? "Cartesian targets" : "joint targets",
      job.targets.empty() || job.targets.front().orientation ? "position and orientation"
                                                             : "position",
      before * 1e3, after * 1e3));
  for (const CompensatedTarget& t : job.targets) {
    if (!t.usable() || t.near_singularity())
      job.lines.push_back(fmt::format("warning: {}:{}: {}{}", targets.origin, t.line,
                                      t.usable() ? "" : "no command: ", why_not(t)));
  }
  if (request.options.load > 0 && !calibrated.compliant())
    job.lines.push_back(
        "note: --load changes nothing: the calibrated model has no joint compliance");
  const std::string& dir = job.out->dir();
  write_file_atomically(dir + "/compensated.csv", compensated_csv(job.targets, nominal.dof()));
  nlohmann::ordered_json j;
  j["format"] = "hapticcal-compensate/1";
  j["model"] = request.model;
  j["nominal"] = request.nominal;
  j["targets"] = request.targets;
  j["load"] = request.options.load;
  j["count"] = total;
  j["usable"] = job.usable;
  j["uncompensated_rms"] = std::isfinite(before) ? nlohmann::ordered_json(before) : nullptr;
  j["compensated_rms"] = std::isfinite(after) ? nlohmann::ordered_json(after) : nullptr;
  nlohmann::ordered_json refused = nlohmann::ordered_json::array();
  nlohmann::ordered_json near = nlohmann::ordered_json::array();
  for (const CompensatedTarget& t : job.targets) {
    if (!t.usable()) refused.push_back({{"line", t.line}, {"why", why_not(t)}});
    if (t.usable() && t.near_singularity()) near.push_back(t.line);
  }
  j["not_usable"] = refused;
  j["near_singularity"] = near;
  job.results_json = j.dump(2);
  write_file_atomically(dir + "/results.json", job.results_json + "\n");
  job.out->commit();
  return job;
}

}  // namespace hapticcal
