// The device's own model out of a calibration in a measurement frame (a
// tracker's, a mocap system's): the set-up's unknowns apart.
//
// A tracker sees the tool, never the device's housing, so where the device
// stands in the tracker's frame and the part of joint 1's geometry before its
// motion are one unknown: the base transform B and, of joint 1, theta and d
// (DH), alpha, a, beta, theta and d (MDH), the origin and offset (URDF). The
// device's frame is therefore fixed to its first joint: joint 1's axis and
// zero lie where the nominal model puts them. The device's model keeps the
// nominal base and joint-1 placement and every other calibrated parameter; its
// forward kinematics are the calibrated model's expressed in that frame,
//   FK_device(q) = D^-1 FK_calibrated(q),  D = A_cal A_nom^-1,
// A = B * (joint 1's transform before its motion), for every reading q.
#pragma once

#include <array>
#include <optional>

#include "hapticcal/model/frame.hpp"
#include "hapticcal/model/model.hpp"

namespace hapticcal {

struct DeviceFrameSplit {
  // The calibrated chain in the device's frame, ending at the tool asked for.
  DeviceModel device;
  // D = T_measurement_device: the device's frame in the measurement frame.
  Frame<double> device_in_measurement = Frame<double>::Identity();
  // The calibrated tool: the point (and frame) the instrument measured, in the
  // last link's frame (a marker, a tracker's target, a fixture's ball).
  std::array<double, 6> measured_tool{};
};

// The frame before joint 1's motion in the model's measurement frame: B times
// joint 1's transform at a zero reading without its part after the motion
// (DH: Tx(a) Rx(alpha) Ry(beta)).
Frame<double> first_joint_frame(const DeviceModel& model);

// The calibrated chain split into the device's model and the set-up. tool: the
// device model's tool pose (x, y, z, roll, pitch, yaw in the last link's
// frame); none: the calibrated tool, the point the instrument measured.
// Gravity (joint compliance) is turned into the device's base frame. Throws
// std::invalid_argument for a tree or models of different structure.
DeviceFrameSplit split_device_frame(
    const DeviceModel& calibrated, const DeviceModel& nominal,
    const std::optional<std::array<double, 6>>& tool = std::nullopt);

// The turn of the last joint's zero about its own axis, calibrated against
// nominal, moved into the tool: the joint's zero as nominal (DH, MDH: theta;
// URDF: the origin's twist about the axis, the offset nominal) and the tool
// turned instead, tool' = X^-1 R_axis(phi) X tool (X: the joint's transform
// after its motion, DH's Tx(a) Rx(alpha) Ry(beta)). The forward kinematics are
// the same for every reading. Measurements that do not see the tool's
// orientation (positions, distances, a fixture's points) cannot tell this turn
// from the direction of the tool point about the axis (a ball on a flange):
// written as a joint's zero it would turn the flange by what the data never
// saw. Returns the turn moved [rad]; 0 (nothing changed) for a tree or a
// prismatic last joint.
double move_last_turn_into_tool(DeviceModel& calibrated, const DeviceModel& nominal);

}  // namespace hapticcal
