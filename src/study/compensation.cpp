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

std::vector<double> limits(const DeviceModel& m, bool upper) {
  std::vector<double> out;
  for (const Link& l : m.links) out.push_back(upper ? l.upper : l.lower);
  return out;
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
  if (targets.dof() != nominal_model.dof())
    throw InputError(targets.origin, 0, "q1",
                     fmt::format("{} joint columns for a device of {} joints", targets.dof(),
                                 nominal_model.dof()));
  const PreparedModel calibrated(with_load(calibrated_model, options.load));
  const PreparedModel nominal(nominal_model);
  const std::vector<double> lower = limits(nominal_model, false),
                            upper = limits(nominal_model, true);
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
    if (!orientation) t.command.R = t.target.R;  // a point's target: its orientation as given
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
