// Targets compensated for a controller that runs the nominal model
// (study/compensation.hpp).
#include "hapticcal/study/compensation.hpp"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <cmath>
#include <tuple>
#include <utility>

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/measurement.hpp"
#include "hapticcal/kinematics/kinematics.hpp"

namespace hapticcal {
namespace {

// The models' joints must be the same: a program's readings mean one thing.
void check_same_joints(const DeviceModel& calibrated, const DeviceModel& nominal) {
  if (calibrated.tree() || nominal.tree())
    throw InputError("compensate: a tree has several tips; give one chain (--tip)");
  if (calibrated.dof() != nominal.dof())
    throw InputError(fmt::format("compensate: the calibrated model has {} joints, the nominal {}",
                                 calibrated.dof(), nominal.dof()));
  for (int i = 0; i < nominal.dof(); ++i) {
    const Link& c = calibrated.links[static_cast<size_t>(i)];
    const Link& n = nominal.links[static_cast<size_t>(i)];
    if (c.name != n.name || c.type != n.type)
      throw InputError(fmt::format(
          "compensate: joint {} is '{}' in the calibrated model and '{}' in the nominal: the "
          "models are not of one device",
          i + 1, printable(c.name, 80), printable(n.name, 80)));
  }
}

// How far the tool at `at` is from `target`: distance [m] and turn [rad] (0
// without orientation).
std::pair<double, double> gap(const Frame<double>& target, const Frame<double>& at,
                              bool orientation) {
  return {(at.p - target.p).norm(),
          orientation ? Eigen::AngleAxisd(Mat3<double>(target.R * at.R.transpose())).angle() : 0};
}

// The calibrated model's tool must be the controller's: a tracker's target
// (device.yaml's default tool) is not the controller's TCP.
constexpr double kSameToolLength = 5e-3;  // m
constexpr double kSameToolAngle = 0.05;   // rad

void check_same_tool(const DeviceModel& calibrated, const DeviceModel& nominal) {
  const auto [length, angle] = gap(pose_frame(nominal.tool), pose_frame(calibrated.tool), true);
  if (length > kSameToolLength || angle > kSameToolAngle)
    throw InputError(fmt::format(
        "compensate: the calibrated model's tool is {:.1f} mm and {:.1f} mrad from the nominal "
        "model's: give the controller's tool (calibrate --tool-point nominal, or X,Y,Z)",
        length * 1e3, angle * 1e3));
}

}  // namespace

DeviceModel with_load(const DeviceModel& model, double kg) {
  if (!(kg >= 0 && kg <= 1000))
    throw InputError(fmt::format("--load: {} kg is not a payload in [0, 1000] kg", kg));
  DeviceModel out = model;
  if (kg == 0 || out.links.empty()) return out;
  Link& last = out.links.back();
  const Eigen::Vector3d tool(out.tool[0], out.tool[1], out.tool[2]);
  last.com = (last.mass * last.com + kg * tool) / (last.mass + kg);
  last.mass += kg;
  return out;
}

std::vector<CompensatedTarget> compensate_targets(const DeviceModel& calibrated_model,
                                                  const DeviceModel& nominal_model,
                                                  const Log& targets,
                                                  const CompensationOptions& options) {
  check_same_joints(calibrated_model, nominal_model);
  check_same_tool(calibrated_model, nominal_model);
  if (targets.dof() != nominal_model.dof())
    throw InputError(targets.origin, 0, "q1",
                     fmt::format("{} joint columns for a device of {} joints", targets.dof(),
                                 nominal_model.dof()));
  const PreparedModel calibrated(with_load(calibrated_model, options.load));
  const PreparedModel nominal(nominal_model);
  std::vector<double> lower(static_cast<size_t>(nominal_model.dof())), upper(lower);
  reading_limits(nominal_model, lower.data(), upper.data());
  // A joint program holds the tool's pose; a Cartesian one what it gives.
  const bool cartesian = holds(targets, MeasurementType::kPosition);
  const bool posed = holds(targets, MeasurementType::kPose);
  const bool orientation = !cartesian || posed;
  InverseOptions inverse = options.inverse;
  inverse.orientation = orientation;
  std::vector<CompensatedTarget> out;
  const int n = nominal_model.dof();
  for (int r = 0; r < targets.rows; ++r) {
    CompensatedTarget t;
    t.line = r < static_cast<int>(targets.line.size()) ? targets.line[static_cast<size_t>(r)] : 0;
    t.orientation = orientation;
    const Eigen::VectorXd q = targets.q.row(r).transpose();
    t.nominal_readings = q;
    if (cartesian) {
      t.target.p = targets.position.row(r).transpose();
      t.target.R = Mat3<double>::Identity();
      if (posed) {
        t.target.R = Eigen::Quaterniond(targets.orientation(r, 0), targets.orientation(r, 1),
                                        targets.orientation(r, 2), targets.orientation(r, 3))
                         .normalized()
                         .toRotationMatrix();
      }
      t.nominal = inverse_kinematics(nominal, t.target, q.data(), t.nominal_readings.data(),
                                     inverse, lower.data(), upper.data());
      check_ranges(nominal_model, t.nominal_readings.data(), t.nominal);
    } else {
      t.target = nominal.forward(q.data());
      t.nominal.status = InverseStatus::kConverged;
    }
    t.readings.resize(n);
    t.calibrated = inverse_kinematics(calibrated, t.target, t.nominal_readings.data(),
                                      t.readings.data(), inverse, lower.data(), upper.data());
    check_ranges(nominal_model, t.readings.data(), t.calibrated);
    t.command = nominal.forward(t.readings.data());
    Eigen::VectorXd solved(n);
    t.controller = inverse_kinematics(nominal, t.command, t.nominal_readings.data(), solved.data(),
                                      inverse, lower.data(), upper.data());
    t.controller_deviation = (solved - t.readings).cwiseAbs().maxCoeff();
    std::tie(t.controller_position, t.controller_rotation) =
        gap(t.target, calibrated.forward(solved.data()), orientation);
    std::tie(t.uncompensated_position, t.uncompensated_rotation) =
        gap(t.target, calibrated.forward(t.nominal_readings.data()), orientation);
    out.push_back(std::move(t));
  }
  return out;
}

}  // namespace hapticcal
