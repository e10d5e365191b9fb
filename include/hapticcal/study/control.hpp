// Closed-loop impedance control with a proportional force loop (paper Fig. 11)
// against a virtual wall, with the handle fixed: what the
// kinematic model does to the force a haptic device renders.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "hapticcal/model/model.hpp"
#include "hapticcal/study/paper.hpp"

namespace hapticcal {

using Vector6d = Eigen::Matrix<double, 6, 1>;

struct ForceScenario {
  Eigen::VectorXd posture;  // readings q of the fixed handle (empty: the default)
  // Zero-based; kNoLock: none; kLockRedundant: joint 3 on a 7-joint device (the
  // paper's redundant joint), none on a 6-joint one. 6 joints must remain.
  static constexpr int kNoLock = -1, kLockRedundant = -2;
  int locked_joint = kLockRedundant;
  double stiffness = 100;   // virtual wall K [N/m]
  double travel = 0.02;     // how far the wall moves along the handle's z [m]
  double move_seconds = 2;  // over this time (smooth), then
  double hold_seconds = 1;  // held
  double rate_hz = 1000;
  double gain = 0.5;        // G in F_cmd = F_d + G (F_d - F_sens)
  double sensor_noise = 0;  // sd of each sensor force [N] (moments: times 0.01 m)
  std::uint64_t seed = 1;
};

struct ForceRun {
  std::vector<double> t;
  std::vector<Vector6d> desired, measured;  // [F; M] in the handle frame
  double transverse_rms = 0;                // RMS of sqrt(Fx^2 + Fy^2) [N]
};

// The locked joint (zero-based, or kNoLock) for `model`: kLockRedundant
// resolved (joint 3 of a device of 7 actuated joints). Throws InputError,
// saying what the study needs, unless 6 actuated joints remain (the handle
// Jacobian must be 6 x 6; a coupled model's passive joints are not actuated).
int resolved_locked_joint(const ForceScenario& scenario, const DeviceModel& model);

// The static map from the commanded to the rendered wrench with the handle
// fixed: W = J_q,a^-T J_q,m^T F_cmd, J_q = J d theta / d q the handle Jacobian
// w.r.t. the actuated readings (handle frame, locked reading removed; d theta /
// d q = C diag(1 + dtheta') carries the transmissions and a coupling: the
// actuators' torques are C^T-mapped). Throws InputError if the posture is
// singular for either model.
Eigen::Matrix<double, 6, 6> rendering_map(const DeviceModel& actual, const DeviceModel& controller,
                                          const ForceScenario& scenario);

// The loop is stable for |G| < 1 / spectral radius of the rendering map.
double stable_gain_limit(const DeviceModel& actual, const DeviceModel& controller,
                         const ForceScenario& scenario);

// One run at `rate_hz`: the sensor reads the rendered wrench one sample later.
ForceRun run_force(const DeviceModel& actual, const DeviceModel& controller,
                   const ForceScenario& scenario);

// The force study's stable range: |G| < the smaller of stable_gain_limit for the
// nominal and the calibrated controller model (an empty posture: the default).
double force_study_gain_limit(const DeviceModel& actual, const DeviceModel& nominal,
                              const DeviceModel& calibrated, const ForceScenario& scenario);

// The actual device rendered by the nominal and by the calibrated model.
struct ForceStudy {
  ForceScenario scenario;        // as run: an empty posture replaced by the default
  bool default_posture = false;  // the posture was default_posture(actual)
  double stable_gain_limit = 0;  // force_study_gain_limit
  ForceRun nominal, calibrated;
  double reduction_pct = 0;  // eq. (9) on the transverse force RMS
};

// Throws InputError if |gain| is outside the stable range or the posture is
// singular or of the wrong size.
ForceStudy run_force_study(const DeviceModel& actual, const DeviceModel& nominal,
                           const DeviceModel& calibrated, const ForceScenario& scenario);

}  // namespace hapticcal
