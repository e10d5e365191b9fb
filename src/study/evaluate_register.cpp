// evaluate --register: the measurement frame (and tool) fitted on the evaluated
// log, so that a log taken after the tracker moved is scored in its own frame.
#include <ceres/ceres.h>
#include <fmt/format.h>

#include <cmath>
#include <optional>

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/registration.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "identification/problem/measurement_cost.hpp"
#include "identification/problem/solver_options.hpp"

namespace hapticcal {
namespace {

constexpr int kRegistrationIterations = 100;  // Levenberg-Marquardt's limit

std::array<double, 6> pose_of(const Frame<double>& T) {
  const Eigen::Vector3d rpy = matrix_rpy(T.R);
  return {T.p[0], T.p[1], T.p[2], rpy[0], rpy[1], rpy[2]};
}

// The model with its base as a pose: a DH base is one rigid transform too, and
// only a pose can take any registration.
DeviceModel with_pose_base(DeviceModel m) {
  if (m.base_is_pose()) return m;
  const Frame<double> B = base_frame(m.structure(), m.kinematic_parameters().data());
  m.base_kind = BaseKind::kPose;
  m.base = pose_of(B);
  return m;
}

// Registration needs the log to say where the tool point was.
MeasurementType registrable_type(const Log& log) {
  const MeasurementType type = measurement_type(log);
  if (!traits(type).own_frame) {
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
Registration closed_form(const Log& log, const Eigen::Matrix3Xd& a, const Eigen::Matrix3Xd& b) {
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
double rotation_scale(const ChainStructure& s, const Eigen::VectorXd& p,
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
void refine(const ChainStructure& s, Eigen::VectorXd& p, const std::vector<Eigen::VectorXd>& joints,
            const detail::RowsOf& kind, const detail::RowMatrix& measured, RegisterWhat what) {
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
  fit.change = pose_of(change);
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
    b.col(r) = log.position.row(r).transpose();
    if (!a.col(r).allFinite()) {
      throw InputError(log.origin, r < static_cast<int>(log.line.size()) ? log.line[r] : 0, "",
                       "the model's tool point on this row is not finite");
    }
  }
  const double rms_before = std::sqrt((a - b).colwise().squaredNorm().mean());
  const Registration reg = closed_form(log, a, b);
  const Frame<double> moved = Frame<double>{reg.R, reg.t} * constants.base;
  const std::array<double, 6> start = pose_of(moved);
  for (int k = 0; k < kPoseSlots; ++k) p[k] = start[k];
  refine(s, p, joints, detail::RowsOf{type, rotation_scale(s, p, joints), nullptr, nullptr, bends},
         measured, what);
  m.set_kinematic_parameters(p);
  return {m, frame_fit(model, m, what, rms_before)};
}

Evaluation evaluate_registered(const DeviceModel& model, const Log& log, RegisterWhat what,
                               const std::vector<PointDistance>& point_distances,
                               const std::vector<KnownPoint>& known_points) {
  RegisteredModel r = register_for_evaluation(model, log, what);
  Evaluation ev = evaluate(r.model, log, point_distances, known_points);
  ev.registered = std::move(r.fit);
  return ev;
}

}  // namespace hapticcal
