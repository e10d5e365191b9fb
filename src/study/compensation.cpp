// Targets compensated for a controller that runs the nominal model
// (study/compensation.hpp).
#include "hapticcal/study/compensation.hpp"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <cmath>

#include "hapticcal/core/error.hpp"
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

// The calibrated model's tool must be the controller's: a tracker's target
// (device.yaml's default tool) is not the controller's TCP.
constexpr double kSameToolLength = 5e-3;  // m
constexpr double kSameToolAngle = 0.05;   // rad

void check_same_tool(const DeviceModel& calibrated, const DeviceModel& nominal) {
  const Frame<double> a = pose_frame(calibrated.tool[0], calibrated.tool[1], calibrated.tool[2],
                                     calibrated.tool[3], calibrated.tool[4], calibrated.tool[5]);
  const Frame<double> b = pose_frame(nominal.tool[0], nominal.tool[1], nominal.tool[2],
                                     nominal.tool[3], nominal.tool[4], nominal.tool[5]);
  const double length = (a.p - b.p).norm();
  const double angle = Eigen::AngleAxisd(Mat3<double>(a.R * b.R.transpose())).angle();
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
  const bool orientation = !targets.has_position || targets.has_orientation;
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
    if (targets.has_position) {
      t.target.p = targets.position.row(r).transpose();
      t.target.R = Mat3<double>::Identity();
      if (targets.has_orientation) {
        t.target.R = Eigen::Quaterniond(targets.orientation(r, 0), targets.orientation(r, 1),
                                        targets.orientation(r, 2), targets.orientation(r, 3))
                         .normalized()
                         .toRotationMatrix();
      }
      t.nominal = inverse_kinematics(nominal, t.target, q.data(), t.nominal_readings.data(),
                                     inverse, lower.data(), upper.data());
    } else {
      t.target = nominal.forward(q.data());
      t.nominal.status = InverseStatus::kConverged;
    }
    t.readings.resize(n);
    t.calibrated = inverse_kinematics(calibrated, t.target, t.nominal_readings.data(),
                                      t.readings.data(), inverse, lower.data(), upper.data());
    t.command = nominal.forward(t.readings.data());
    Eigen::VectorXd solved(n);
    t.controller = inverse_kinematics(nominal, t.command, t.nominal_readings.data(), solved.data(),
                                      inverse, lower.data(), upper.data());
    t.controller_deviation = (solved - t.readings).cwiseAbs().maxCoeff();
    const Frame<double> reached = calibrated.forward(solved.data());
    t.controller_position = (reached.p - t.target.p).norm();
    t.controller_rotation =
        orientation ? Eigen::AngleAxisd(Mat3<double>(t.target.R * reached.R.transpose())).angle()
                    : 0;
    const Frame<double> uncompensated = calibrated.forward(t.nominal_readings.data());
    t.uncompensated_position = (uncompensated.p - t.target.p).norm();
    t.uncompensated_rotation =
        orientation
            ? Eigen::AngleAxisd(Mat3<double>(t.target.R * uncompensated.R.transpose())).angle()
            : 0;
    out.push_back(std::move(t));
  }
  return out;
}

}  // namespace hapticcal
