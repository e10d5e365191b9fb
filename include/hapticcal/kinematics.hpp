// Forward kinematics T_meas_tool = B * A_1 ... A_n * T_tool (SPEC section 1), the
// geometric Jacobian, and analytic derivatives of the tool position and of the
// distance (paper eq. 5) with respect to every kinematic parameter.
//
// The generic functions are templated on the scalar (double or ceres::Jet) and
// take the flat parameter vector of ChainStructure. PreparedModel is the fast
// double path for a controller: constant link terms are computed once.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cassert>
#include <cmath>
#include <vector>

#include "hapticcal/frame.hpp"
#include "hapticcal/model.hpp"
#include "hapticcal/transmission.hpp"

namespace hapticcal {

constexpr int kMaxDof = 32;

// In which frame the geometric Jacobian is expressed; the reference point is the
// tool point in both cases.
enum class JacobianFrame { kMeasurement, kTool };

template <typename T>
using Jacobian6 = Eigen::Matrix<T, 6, Eigen::Dynamic>;

// The parts of A_i that do not depend on the joint angle.
//   DH:  A = Rz(theta) * T(a, 0, d) * Rx(alpha) * Ry(beta)
//   MDH: A = Rx(alpha) * Tx(a) * Ry(beta) * Rz(theta) * Tz(d)
// Each elementary rotation is applied to two columns only. apply_beta is false
// only where beta is exactly zero in a prepared double model; the generic path
// always applies Ry(beta) so that a Jet carries its derivative.
template <typename T>
struct LinkConstants {
  T a, d, theta_offset;
  T cos_alpha, sin_alpha, cos_beta, sin_beta;
  bool apply_beta = true;
};

template <typename T>
LinkConstants<T> link_constants(const T* slot) {
  using std::cos;
  using std::sin;
  LinkConstants<T> k;
  k.a = slot[kLinkA];
  k.d = slot[kLinkD];
  k.theta_offset = slot[kLinkTheta];
  k.cos_alpha = cos(slot[kLinkAlpha]);
  k.sin_alpha = sin(slot[kLinkAlpha]);
  k.cos_beta = cos(slot[kLinkBeta]);
  k.sin_beta = sin(slot[kLinkBeta]);
  return k;
}

#if defined(__GNUC__)
#define HAPTICCAL_INLINE [[gnu::always_inline]] inline
#else
#define HAPTICCAL_INLINE inline
#endif

// R * Rz(theta), R * Rx(alpha), R * Ry(beta) in place, by columns.
template <typename T>
HAPTICCAL_INLINE void turn_z(Mat3<T>& R, const T& c, const T& s) {
  const Vec3<T> x = R.col(0);
  R.col(0) = c * x + s * R.col(1);
  R.col(1) = c * R.col(1) - s * x;
}
template <typename T>
HAPTICCAL_INLINE void turn_x(Mat3<T>& R, const T& c, const T& s) {
  const Vec3<T> y = R.col(1);
  R.col(1) = c * y + s * R.col(2);
  R.col(2) = c * R.col(2) - s * y;
}
template <typename T>
HAPTICCAL_INLINE void turn_y(Mat3<T>& R, const T& c, const T& s) {
  const Vec3<T> x = R.col(0);
  R.col(0) = c * x - s * R.col(2);
  R.col(2) = s * x + c * R.col(2);
}

// next = prev * A_i for the joint angle theta given by its cosine and sine.
template <typename T>
HAPTICCAL_INLINE void compose_link(Convention convention, const Frame<T>& prev,
                                   const LinkConstants<T>& k, const T& c, const T& s,
                                   Frame<T>& next) {
  next.R = prev.R;
  if (convention == Convention::kDh) {
    turn_z(next.R, c, s);
    next.p = prev.p + k.a * next.R.col(0) + k.d * next.R.col(2);
    turn_x(next.R, k.cos_alpha, k.sin_alpha);
    if (k.apply_beta) turn_y(next.R, k.cos_beta, k.sin_beta);
  } else {
    turn_x(next.R, k.cos_alpha, k.sin_alpha);
    next.p = prev.p + k.a * next.R.col(0);
    if (k.apply_beta) turn_y(next.R, k.cos_beta, k.sin_beta);
    next.p += k.d * next.R.col(2);
    turn_z(next.R, c, s);
  }
}

template <typename T>
Frame<T> base_frame(const ChainStructure& s, const T* params) {
  using std::cos;
  using std::sin;
  if (s.base_kind == BaseKind::kPose) {
    return pose_frame(params[0], params[1], params[2], params[3], params[4], params[5]);
  }
  // Paper's frame "w": a standard DH transform with its own (fixed) theta.
  const T slot[kLinkSlots] = {params[0], params[1], params[2], params[3], T(0)};
  LinkConstants<T> k = link_constants(slot);
  k.apply_beta = false;
  Frame<T> B;
  compose_link(Convention::kDh, Frame<T>::Identity(), k, cos(k.theta_offset), sin(k.theta_offset),
               B);
  return B;
}

template <typename T>
Frame<T> tool_frame(const ChainStructure& s, const T* params) {
  const T* t = params + s.tool_slot();
  return pose_frame(t[0], t[1], t[2], t[3], t[4], t[5]);
}

// The parts of the chain that do not depend on the joint angles, computed once
// per parameter vector and shared by every sample.
template <typename T>
struct ChainConstants {
  Frame<T> base, tool;
  std::array<LinkConstants<T>, kMaxDof> links;
};

template <typename T>
ChainConstants<T> chain_constants(const ChainStructure& s, const T* params) {
  assert(s.dof <= kMaxDof);
  ChainConstants<T> c;
  c.base = base_frame(s, params);
  c.tool = tool_frame(s, params);
  for (int i = 0; i < s.dof; ++i) c.links[i] = link_constants(params + s.link_slot(i));
  return c;
}

// T_meas_tool for joint = q + dtheta(q) (the offsets are added here). If frames is
// given it receives T_meas_i for i = 0..n (frame 0 is the base).
template <typename T>
Frame<T> forward_kinematics(const ChainStructure& s, const ChainConstants<T>& c, const T* joint,
                            Frame<T>* frames = nullptr) {
  using std::cos;
  using std::sin;
  std::array<Frame<T>, kMaxDof + 1> local;
  if (!frames) frames = local.data();
  frames[0] = c.base;
  for (int i = 0; i < s.dof; ++i) {
    const T theta = joint[i] + c.links[i].theta_offset;
    compose_link(s.convention, frames[i], c.links[i], cos(theta), sin(theta), frames[i + 1]);
  }
  return frames[s.dof] * c.tool;
}

template <typename T>
Frame<T> forward_kinematics(const ChainStructure& s, const T* params, const T* joint,
                            Frame<T>* frames = nullptr) {
  return forward_kinematics(s, chain_constants(s, params), joint, frames);
}

// Geometric Jacobian (6 x n, linear rows first) of the tool point with respect to
// the joint angles, from the frames of forward_kinematics.
template <typename T>
void geometric_jacobian(const ChainStructure& s, const Frame<T>* frames,
                        const Frame<T>& T_meas_tool, JacobianFrame expressed_in, Jacobian6<T>& J) {
  J.resize(6, s.dof);
  for (int i = 0; i < s.dof; ++i) {
    // DH: joint i turns about z of frame i-1; MDH: about z of frame i.
    const Frame<T>& axis = s.convention == Convention::kDh ? frames[i] : frames[i + 1];
    const Vec3<T> z = axis.R.col(2);
    J.template block<3, 1>(0, i) = z.cross(T_meas_tool.p - axis.p);
    J.template block<3, 1>(3, i) = z;
  }
  if (expressed_in == JacobianFrame::kTool) {
    const Mat3<T> Rt = T_meas_tool.R.transpose();
    for (int i = 0; i < s.dof; ++i) {
      J.template block<3, 1>(0, i) = (Rt * J.template block<3, 1>(0, i)).eval();
      J.template block<3, 1>(3, i) = (Rt * J.template block<3, 1>(3, i)).eval();
    }
  }
}

// J_p_params: d p_meas / d params (3 x num_slots) of the tool point; columns of
// slots without meaning are zero. Analytic: a parameter that turns about an axis u
// through o moves p by u x (p - o); one that translates along u moves it by u.
// This overload takes the chain constants of `params`, for many samples.
template <typename T>
Vec3<T> position_parameter_jacobian(const ChainStructure& s, const ChainConstants<T>& constants,
                                    const T* params, const T* joint,
                                    Eigen::Matrix<T, 3, Eigen::Dynamic>& J_p_params) {
  using std::cos;
  using std::sin;
  assert(s.dof <= kMaxDof);
  std::array<Frame<T>, kMaxDof + 1> frames;
  const Vec3<T> p = forward_kinematics(s, constants, joint, frames.data()).p;
  J_p_params.setZero(3, s.num_slots());

  // Standard DH transform prev -> next, slots a, alpha, d, theta, beta. The x axis
  // after Rz(theta) is next's x with Ry(beta) undone: c_beta x_next + s_beta z_next.
  auto dh_columns = [&](const Frame<T>& prev, const Frame<T>& next, const T& cos_beta,
                        const T& sin_beta, int slot, bool with_beta) {
    const Vec3<T> z = prev.R.col(2);
    const Vec3<T> x = cos_beta * next.R.col(0) + sin_beta * next.R.col(2);
    J_p_params.col(slot + kLinkA) = x;
    J_p_params.col(slot + kLinkAlpha) = x.cross(p - next.p);
    J_p_params.col(slot + kLinkD) = z;
    J_p_params.col(slot + kLinkTheta) = z.cross(p - prev.p);
    if (with_beta) J_p_params.col(slot + kLinkBeta) = Vec3<T>(next.R.col(1)).cross(p - next.p);
  };

  const Frame<T>& B = frames[0];
  if (s.base_kind == BaseKind::kDh) {
    dh_columns(Frame<T>::Identity(), B, T(1), T(0), 0, false);
  } else {
    const Vec3<T> r = p - B.p;
    const T cy = cos(params[5]), sy = sin(params[5]);
    J_p_params.col(0) = Vec3<T>(T(1), T(0), T(0));
    J_p_params.col(1) = Vec3<T>(T(0), T(1), T(0));
    J_p_params.col(2) = Vec3<T>(T(0), T(0), T(1));
    J_p_params.col(3) = Vec3<T>(B.R.col(0)).cross(r);        // roll: x of Rz Ry
    J_p_params.col(4) = Vec3<T>(-sy, cy, T(0)).cross(r);     // pitch: y of Rz
    J_p_params.col(5) = Vec3<T>(T(0), T(0), T(1)).cross(r);  // yaw: z
  }
  for (int i = 0; i < s.dof; ++i) {
    const int slot = s.link_slot(i);
    const Frame<T>& prev = frames[i];
    const Frame<T>& next = frames[i + 1];
    const LinkConstants<T>& k = constants.links[i];
    if (s.convention == Convention::kDh) {
      dh_columns(prev, next, k.cos_beta, k.sin_beta, slot, true);
    } else {
      // Ry(beta) turns about y of prev * Rx(alpha) through the foot of the new
      // axis on the common normal, next.p - d z.
      const Vec3<T> x = prev.R.col(0);
      const Vec3<T> y = k.cos_alpha * prev.R.col(1) + k.sin_alpha * prev.R.col(2);
      const Vec3<T> z = next.R.col(2);
      J_p_params.col(slot + kLinkA) = x;
      J_p_params.col(slot + kLinkAlpha) = x.cross(p - prev.p);
      J_p_params.col(slot + kLinkD) = z;
      J_p_params.col(slot + kLinkTheta) = z.cross(p - next.p);
      J_p_params.col(slot + kLinkBeta) = y.cross(p - next.p + k.d * z);
    }
  }
  const Frame<T>& flange = frames[s.dof];
  for (int k = 0; k < 3; ++k) J_p_params.col(s.tool_slot() + k) = flange.R.col(k);
  return p;
}

template <typename T>
Vec3<T> position_parameter_jacobian(const ChainStructure& s, const T* params, const T* joint,
                                    Eigen::Matrix<T, 3, Eigen::Dynamic>& J_p_params) {
  return position_parameter_jacobian(s, chain_constants(s, params), params, joint, J_p_params);
}

// J_delta_params: d |p_meas| / d params (paper eq. 5), 1 x num_slots. Returns delta.
template <typename T>
T distance_parameter_jacobian(const ChainStructure& s, const T* params, const T* joint,
                              Eigen::Matrix<T, 1, Eigen::Dynamic>& J_delta_params) {
  Eigen::Matrix<T, 3, Eigen::Dynamic> J_p_params;
  const Vec3<T> p = position_parameter_jacobian(s, params, joint, J_p_params);
  const T delta = p.norm();
  J_delta_params = (p / delta).transpose() * J_p_params;
  return delta;
}

// The calibrated model in the form a 1 kHz controller uses: transmissions and
// constant link terms prepared once; no allocation per call.
class PreparedModel {
 public:
  explicit PreparedModel(const DeviceModel& model);

  int dof() const { return structure_.dof; }
  // q + dtheta(q) for the readings q (n values).
  void compensate(const double* q, double* joint) const;
  // T_meas_tool from the readings q.
  Frame<double> forward(const double* q) const;
  // T_meas_tool and the geometric Jacobian w.r.t. the joint angles.
  Frame<double> forward_jacobian(const double* q, JacobianFrame expressed_in,
                                 Jacobian6<double>& J) const;

 private:
  Frame<double> chain(const double* q, Frame<double>* frames) const;

  ChainStructure structure_;
  Frame<double> base_, tool_;
  std::vector<LinkConstants<double>> links_;
  std::vector<PreparedTransmission> transmissions_;
  std::vector<int> capstan_joints_;  // joints whose transmission is a capstan
};

}  // namespace hapticcal
