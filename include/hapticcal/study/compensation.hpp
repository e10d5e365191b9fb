// Targets compensated for a controller that runs the nominal model (docs/compensate.md):
// an industrial controller cannot load a calibrated model, so each target of its
// program is moved so that the controller, running its maker's nominal
// kinematics, commands the readings at which the calibrated model (every
// effect it holds, compliance under the stated load) reaches the true target.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "hapticcal/core/log.hpp"
#include "hapticcal/kinematics/inverse.hpp"
#include "hapticcal/model/model.hpp"

namespace hapticcal {

struct CompensationOptions {
  // A payload at the tool point [kg]: added to the last link's weight for the
  // compliance (a model without compliance is unchanged by it).
  double load = 0;
  InverseOptions inverse;  // tolerances and iterations (orientation: from the targets)
};

// One target of a program.
struct CompensatedTarget {
  int line = 0;  // the targets file's line
  // The pose to reach: the row's x, y, z (and orientation) or, for a joint
  // target, the nominal model's pose at its readings.
  Frame<double> target;
  bool orientation = false;  // the target holds the tool's orientation
  // What the nominal controller commands for the target: the row's readings,
  // or (a Cartesian target) its nominal inverse kinematics from them.
  Eigen::VectorXd nominal_readings;
  InverseResult nominal;
  // The readings at which the calibrated model reaches the target (from the
  // nominal readings), and the pose to give the nominal controller for them.
  Eigen::VectorXd readings;
  InverseResult calibrated;
  Frame<double> command;
  // The controller's own inverse kinematics of `command` from the nominal
  // readings, as it will solve it; how far its readings are from `readings`
  // (the largest difference [rad or m]: a redundant arm's controller may
  // settle elsewhere on the self-motion); and how far the calibrated model's
  // tool is from the target at them [m, rad]. A command the controller would
  // not bring to the target (beyond kControllerPosition, kControllerRotation)
  // is not given.
  InverseResult controller;
  double controller_deviation = 0;
  double controller_position = 0, controller_rotation = 0;
  // Where the calibrated model puts the tool at the nominal readings: the
  // uncompensated program's error [m, rad].
  double uncompensated_position = 0, uncompensated_rotation = 0;
  // Whether the command may be sent: both inverse kinematics reached the
  // target within the limits (near a singularity too: then said, since the
  // readings there move far for a small change of the target).
  bool usable() const {
    const auto ok = [](InverseStatus s) {
      return s == InverseStatus::kConverged || s == InverseStatus::kNear;
    };
    return ok(nominal.status) && ok(calibrated.status) && ok(controller.status) &&
           controller_position <= kControllerPosition && controller_rotation <= kControllerRotation;
  }
  bool near_singularity() const {
    return nominal.status == InverseStatus::kNear || calibrated.status == InverseStatus::kNear ||
           controller.status == InverseStatus::kNear;
  }
  // Below a robot's repeatability: a redundant arm's controller, settling a
  // little further along the self-motion (1e-4 rad), moves the tool by microns.
  static constexpr double kControllerPosition = 1e-5;  // m
  static constexpr double kControllerRotation = 1e-4;  // rad
};

// The calibrated model with `kg` at its tool point, lumped into its last
// link's mass (its centre of mass moved accordingly).
DeviceModel with_load(const DeviceModel& model, double kg);

// Each row of `targets` (read_log: q1..qn, the program's readings; x, y, z
// and an orientation, if given, the Cartesian target, the readings then its
// configuration) compensated. `calibrated` and `nominal` are chains with the
// same joints in the same frame (the robot's base): InputError otherwise.
std::vector<CompensatedTarget> compensate_targets(const DeviceModel& calibrated,
                                                  const DeviceModel& nominal, const Log& targets,
                                                  const CompensationOptions& options = {});

}  // namespace hapticcal
