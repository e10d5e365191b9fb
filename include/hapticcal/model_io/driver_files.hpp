// A calibrated built-in device's calibration in its driver's own file: what the
// driver can apply of it (docs/devices.md, "Driver files").
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "hapticcal/model/model.hpp"

namespace hapticcal {

// The calibrated model's change to each reading that a driver can apply,
// r' = scale r + offset, such that the nominal model at r' is the calibrated
// model at r as nearly as a map of the readings can make it: least squares
// over the tool's poses at readings drawn within the limits (seeded; a turn
// counts 0.1 m a radian), from each joint's zero (a DH theta, or a URDF
// joint's offset and its origin's turn about its axis) through the coupling
// and a transmission's best line. `left_out`: the RMS distance [m] between the
// two models' tool points over those draws: what the map cannot hold.
struct ReadingMap {
  std::vector<double> scale, offset;
  double left_out = 0;
};
// `calibrated` in the device's own frame (device.yaml's model) and `nominal`
// of the same joints.
ReadingMap reading_map(const DeviceModel& calibrated, const DeviceModel& nominal);

// A driver's calibration file: its file name and text, and one line saying
// what it cannot hold.
struct DriverFile {
  std::string name, text, note;
};
// The driver file of the built-in device `nominal` names, or none: the
// Geomagic Touch's sawSensablePhantom configuration (its joint-scales and
// joint-offsets, applied by the driver as q = scale raw + offset before it
// negates the waist and makes the elbow relative: relative to the driver's
// defaults, scales 1 and offsets 0); the dVRK MTM's kinematic file
// (base-offset, standard DH links, ActuatorToJointPosition).
std::optional<DriverFile> driver_file(const DeviceModel& calibrated, const DeviceModel& nominal);

}  // namespace hapticcal
