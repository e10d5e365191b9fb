// Internal: the clock's Gauss-Newton step at a fit (or with the model held) and
// what a clock the fit holds leaves in its residuals (a step, a drift):
// calibrate_streams and align_streams (stream_fit.cpp) iterate and check them.
#pragma once

#include <Eigen/Core>
#include <string>

#include "hapticcal/identification/identification.hpp"
#include "hapticcal/identification/stream.hpp"
#include "hapticcal/kinematics/kinematics.hpp"

namespace hapticcal::detail {

// The tool point's velocity at device time t [m/s], central differences over
// ReadingInterpolator::around (a and b: buffers of dof values); false where the
// readings do not reach.
bool tool_velocity(const PreparedModel& model, const ReadingInterpolator& readings, double t,
                   Eigen::VectorXd& a, Eigen::VectorXd& b, Eigen::Vector3d& v, int tip = 0);

struct ClockStep {
  Eigen::VectorXd step;        // offset [s] (, drift)
  Eigen::MatrixXd covariance;  // of the clock parameters
};

// The Gauss-Newton step of the clock at a fitted model: the residuals'
// columns over the clock (the predicted point's velocity, times the tracker
// time since the reference for the drift), projected off the identified
// kinematic columns.
ClockStep clock_step(const CalibrationResult& fit, const ReadingInterpolator& readings,
                     const Log& poses, const StreamClock& clock, bool drift);
// The Gauss-Newton step of the clock with the model held: the residuals'
// columns over the clock (the velocity, times the time since the reference
// for the drift), not projected (nothing else is fitted); the sd from the
// residuals' own scatter.
ClockStep held_clock_step(const DeviceModel& model, const ReadingInterpolator& readings,
                          const Log& poses, const StreamClock& clock, bool drift);

// What a clock the fit holds constant (or drifting) leaves in the residuals: each
// sample's residual e against the tool point's velocity v is v times the
// clock's error there, so the share of the residuals' sum of squares that one
// offset change (at the best split) or a drift explains tells a step or a
// drift from noise (about 1 / samples).
struct ClockCheck {
  double step_share = 0, drift_share = 0;
  double step = 0, step_sd = 0;  // s: the offset after the split less before
  double step_time = 0;          // tracker time [s] between the split's samples
  int line_before = 0, line_after = 0;
  double drift = 0;  // the drift a linear clock error gives
};

ClockCheck check_clock(const CalibrationResult& fit, const ReadingInterpolator& readings,
                       const Log& poses, const StreamClock& clock);

// A clock the model cannot hold: the reason a step refuses the session (empty
// if none), and `drift_note` for a drift not fitted.
std::string clock_verdict(const ClockCheck& check, const StreamOptions& stream,
                          const std::string& tracker, double span, std::string& drift_note);

}  // namespace hapticcal::detail
