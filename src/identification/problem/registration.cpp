#include "hapticcal/identification/registration.hpp"

#include <ceres/ceres.h>
#include <fmt/format.h>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <optional>

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/joint_errors.hpp"
#include "hapticcal/identification/log_fit.hpp"
#include "hapticcal/identification/measurement.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "identification/problem/measurement_cost.hpp"
#include "identification/problem/solver_options.hpp"

namespace hapticcal {
namespace {

// Below this ratio of the second to the first singular value of the centred points, the points
// lie on a line as far as double precision and measurement can tell: the rotation about it is
// not determined.
constexpr double kCollinear = 1e-9;

template <typename Derived>
void check_finite(const Eigen::MatrixBase<Derived>& m, const char* name) {
  for (Eigen::Index j = 0; j < m.cols(); ++j) {
    for (Eigen::Index i = 0; i < m.rows(); ++i) {
      if (!std::isfinite(m(i, j))) {
        throw InputError(
            fmt::format("register_points: {}({}, {}) = {} is not finite", name, i, j, m(i, j)));
      }
    }
  }
}

// centred: the points minus their weighted mean, column i scaled by sqrt(w_i).
void check_spread(const Eigen::Matrix3Xd& centred, const char* name) {
  const Eigen::Vector3d s = Eigen::JacobiSVD<Eigen::MatrixXd>(centred).singularValues();
  if (!(s[1] > kCollinear * s[0])) {
    throw InputError(fmt::format(
        "register_points: the points of {} are {}: the rotation is not determined (singular "
        "values of the centred points {:.3g}, {:.3g}, {:.3g})",
        name, s[0] == 0 ? "all at one place" : "(near-)collinear", s[0], s[1], s[2]));
  }
}

}  // namespace

Registration register_points(const Eigen::Matrix3Xd& a, const Eigen::Matrix3Xd& b,
                             const Eigen::VectorXd& weights) {
  const Eigen::Index n = a.cols();
  if (b.cols() != n) {
    throw InputError(
        fmt::format("register_points: a has {} points but b has {}", a.cols(), b.cols()));
  }
  if (weights.size() != 0 && weights.size() != n) {
    throw InputError(
        fmt::format("register_points: {} weights for {} points", weights.size(), a.cols()));
  }
  if (n < 3) {
    throw InputError(
        fmt::format("register_points: {} points; a rigid transform needs at least 3", n));
  }
  check_finite(a, "a");
  check_finite(b, "b");
  check_finite(weights, "weights");
  const Eigen::VectorXd w = weights.size() == 0 ? Eigen::VectorXd::Ones(n) : weights;
  Eigen::Index positive = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    if (w[i] < 0) {
      throw InputError(fmt::format("register_points: weights({}) = {} is negative", i, w[i]));
    }
    positive += w[i] > 0;
  }
  if (positive < 3) {
    throw InputError(fmt::format(
        "register_points: {} points have a positive weight; a rigid transform needs at least 3",
        positive));
  }

  // Weighted means, and the centred points scaled by sqrt(w) so that products of them are the
  // weighted sums of Horn (1987) eqs. (25)-(27).
  const double w_sum = w.sum();
  const Eigen::Vector3d a_mean = a * w / w_sum;
  const Eigen::Vector3d b_mean = b * w / w_sum;
  const Eigen::VectorXd sqrt_w = w.cwiseSqrt();
  const Eigen::Matrix3Xd a_c = (a.colwise() - a_mean) * sqrt_w.asDiagonal();
  const Eigen::Matrix3Xd b_c = (b.colwise() - b_mean) * sqrt_w.asDiagonal();
  if (!std::isfinite(w_sum) || !a_c.allFinite() || !b_c.allFinite()) {
    throw InputError("register_points: coordinates or weights too large to square and sum");
  }
  check_spread(a_c, "a");
  check_spread(b_c, "b");

  // Sigma_ba = sum w_i (b_i - b_mean)(a_i - a_mean)^T = U S V^T; R = U diag(1, 1, det(U V^T)) V^T
  // maximises trace(R^T Sigma_ba) over rotations (Umeyama 1991, eqs. (39)-(40)).
  const Eigen::Matrix3d sigma_ba = b_c * a_c.transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(sigma_ba, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d& U = svd.matrixU();
  const Eigen::Matrix3d& V = svd.matrixV();
  Eigen::Vector3d d(1, 1, 1);
  if (U.determinant() * V.determinant() < 0) d[2] = -1;  // a reflection: flip the weakest axis

  Registration out;
  out.R = U * d.asDiagonal() * V.transpose();
  out.t = b_mean - out.R * a_mean;
  const Eigen::Matrix3Xd residual = (out.R * a).colwise() + out.t - b;
  out.rms = std::sqrt(residual.colwise().squaredNorm().dot(w) / w_sum);
  return out;
}

// A model's measurement frame (and tool) fitted on a log (evaluate --register):
// the measured points registered in closed form, then Levenberg-Marquardt.
namespace {

constexpr int kRegistrationIterations = 100;  // Levenberg-Marquardt's limit

std::array<double, 6> registered_pose(const Frame<double>& T) {
  const Eigen::Vector3d rpy = matrix_rpy(T.R);
  return {T.p[0], T.p[1], T.p[2], rpy[0], rpy[1], rpy[2]};
}

// The model with its base as a pose: a DH base is one rigid transform too, and
// only a pose can take any registration.
DeviceModel with_pose_base(DeviceModel m) {
  if (m.base_is_pose()) return m;
  const Frame<double> B = base_frame(m.structure(), m.kinematic_parameters().data());
  m.base_kind = BaseKind::kPose;
  m.base = registered_pose(B);
  return m;
}

// Registration needs the log to say where the tool point was.
MeasurementType registrable_type(const Log& log) {
  const MeasurementType type = measurement_type(log);
  if (!kind_of(type).measures_point()) {
    throw InputError(log.origin, 0, "--register",
                     fmt::format("registration needs measured positions (x, y, z columns); this "
                                 "log has {}",
                                 traits(type).plural));
  }
  if (log.rows < 3) {
    throw InputError(log.origin, 0, "--register",
                     fmt::format("the log has {} rows; fitting the measurement frame needs at "
                                 "least 3 positions, not on one line",
                                 log.rows));
  }
  return type;
}

// The closed form (Horn/Kabsch) of T_meas_model on predicted points a and
// measured points b, with the log named in the error.
Registration closed_form_registration(const Log& log, const Eigen::Matrix3Xd& a,
                                      const Eigen::Matrix3Xd& b) {
  try {
    return register_points(a, b);
  } catch (const InputError& e) {
    throw InputError(log.origin, 0, "--register",
                     "the measurement frame is not determined: the measured positions (or the "
                     "model's tool points) lie at one place or on one line (" +
                         e.message() + ")");
  }
}

// A pose's rotation rows count as that angle at the RMS distance of the tool
// point from the base (as calibrate weighs them): invariant under a base move.
double registration_rotation_scale(const ChainStructure& s, const Eigen::VectorXd& p,
                                   const std::vector<Eigen::VectorXd>& joints) {
  const ChainConstants<double> constants = chain_constants(s, p.data());
  double sum = 0;
  for (const Eigen::VectorXd& q : joints) {
    sum += (forward_kinematics(s, constants, q.data()).p - constants.base.p).squaredNorm();
  }
  return std::max(std::sqrt(sum / static_cast<double>(joints.size())), 1e-3);
}

// Levenberg-Marquardt over the base slots and, with the tool, the tool's
// position (and its rotation, which only a pose log sees); every other slot held.
void refine_registration(const ChainStructure& s, Eigen::VectorXd& p,
                         const std::vector<Eigen::VectorXd>& joints, const detail::RowsOf& kind,
                         const detail::RowMatrix& measured, RegisterWhat what) {
  const int tool_free = what == RegisterWhat::kFrameAndTool ? observed_tool_slots(kind.type) : 0;
  std::vector<int> constant;
  for (int k = s.base_slots(); k < s.num_slots(); ++k) {
    if (k < s.tool_slot() || k >= s.tool_slot() + tool_free) constant.push_back(k);
  }
  ceres::Problem problem;
  problem.AddResidualBlock(new detail::MeasurementCost(s, joints, kind, measured), nullptr,
                           p.data());
  problem.SetManifold(p.data(), new ceres::SubsetManifold(s.num_slots(), constant));
  ceres::Solver::Summary summary;
  detail::solve(detail::levenberg_marquardt(kRegistrationIterations), &problem, &summary);
}

FrameFit frame_fit(const DeviceModel& model, const DeviceModel& fitted, RegisterWhat what,
                   double rms_before) {
  const Frame<double> B0 = base_frame(model.structure(), model.kinematic_parameters().data());
  const Frame<double> B1 = base_frame(fitted.structure(), fitted.kinematic_parameters().data());
  const Frame<double> change = B1 * B0.inverse();
  FrameFit fit;
  fit.what = what;
  fit.base = fitted.base;
  fit.change = registered_pose(change);
  fit.moved = (B1.p - B0.p).norm();
  fit.turned = Eigen::AngleAxisd(change.R).angle();
  fit.rms_position_before = rms_before;
  if (what == RegisterWhat::kFrameAndTool) {
    fit.tool = fitted.tool;
    const Frame<double> T0 = pose_frame(model.tool), T1 = pose_frame(fitted.tool);
    fit.tool_offset = T1.p - T0.p;
    fit.tool_turned = Eigen::AngleAxisd(Eigen::Matrix3d(T1.R * T0.R.transpose())).angle();
  }
  return fit;
}

}  // namespace

RegisterWhat parse_register(const std::string& text) {
  if (text == "frame") return RegisterWhat::kFrame;
  if (text == "frame,tool") return RegisterWhat::kFrameAndTool;
  throw InputError(fmt::format(
      "--register '{}': expected frame (the measurement frame) or frame,tool (it and the tool "
      "point)",
      printable(text)));
}

const char* to_string(RegisterWhat what) {
  return what == RegisterWhat::kFrame ? "frame" : "frame,tool";
}

RegisteredModel register_for_evaluation(const DeviceModel& model, const Log& log,
                                        RegisterWhat what) {
  check_log_fits(log, model);
  const MeasurementType type = registrable_type(log);
  DeviceModel m = with_pose_base(model);
  const ChainStructure s = m.structure();
  Eigen::VectorXd p = m.kinematic_parameters();
  std::vector<Eigen::VectorXd> joints(log.rows);
  detail::RowMatrix measured(log.rows, traits(type).width);
  Eigen::Matrix3Xd a(3, log.rows), b(3, log.rows);
  const ChainConstants<double> constants = chain_constants(s, p.data());
  // Each pose's joint values (compensated, with backlash) and a lateral
  // compliance's bends of its links (StepTwoJoints).
  const StepTwoJoints step_two(m);
  const std::optional<int> bends = step_two.bends();
  for (int r = 0; r < log.rows; ++r) {
    joints[r] = step_two.row(log, r);
    measured_values(type, log, r, measured.row(r).data());
    ChainConstants<double> bent = constants;
    if (bends) bend_links(s, joints[r].data() + *bends, bent.links.data());
    a.col(r) = forward_kinematics(s, bent, joints[r].data()).p;
    b.col(r) = kind_of(type).measured_point(measured.row(r).data());
    if (!a.col(r).allFinite()) {
      throw InputError(log.origin, r < static_cast<int>(log.line.size()) ? log.line[r] : 0, "",
                       "the model's tool point on this row is not finite");
    }
  }
  const double rms_before = std::sqrt((a - b).colwise().squaredNorm().mean());
  const Registration reg = closed_form_registration(log, a, b);
  const Frame<double> moved = Frame<double>{reg.R, reg.t} * constants.base;
  const std::array<double, 6> start = registered_pose(moved);
  for (int k = 0; k < kPoseSlots; ++k) p[k] = start[k];
  refine_registration(
      s, p, joints,
      detail::RowsOf{type, registration_rotation_scale(s, p, joints), nullptr, nullptr, bends},
      measured, what);
  m.set_kinematic_parameters(p);
  return {m, frame_fit(model, m, what, rms_before)};
}

}  // namespace hapticcal
