// The clock's Gauss-Newton step and its check (clock_step.hpp): the residuals'
// columns over the clock at a fitted model, and the share of the residuals a
// step or a drift of the clock explains.
#include "identification/streams/clock_step.hpp"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include "hapticcal/identification/two_step.hpp"

namespace hapticcal::detail {
namespace {

// A clock's step or drift is refused or named when it explains this share of
// the fit's residual sum of squares (a clock the fit holds explains about 1 /
// samples); a step splits at least kClockCheckSide samples from either end.
constexpr double kClockShare = 0.1;
constexpr size_t kClockCheckSide = 50;

// The identified kinematic slots of a fit.
std::vector<int> identified_slots(const KinematicFit& fit, int slots) {
  std::vector<int> out;
  for (const ParameterEstimate& e : fit.parameters) {
    if (e.slot < slots && std::find(fit.identified_names.begin(), fit.identified_names.end(),
                                    e.name) != fit.identified_names.end())
      out.push_back(e.slot);
  }
  return out;
}

// Each sample's position residual at a fitted model and the model's tool
// point velocity at its device time (zero where the readings do not reach:
// readings_at_tracker kept only samples with readings either side at the
// clock it was read at), a row each.
struct SampleMotion {
  Eigen::MatrixX3d residual, velocity;
};

SampleMotion sample_motion(const DeviceModel& model, const ReadingInterpolator& readings,
                           const Log& poses, const StreamClock& clock) {
  const PreparedModel prepared(model);
  const int n = model.dof();
  const Eigen::Index m = poses.rows;
  SampleMotion out{Eigen::MatrixX3d(m, 3), Eigen::MatrixX3d(m, 3)};
  Eigen::VectorXd q(n), a(n), b(n);
  Eigen::Vector3d v;
  for (Eigen::Index r = 0; r < m; ++r) {
    q = poses.q.row(r).transpose();
    const int tip = poses.tip.empty() ? 0 : poses.tip[static_cast<size_t>(r)];
    if (!tool_velocity(prepared, readings, clock.device_time(poses.t[r]), a, b, v, tip))
      v.setZero();
    out.residual.row(r) = poses.position.row(r) - prepared.forward(q.data(), tip).p.transpose();
    out.velocity.row(r) = v.transpose();
  }
  return out;
}

// The residuals e (3 a sample) and their columns G over the clock: the
// predicted point's velocity, times the tracker time since the reference for
// the drift.
struct ClockColumns {
  Eigen::MatrixXd G;
  Eigen::VectorXd e;
};

ClockColumns clock_columns(const DeviceModel& model, const ReadingInterpolator& readings,
                           const Log& poses, const StreamClock& clock, bool drift) {
  const Eigen::Index m = poses.rows;
  const SampleMotion motion = sample_motion(model, readings, poses, clock);
  ClockColumns out{Eigen::MatrixXd(3 * m, drift ? 2 : 1), Eigen::VectorXd(3 * m)};
  for (Eigen::Index r = 0; r < m; ++r) {
    out.e.segment<3>(3 * r) = motion.residual.row(r).transpose();
    out.G.block(3 * r, 0, 3, 1) = motion.velocity.row(r).transpose();
    if (drift)
      out.G.block(3 * r, 1, 3, 1) =
          motion.velocity.row(r).transpose() * (poses.t[r] - clock.reference);
  }
  return out;
}

// The least-squares step of G step = e and its covariance sigma^2 (G^T G)^-1,
// sigma^2 from the residuals left when `sigma` is NaN; no step and a NaN
// covariance when G's columns vanish (no motion left to time).
ClockStep solve_clock(const Eigen::MatrixXd& G, const Eigen::VectorXd& e, double sigma) {
  const Eigen::Index c = G.cols();
  ClockStep out;
  const Eigen::MatrixXd N = G.transpose() * G;
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(N);
  if (eig.info() != Eigen::Success || !(eig.eigenvalues().minCoeff() > 1e-12 * N.trace())) {
    out.step = Eigen::VectorXd::Zero(c);
    out.covariance = Eigen::MatrixXd::Constant(c, c, std::nan(""));
    return out;
  }
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(N);
  out.step = ldlt.solve(G.transpose() * e);
  const double dof = std::max<double>(static_cast<double>(G.rows() - c), 1.0);
  const double sigma2 = std::isnan(sigma) ? (e - G * out.step).squaredNorm() / dof : sigma * sigma;
  out.covariance = sigma2 * ldlt.solve(Eigen::MatrixXd::Identity(c, c));
  return out;
}

}  // namespace

bool tool_velocity(const PreparedModel& model, const ReadingInterpolator& readings, double t,
                   Eigen::VectorXd& a, Eigen::VectorXd& b, Eigen::Vector3d& v, int tip) {
  if (!readings.around(t, a.data(), b.data())) return false;
  v = (model.forward(b.data(), tip).p - model.forward(a.data(), tip).p) /
      readings.median_interval();
  return true;
}

ClockStep clock_step(const CalibrationResult& fit, const ReadingInterpolator& readings,
                     const Log& poses, const StreamClock& clock, bool drift) {
  const DeviceModel& model = fit.calibrated;
  const int n = model.dof();
  const Eigen::Index m = poses.rows;
  auto [G, e] = clock_columns(model, readings, poses, clock, drift);
  const std::vector<int> slots = identified_slots(fit.kinematics, model.structure().num_slots());
  if (!slots.empty()) {
    // A tree's rows are each pose's tips in turn, as its samples (tip_samples).
    Eigen::MatrixXd q_poses = poses.q;
    if (model.tree()) {
      q_poses.resize(m / model.tips(), n);
      for (Eigen::Index r = 0; r < q_poses.rows(); ++r)
        q_poses.row(r) = poses.q.row(r * model.tips());
    }
    const Eigen::MatrixXd J =
        two_step_jacobians(model, MeasurementType::kPosition, 1.0, slots, {}, q_poses).kinematic;
    // J x with x the least-squares (basic) solution is G's projection on J's
    // range, rank-deficient or not.
    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(J);
    G -= J * qr.solve(G);
  }
  return solve_clock(G, e, fit.kinematics.sigma);
}

ClockStep held_clock_step(const DeviceModel& model, const ReadingInterpolator& readings,
                          const Log& poses, const StreamClock& clock, bool drift) {
  const ClockColumns columns = clock_columns(model, readings, poses, clock, drift);
  return solve_clock(columns.G, columns.e, std::nan(""));
}

ClockCheck check_clock(const CalibrationResult& fit, const ReadingInterpolator& readings,
                       const Log& poses, const StreamClock& clock) {
  const Eigen::Index m = poses.rows;
  const SampleMotion motion = sample_motion(fit.calibrated, readings, poses, clock);
  // Per sample: v.e and |v|^2, and the time since the session's middle.
  std::vector<double> ve, vv, tau;
  const double sse = motion.residual.squaredNorm();
  const double middle = 0.5 * (poses.t[0] + poses.t[m - 1]);
  for (Eigen::Index r = 0; r < m; ++r) {
    ve.push_back(motion.velocity.row(r).dot(motion.residual.row(r)));
    vv.push_back(motion.velocity.row(r).squaredNorm());
    tau.push_back(poses.t[r] - middle);
  }
  ClockCheck out;
  if (!(sse > 0) || static_cast<size_t>(m) < 2 * kClockCheckSide) return out;
  double S = 0, W = 0, St = 0, Wt = 0, Wtt = 0;
  for (size_t i = 0; i < ve.size(); ++i) {
    S += ve[i], W += vv[i], St += ve[i] * tau[i], Wt += vv[i] * tau[i],
        Wtt += vv[i] * tau[i] * tau[i];
  }
  if (!(W > 0)) return out;
  const double constant = S * S / W;
  // The drift: the offset linear in time (two parameters against one).
  const double det = W * Wtt - Wt * Wt;
  if (det > 0) {
    const double c0 = (Wtt * S - Wt * St) / det, c1 = (W * St - Wt * S) / det;
    out.drift_share = (c0 * S + c1 * St - constant) / sse;
    out.drift = c1;
  }
  // The step: one offset before the split and another after.
  double S1 = 0, W1 = 0, best = 0, best_W1 = 0;
  size_t split = 0;
  for (size_t k = 0; k + 1 < ve.size(); ++k) {
    S1 += ve[k], W1 += vv[k];
    const size_t before = k + 1;
    if (before < kClockCheckSide || ve.size() - before < kClockCheckSide) continue;
    const double S2 = S - S1, W2 = W - W1;
    if (!(W1 > 0 && W2 > 0)) continue;
    const double gain = S1 * S1 / W1 + S2 * S2 / W2 - constant;
    if (gain > best) best = gain, split = before, best_W1 = W1, out.step = S2 / W2 - S1 / W1;
  }
  if (split > 0) {
    const double sigma2 = std::max(sse - best, 0.0) / (3.0 * static_cast<double>(m));
    out.step_sd = std::sqrt(sigma2 * (1 / best_W1 + 1 / (W - best_W1)));
    out.step_share = best / sse;
    out.step_time = 0.5 * (poses.t[static_cast<Eigen::Index>(split) - 1] +
                           poses.t[static_cast<Eigen::Index>(split)]);
    out.line_before = poses.line[split - 1];
    out.line_after = poses.line[split];
  }
  return out;
}

std::string clock_verdict(const ClockCheck& check, const StreamOptions& stream,
                          const std::string& tracker, double span, std::string& drift_note) {
  if (std::getenv("HAPTICCAL_DEBUG_STREAM"))
    fmt::print(stderr, "clock check: step {:.4g} ({:.3g} s at {:.3f}), drift {:.4g} ({:.3g})\n",
               check.step_share, check.step, check.step_time, check.drift_share, check.drift);
  if (!stream.drift && check.drift_share >= kClockShare) {
    drift_note = fmt::format(
        "the clocks drift apart: their offset changes by about {:.1f} ms over the {:.0f} s session "
        "({:.0f} ppm), which explains {:.0f} % of the fit's residual: --clock-drift fits it",
        1e3 * check.drift * span, span, 1e6 * check.drift, 100 * check.drift_share);
  }
  if (!(check.step_share >= kClockShare && (stream.drift || check.step_share > check.drift_share)))
    return {};
  drift_note.clear();
  return fmt::format(
      "the clocks' offset steps by {:+.2f} ms +- {:.2f} between {} lines {} and {} (tracker time "
      "{:.3f} s; a clock resynchronised?), which explains {:.0f} % of the fit's residual: one "
      "offset cannot hold the session; calibrate the parts before and after the step on their own",
      1e3 * check.step, 1e3 * check.step_sd, tracker, check.line_before, check.line_after,
      check.step_time, 100 * check.step_share);
}

}  // namespace hapticcal::detail
