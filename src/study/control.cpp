#include "hapticcal/study/control.hpp"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <random>

#include "hapticcal/core/error.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/study/evaluate.hpp"

namespace hapticcal {
namespace {

// The handle Jacobian with respect to the actuated readings,
// J_q = J (d theta / d q) (handle frame; the locked reading and a coupled
// model's unused readings removed): J_q^T maps a handle wrench to the
// actuators' torques (through a coupling's C^T).
struct Statics {
  Eigen::Matrix<double, 6, 6> Jq;
};

Statics statics(const DeviceModel& model, const ForceScenario& sc, const char* which) {
  const PreparedModel prepared(model);
  Jacobian6<double> J;
  prepared.forward_jacobian(sc.posture.data(), JacobianFrame::kTool, J);
  int locked = ForceScenario::kNoLock;
  try {
    locked = resolved_locked_joint(sc, model);
  } catch (const InputError& e) {
    throw InputError(fmt::format("{}: {}", which, e.what()));
  }
  const Eigen::Matrix<double, 6, Eigen::Dynamic> Jq = J * model.reading_jacobian(sc.posture);
  Statics s;
  for (int k = 0, c = 0; k < model.dof(); ++k) {
    if (k == locked || !model.reading_used(k)) continue;
    s.Jq.col(c++) = Jq.col(k);
  }
  const Eigen::JacobiSVD<Eigen::Matrix<double, 6, 6>> svd(s.Jq);
  const double ratio = svd.singularValues()[5] / svd.singularValues()[0];
  // Below 1e-2 a joint-torque error reaches the wrench amplified over 100 times.
  if (!(ratio > 1e-2)) {
    throw InputError(
        fmt::format("{}: the posture is (nearly) singular (smallest / largest singular "
                    "value of the 6 x 6 Jacobian {:.2g}, below 0.01): choose another "
                    "--posture",
                    which, ratio));
  }
  return s;
}

}  // namespace

int resolved_locked_joint(const ForceScenario& sc, const DeviceModel& model) {
  const int dof = model.dof();
  int actuated = 0;  // readings some joint uses
  for (int k = 0; k < dof; ++k) actuated += model.reading_used(k) ? 1 : 0;
  int locked = sc.locked_joint;
  if (locked == ForceScenario::kLockRedundant) {  // the third actuated reading
    locked = ForceScenario::kNoLock;
    for (int k = 0, seen = 0; actuated == 7 && k < dof && locked < 0; ++k) {
      if (model.reading_used(k) && ++seen == 3) locked = k;
    }
  }
  if (locked >= dof || locked < ForceScenario::kNoLock) {
    throw InputError(
        fmt::format("joint {} cannot be locked: the device has {} joints", locked + 1, dof));
  }
  if (locked >= 0 && !model.reading_used(locked)) {
    throw InputError(
        fmt::format("joint {} cannot be locked: it is passive (no joint uses its "
                    "reading; the coupling drives it)",
                    locked + 1));
  }
  const int kept = actuated - (locked >= 0 ? 1 : 0);
  if (kept != 6) {
    throw InputError(fmt::format(
        "the force study needs 6 actuated joints after locking (a 6 x 6 handle Jacobian): the "
        "device has {} actuated joints{}, so {} remain; {}",
        actuated, locked >= 0 ? fmt::format(" with joint {} locked", locked + 1) : "", kept,
        kept > 6 ? "lock one with --lock J (a 7-joint device)"
        : actuated == 6
            ? "lock none (--lock 0)"
            : "a device of fewer than 6 joints cannot render a 6-D wrench at a fixed handle"));
  }
  return locked;
}

Eigen::Matrix<double, 6, 6> rendering_map(const DeviceModel& actual, const DeviceModel& controller,
                                          const ForceScenario& scenario) {
  ForceScenario sc = scenario;
  if (sc.posture.size() == 0) sc.posture = default_posture(actual);
  if (sc.posture.size() != actual.dof() || controller.dof() != actual.dof()) {
    throw InputError(fmt::format("the posture has {} readings, the devices {} and {} joints",
                                 sc.posture.size(), actual.dof(), controller.dof()));
  }
  for (int i = 0; i < sc.posture.size(); ++i) {  // the library's check, for every caller
    if (!std::isfinite(sc.posture[i])) {
      throw InputError(
          fmt::format("--posture: reading {} is {}: give a finite number", i + 1, sc.posture[i]));
    }
  }
  const Statics a = statics(actual, sc, "actual device"),
                m = statics(controller, sc, "controller model");
  // The actuators apply tau_q = J_q,m^T F; the device renders W with J_q,a^T W = tau_q.
  return a.Jq.transpose().partialPivLu().solve(m.Jq.transpose());
}

double stable_gain_limit(const DeviceModel& actual, const DeviceModel& controller,
                         const ForceScenario& scenario) {
  const Eigen::Matrix<double, 6, 6> A = rendering_map(actual, controller, scenario);
  return 1 / Eigen::EigenSolver<Eigen::Matrix<double, 6, 6>>(A, false)
                 .eigenvalues()
                 .cwiseAbs()
                 .maxCoeff();
}

ForceRun run_force(const DeviceModel& actual, const DeviceModel& controller,
                   const ForceScenario& sc) {
  const Eigen::Matrix<double, 6, 6> A = rendering_map(actual, controller, sc);
  std::mt19937_64 rng(sc.seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  ForceRun run;
  const int steps = static_cast<int>((sc.move_seconds + sc.hold_seconds) * sc.rate_hz);
  Vector6d rendered = Vector6d::Zero();  // W at the previous sample
  double transverse2 = 0;
  for (int k = 0; k < steps; ++k) {
    const double t = k / sc.rate_hz;
    const double u = sc.move_seconds > 0 ? std::min(t / sc.move_seconds, 1.0) : 1.0;
    const double depth = sc.travel * u * u * (3 - 2 * u);  // smooth wall motion
    Vector6d desired = Vector6d::Zero();
    desired[2] = sc.stiffness * depth;  // along the handle's z axis
    Vector6d sensed = rendered;         // one sample late
    if (sc.sensor_noise > 0) {
      for (int c = 0; c < 6; ++c) sensed[c] += sc.sensor_noise * (c < 3 ? 1.0 : 0.01) * gauss(rng);
    }
    const Vector6d command = desired + sc.gain * (desired - sensed);
    rendered = A * command;
    run.t.push_back(t);
    run.desired.push_back(desired);
    run.measured.push_back(sensed);
    transverse2 += sensed[0] * sensed[0] + sensed[1] * sensed[1];
  }
  run.transverse_rms = std::sqrt(transverse2 / std::max(steps, 1));
  return run;
}

double force_study_gain_limit(const DeviceModel& actual, const DeviceModel& nominal,
                              const DeviceModel& calibrated, const ForceScenario& scenario) {
  return std::min(stable_gain_limit(actual, nominal, scenario),
                  stable_gain_limit(actual, calibrated, scenario));
}

ForceStudy run_force_study(const DeviceModel& actual, const DeviceModel& nominal,
                           const DeviceModel& calibrated, const ForceScenario& scenario) {
  ForceStudy study;
  study.scenario = scenario;
  ForceScenario& sc = study.scenario;
  study.default_posture = sc.posture.size() == 0;
  if (study.default_posture) sc.posture = default_posture(actual);
  sc.locked_joint = resolved_locked_joint(sc, actual);
  study.stable_gain_limit = force_study_gain_limit(actual, nominal, calibrated, sc);
  if (!(std::abs(sc.gain) < study.stable_gain_limit)) {
    throw InputError(fmt::format(
        "gain G = {} is outside the stable range: |G| < {:.4f} for these models (1 / spectral "
        "radius of the rendering map)",
        sc.gain, study.stable_gain_limit));
  }
  study.nominal = run_force(actual, nominal, sc);
  study.calibrated = run_force(actual, calibrated, sc);
  study.reduction_pct =
      rms_improvement_pct(study.calibrated.transverse_rms, study.nominal.transverse_rms);
  return study;
}

}  // namespace hapticcal
