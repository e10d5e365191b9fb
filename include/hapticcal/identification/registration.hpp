// Registration: the closed form of the rigid transform that maps one point set
// onto its corresponding other in the least-squares sense (used to register an
// unknown measurement frame before the iterative fit), and a model's
// measurement frame (and tool) fitted on a log (evaluate --register).
#pragma once

#include <Eigen/Core>
#include <array>
#include <optional>
#include <string>

#include "hapticcal/core/log.hpp"
#include "hapticcal/model/model.hpp"

namespace hapticcal {

// b_i ~ R a_i + t, i.e. (R, t) is T_b_a when a and b are the same points in frames a and b.
struct Registration {
  Eigen::Matrix3d R;  // a rotation: orthonormal, det R = +1
  Eigen::Vector3d t;
  // sqrt(sum w_i |R a_i + t - b_i|^2 / sum w_i): the plain RMS when all weights are 1.
  double rms = 0;
};

// The rigid transform minimising sum w_i |R a_i + t - b_i|^2 (Horn 1987, Kabsch 1976): the SVD
// of the weighted cross-covariance of the centred points, with the reflection fixed so that
// det R = +1 (Umeyama 1991, eq. (39)). a and b are 3 x N; weights is empty (all 1) or N
// non-negative numbers, at least 3 of them positive.
// Throws InputError if N < 3, the sizes differ, a value is non-finite, a weight is negative, or
// the points of a (or of b) are (near-)collinear so that the rotation is not determined: the
// second singular value of the centred, weighted points is below 1e-9 of the first.
Registration register_points(const Eigen::Matrix3Xd& a, const Eigen::Matrix3Xd& b,
                             const Eigen::VectorXd& weights = {});

// evaluate --register: what is fitted on the evaluated log before it is scored,
// for a tracker moved between sessions (its log is in a new frame).
enum class RegisterWhat { kFrame, kFrameAndTool };
// "frame" or "frame,tool"; anything else is an InputError listing the choices.
RegisterWhat parse_register(const std::string& text);
const char* to_string(RegisterWhat what);

// The measurement frame (and tool) fitted on a log. Poses are x, y, z, roll,
// pitch, yaw [m, rad] (URDF roll-pitch-yaw, as the device file's base).
struct FrameFit {
  RegisterWhat what = RegisterWhat::kFrame;
  std::array<double, 6> base{};    // the fitted T_meas_base
  std::array<double, 6> change{};  // T_meas_model = fitted base * model's base^-1
  double moved = 0;                // how far the base origin moved [m]
  double turned = 0;               // the angle of the change's rotation [rad]
  // frame,tool: the fitted tool (position; its orientation too on a pose log)
  // and the tool point's move from the model's, in the last link's frame.
  std::optional<std::array<double, 6>> tool;
  Eigen::Vector3d tool_offset = Eigen::Vector3d::Zero();
  double tool_turned = 0;          // the angle between fitted and model tool rotations [rad]
  double rms_position_before = 0;  // the model's RMS position error before registration [m]
};

// The model with its measurement frame (its base, made a pose) and with
// kFrameAndTool its tool fitted on the log's positions (and orientations): the
// closed form (register_points, Horn/Kabsch) on predicted and measured tool
// points, then Levenberg-Marquardt over those slots alone.
struct RegisteredModel {
  DeviceModel model;
  FrameFit fit;
};
// Throws InputError if the log does not fit the model, measures no positions
// (distances, fixture points or planes), or has fewer than 3 positions off a line.
RegisteredModel register_for_evaluation(const DeviceModel& model, const Log& log,
                                        RegisterWhat what);

}  // namespace hapticcal
