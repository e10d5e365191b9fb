#include "hapticcal/report/calibration_outputs.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/identification/tree.hpp"
#include "hapticcal/kinematics/device_frame.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/model_io/driver_files.hpp"
#include "hapticcal/model_io/urdf.hpp"
#include "hapticcal/report/report.hpp"
#include "hapticcal/report/results_json.hpp"

namespace hapticcal {
namespace {

// The previous run's calibrated.yaml (and calibrated.urdf of a URDF model, a
// chain's device.yaml and setup.yaml), carried into a failed run's set only if
// that run calibrated the same device.
bool keep_previous_model(const OutputSet& out, const DeviceModel& nominal, bool urdf) {
  if (out.previous_command() != "calibrate") return false;
  try {
    if (load_device(out.target() + "/calibrated.yaml").name != nominal.name) return false;
  } catch (const InputError&) {
    return false;
  }
  if (urdf) out.keep_previous("calibrated.urdf");
  if (!nominal.tree()) {
    out.keep_previous("device.yaml");
    out.keep_previous("setup.yaml");
    for (const char* driver : {"sawSensablePhantom.json", "dvrk-mtm.json"})
      out.keep_previous(driver);  // a built-in device's driver file, if it had one
  }
  return out.keep_previous("calibrated.yaml");
}

std::string pose_yaml(const std::array<double, 6>& v) {
  return fmt::format("{{xyz: [{:.9g}, {:.9g}, {:.9g}], rpy: [{:.9g}, {:.9g}, {:.9g}]}}", v[0], v[1],
                     v[2], v[3], v[4], v[5]);
}

std::array<double, 6> pose_of(const Frame<double>& f) {
  const Eigen::Vector3d rpy = matrix_rpy(f.R);
  return {f.p.x(), f.p.y(), f.p.z(), rpy[0], rpy[1], rpy[2]};
}

// x, y, z in mm and roll, pitch, yaw in degrees, for a sentence.
std::string pose_words(const std::array<double, 6>& v) {
  constexpr double deg = 180 / std::numbers::pi;
  return fmt::format("({:.2f}, {:.2f}, {:.2f}) mm, roll/pitch/yaw ({:.2f}, {:.2f}, {:.2f}) deg",
                     v[0] * 1e3, v[1] * 1e3, v[2] * 1e3, v[3] * deg, v[4] * deg, v[5] * deg);
}

// Whether the measurements saw the tool's orientation (a tool angle identified).
bool tool_orientation_seen(const CalibrationResult& result) {
  for (const ParameterEstimate& e : result.kinematics.parameters) {
    if (e.identifiable && (e.name == "tool.roll" || e.name == "tool.pitch" || e.name == "tool.yaw"))
      return true;
  }
  return false;
}

std::string setup_yaml(const DeviceFrameOutputs& d) {
  return fmt::format(
      "# What this calibration found of the set-up, not of the device.\n"
      "# device.yaml is the device's model in its own frame (its base and joint 1's\n"
      "# placement as the nominal model gives them); calibrated.yaml is the same\n"
      "# model in the measurement frame, the frame of the log's measurements.\n"
      "format: hapticcal-setup/1\n"
      "device: {}\n"
      "# The device's frame in the measurement frame [m, rad]: a point p of the\n"
      "# device's frame is R(rpy) p + xyz in the measurement frame.\n"
      "device_frame: {}\n"
      "# The point (and frame) the instrument measured, in the last link's frame.\n"
      "measured_tool: {}\n"
      "# device.yaml's tool, in the last link's frame: {}.\n"
      "tool: {}\n",
      d.split.device.name.empty() ? "unnamed" : d.split.device.name,
      pose_yaml(pose_of(d.split.device_in_measurement)), pose_yaml(d.split.measured_tool),
      d.ends_at, pose_yaml(d.split.device.tool));
}

// calibrated.urdf: the geometry-only model (geometry_model), unless it
// predicts held-out poses no better than the nominal with its set-up fitted; a
// chain's as `frame` (that model in the device's frame) writes it, a tree's as
// fitted. Its notes into result, once each.
void write_urdf(const std::string& dir, CalibrationResult& result, const CalibrationSource& source,
                const DeviceFrameOutputs* frame, CalibrationOutputs& written) {
  const CalibrationResult& urdf = geometry_model(result);
  if (urdf.status != CalibrationStatus::kConverged) {
    result.notes.push_back("no calibrated.urdf written: " + urdf.status_reason);
    return;
  }
  std::vector<std::string> said;
  write_file_atomically(
      dir + "/calibrated.urdf",
      frame ? calibrated_urdf(source.urdf_text, source.model_path, source.tip, source.root,
                              frame->written, &said)
            : tree_urdf(source.urdf_text, source.model_path, source.root, urdf.calibrated, said));
  for (std::string& note : said) {
    if (std::find(result.notes.begin(), result.notes.end(), note) == result.notes.end())
      result.notes.push_back(std::move(note));
  }
  written.urdf_written = true;
}

// A built-in device's driver file (driver_file), from the geometry-only model
// in the device's frame (`frame`): a driver holds no joint-error family.
void write_driver_file(const std::string& dir, CalibrationResult& result,
                       const DeviceModel& nominal, const DeviceFrameOutputs& frame) {
  const CalibrationResult& g = geometry_model(result);
  const std::optional<DriverFile> f = driver_file(frame.split.device, nominal);
  if (!f) return;
  if (g.status != CalibrationStatus::kConverged) {
    result.notes.push_back(fmt::format("no {} written: {}", f->name, g.status_reason));
    return;
  }
  write_file_atomically(dir + "/" + f->name, f->text);
  result.notes.push_back(f->note);
}

// calibrated.yaml; a chain's device.yaml and setup.yaml; calibrated.urdf of a
// URDF model and a built-in device's driver file, from the geometry-only model.
void write_models(const std::string& dir, CalibrationResult& result, const DeviceModel& nominal,
                  const CalibrationSource& source, CalibrationOutputs& written) {
  save_device(result.calibrated, dir + "/calibrated.yaml");
  if (result.calibrated.tree()) {  // a tree's tips keep their tools: no device.yaml
    if (!source.urdf_text.empty()) write_urdf(dir, result, source, nullptr, written);
    return;
  }
  written.device_frame = device_frame_outputs(result, nominal, source);
  const DeviceFrameOutputs& d = *written.device_frame;
  add_device_frame_notes(result, d, !source.urdf_text.empty());
  save_device(d.split.device, dir + "/device.yaml");
  write_file_atomically(dir + "/setup.yaml", setup_yaml(d));
  // The geometry-only model in the device's frame: device.yaml's own where
  // the whole model is the geometry alone.
  const std::optional<DeviceFrameOutputs> geometry =
      result.geometry ? std::optional(device_frame_outputs(*result.geometry, nominal, source))
                      : std::nullopt;
  const DeviceFrameOutputs& g = geometry ? *geometry : d;
  if (!source.urdf_text.empty()) write_urdf(dir, result, source, &g, written);
  write_driver_file(dir, result, nominal, g);
}

}  // namespace

DeviceFrameOutputs device_frame_outputs(const CalibrationResult& result, const DeviceModel& nominal,
                                        const CalibrationSource& source) {
  DeviceFrameOutputs d;
  d.written = result.calibrated;
  if (!tool_orientation_seen(result)) d.turn = move_last_turn_into_tool(d.written, nominal);
  std::optional<std::array<double, 6>> tool;
  d.ends_at = "the point the instrument measured (the calibrated tool)";
  if (source.nominal_tool) {
    tool = nominal.tool;
    d.ends_at = "the device file's tool";
  } else if (source.tool_point) {
    tool = d.written.tool;
    for (int k = 0; k < 3; ++k) (*tool)[k] = (*source.tool_point)[k];
    d.ends_at = "the tool point given";
  }
  d.split = split_device_frame(d.written, nominal, tool);
  return d;
}

void add_device_frame_notes(CalibrationResult& result, const DeviceFrameOutputs& d, bool urdf) {
  if (std::abs(d.turn) > 1e-6) {
    result.notes.push_back(fmt::format(
        "{} joint {}'s zero at nominal: the measurements do not see the tool's orientation, so "
        "the calibrated turn of its zero about its axis ({:.2f} deg) and the tool point's "
        "direction about that axis are one unknown, written as the tool's",
        urdf ? "calibrated.urdf and device.yaml keep" : "device.yaml keeps",
        d.written.links.back().name, d.turn * 180 / std::numbers::pi));
  }
  result.notes.push_back(fmt::format(
      "device.yaml is the model in the device's own frame, ending at {}; setup.yaml holds the "
      "set-up: the device's frame at {} in the measurement frame, the measured point at ({:.2f}, "
      "{:.2f}, {:.2f}) mm in the last link's frame",
      d.ends_at, pose_words(pose_of(d.split.device_in_measurement)), d.split.measured_tool[0] * 1e3,
      d.split.measured_tool[1] * 1e3, d.split.measured_tool[2] * 1e3));
}

CalibrationOutputs write_calibration_outputs(OutputSet& out, CalibrationResult& result,
                                             const DeviceModel& nominal, const Log& log,
                                             const CalibrationOptions& options,
                                             const CalibrationSource& source) {
  CalibrationOutputs written;
  if (result.status == CalibrationStatus::kConverged) {
    write_models(out.dir(), result, nominal, source, written);
    written.model_written = true;
  } else {
    written.previous_kept = keep_previous_model(out, nominal, !source.urdf_text.empty());
    result.notes.push_back(written.previous_kept
                               ? "calibrated.yaml is the previous run's model: not replaced"
                               : "no calibrated.yaml written: the calibration is not usable");
  }
  written.results_json =
      calibration_json(result, nominal, source.model_path, source.log_path, options);
  write_file_atomically(out.dir() + "/results.json", written.results_json);
  written.figures = write_report(
      calibration_report(result, nominal, log, options.point_distances, options.known_points),
      out.dir(), written.report_note);
  out.commit();
  return written;
}

}  // namespace hapticcal
