// Inverse kinematics with a calibrated model: the readings at which the model
// (every effect it holds: transmissions and joint errors, couplings,
// compliance under its links' weights) puts the tool at a target, by damped
// least squares (Levenberg-Marquardt) from a start. Bounded time (at most
// max_iterations Jacobians and 3 max_iterations evaluations of the model, one
// derivative of its readings' map), no allocation: a controller may call it in
// its loop.
#pragma once

#include "hapticcal/kinematics/kinematics.hpp"

namespace hapticcal {

struct InverseOptions {
  // The tool's orientation too (6 rows), or its point alone (3 rows: a device
  // whose measured point is all its program holds).
  bool orientation = true;
  double position_tolerance = 1e-9;  // m
  double rotation_tolerance = 1e-9;  // rad
  int max_iterations = 100;
  // m/rad: a rotation error counts as this length in the step (the rows'
  // balance; not the tolerance).
  double rotation_scale = 0.1;
  // Near a singularity: the smallest singular value of the Jacobian with
  // respect to the readings (rotation rows times rotation_scale) below this
  // [m/rad]: a target there moves the joints far for a small change.
  double singular_below = 1e-3;
  int tip = 0;  // a tree's tip
};

enum class InverseStatus {
  kConverged,      // within the tolerances, the readings within their limits
  kNear,           // converged, but near a singularity (singular_below)
  kOutsideLimits,  // converged, but a reading outside its limits (outside_limit)
  kNotConverged,   // not within the tolerances after max_iterations: unreachable from the start
};
// "converged", "near a singularity", "outside the joint limits", "not converged".
const char* to_string(InverseStatus status);

struct InverseResult {
  InverseStatus status = InverseStatus::kNotConverged;
  int iterations = 0;
  double position_error = 0;  // m, at the readings returned
  double rotation_error = 0;  // rad (0 without orientation)
  double smallest_singular_value = 0;
  int outside_limit =
      -1;  // the first reading outside [lower, upper] (or joint outside its range), or -1
};

// The readings q (n = model.dof() values) at which `model`'s tool (tip
// options.tip) is at `target` (T_meas_tool; its rotation is ignored without
// orientation), starting from q_start (q may be q_start). lower and upper, if
// not null, are the readings' limits (n values each): a solution outside them
// is returned and said (kOutsideLimits), never clipped. The readings returned
// are the best found, also when not converged.
// The readings' limits inverse_kinematics checks (n values each): the links'
// limits, a continuous joint's unbounded.
void reading_limits(const DeviceModel& model, double* lower, double* upper);
// A solution within the readings' limits that puts a coupled joint outside its
// range (DeviceModel::outside_range) is outside the limits too: the result
// said so (kOutsideLimits, outside_limit that joint).
void check_ranges(const DeviceModel& model, const double* q, InverseResult& result);

InverseResult inverse_kinematics(const PreparedModel& model, const Frame<double>& target,
                                 const double* q_start, double* q,
                                 const InverseOptions& options = {}, const double* lower = nullptr,
                                 const double* upper = nullptr);

}  // namespace hapticcal
