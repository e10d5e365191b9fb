// Forward kinematics T_meas_tool = B * A_1 ... A_n * T_tool, the
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
#include <memory>
#include <optional>
#include <vector>

#include "hapticcal/model/frame.hpp"
#include "hapticcal/model/model.hpp"
#include "hapticcal/model/transmission.hpp"

namespace hapticcal {

class JointEffect;

// In which frame the geometric Jacobian is expressed; the reference point is the
// tool point in both cases.
enum class JacobianFrame { kMeasurement, kTool };

template <typename T>
using Jacobian6 = Eigen::Matrix<T, 6, Eigen::Dynamic>;

// The parts of A_i that do not depend on the joint value.
//   DH:     A = Rz(theta) * T(a, 0, d) * Rx(alpha) * Ry(beta)
//   MDH:    A = Rx(alpha) * Tx(a) * Ry(beta) * Rz(theta) * Tz(d)
//   origin: A = Trans(xyz) * Rz(yaw) Ry(pitch) Rx(roll) * motion(axis)
// The joint value q + offset is theta (revolute DH, MDH), d (prismatic DH, MDH)
// or the turn / travel about / along the axis (origin). Each elementary rotation
// is applied to two columns only. apply_beta is false only where beta is exactly
// zero in a prepared double model; the generic path always applies Ry(beta) so
// that a Jet carries its derivative.
template <typename T>
struct LinkConstants {
  T a{0}, d{0}, offset{0};
  T cos_alpha{1}, sin_alpha{0}, cos_beta{1}, sin_beta{0};
  T cos_theta{1}, sin_theta{0};            // of a prismatic DH / MDH joint's constant theta
  Frame<T> origin = Frame<T>::Identity();  // origin geometry: Trans(xyz) * R(rpy)
  T cos_yaw{1}, sin_yaw{0};                // origin geometry
  bool apply_beta = true;
};

template <typename T>
LinkConstants<T> link_constants(const JointStructure& j, const T* slot) {
  using std::cos;
  using std::sin;
  LinkConstants<T> k;
  if (j.geometry == Geometry::kOrigin) {
    k.origin = pose_frame(slot[0], slot[1], slot[2], slot[3], slot[4], slot[5]);
    k.cos_yaw = cos(slot[kOriginYaw]);
    k.sin_yaw = sin(slot[kOriginYaw]);
    k.offset = slot[kOriginOffset];
    k.a = k.d = T(0);
    k.apply_beta = false;
    return k;
  }
  k.a = slot[kLinkA];
  k.d = slot[kLinkD];
  k.offset = j.prismatic() ? slot[kLinkD] : slot[kLinkTheta];
  k.cos_theta = cos(slot[kLinkTheta]);
  k.sin_theta = sin(slot[kLinkTheta]);
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
// R * Rot(u, theta) for a unit axis u (Rodrigues):
//   c R + s R [u]x + (1 - c) (R u) u^T.
template <typename T>
HAPTICCAL_INLINE void turn_axis(Mat3<T>& R, const std::array<double, 3>& u, const T& c,
                                const T& s) {
  if (u[0] == 0 && u[1] == 0 && u[2] == 1) return turn_z(R, c, s);
  const Vec3<T> Ru = R.col(0) * T(u[0]) + R.col(1) * T(u[1]) + R.col(2) * T(u[2]);
  Mat3<T> out;
  for (int k = 0; k < 3; ++k) {
    // column k of [u]x: e_k x ... = u x e_k with a sign: [u]x e_k = u x e_k.
    Vec3<T> e = Vec3<T>::Zero();
    e[k] = T(1);
    const Vec3<T> ux(T(u[1]) * e[2] - T(u[2]) * e[1], T(u[2]) * e[0] - T(u[0]) * e[2],
                     T(u[0]) * e[1] - T(u[1]) * e[0]);
    out.col(k) = c * R.col(k) + s * (R * ux) + (T(1) - c) * T(u[k]) * Ru;
  }
  R = out;
}

template <typename T>
HAPTICCAL_INLINE Vec3<T> axis_of(const Mat3<T>& R, const std::array<double, 3>& u) {
  return R.col(0) * T(u[0]) + R.col(1) * T(u[1]) + R.col(2) * T(u[2]);
}

// next = prev * A_i. c, s: cosine and sine of the joint's angle (revolute: of
// q + offset; prismatic DH / MDH: of the constant theta); length: d of a DH /
// MDH joint (prismatic: q + offset), the travel of a prismatic origin joint.
template <typename T>
HAPTICCAL_INLINE void compose_link(const JointStructure& j, const Frame<T>& prev,
                                   const LinkConstants<T>& k, const T& c, const T& s,
                                   const T& length, Frame<T>& next) {
  if (j.geometry == Geometry::kDh) {
    next.R = prev.R;
    turn_z(next.R, c, s);
    next.p = prev.p + k.a * next.R.col(0) + length * next.R.col(2);
    turn_x(next.R, k.cos_alpha, k.sin_alpha);
    if (k.apply_beta) turn_y(next.R, k.cos_beta, k.sin_beta);
  } else if (j.geometry == Geometry::kMdh) {
    next.R = prev.R;
    turn_x(next.R, k.cos_alpha, k.sin_alpha);
    next.p = prev.p + k.a * next.R.col(0);
    if (k.apply_beta) turn_y(next.R, k.cos_beta, k.sin_beta);
    next.p += length * next.R.col(2);
    turn_z(next.R, c, s);
  } else {
    next.R = prev.R * k.origin.R;
    next.p = prev.p + prev.R * k.origin.p;
    if (j.prismatic()) {
      next.p += length * axis_of(next.R, j.axis);
    } else {
      turn_axis(next.R, j.axis, c, s);
    }
  }
}

// compose_link for the joint value v = q + dtheta(q) (offset not yet added).
template <typename T>
HAPTICCAL_INLINE void compose_joint(const JointStructure& j, const Frame<T>& prev,
                                    const LinkConstants<T>& k, const T& v, Frame<T>& next) {
  using std::cos;
  using std::sin;
  const T value = v + k.offset;
  if (j.prismatic()) {
    compose_link(j, prev, k, k.cos_theta, k.sin_theta, value, next);
  } else {
    compose_link(j, prev, k, T(cos(value)), T(sin(value)), k.d, next);
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
  JointStructure dh;
  LinkConstants<T> k = link_constants(dh, slot);
  k.apply_beta = false;
  Frame<T> B;
  compose_link(dh, Frame<T>::Identity(), k, T(cos(params[3])), T(sin(params[3])), k.d, B);
  return B;
}

template <typename T>
Frame<T> tool_frame(const ChainStructure& s, const T* params) {
  const T* t = params + s.tool_slot();
  return pose_frame(t[0], t[1], t[2], t[3], t[4], t[5]);
}

// The parts of the chain that do not depend on the joint values, computed once
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
  for (int i = 0; i < s.dof; ++i) c.links[i] = link_constants(s.joints[i], params + s.link_slot(i));
  return c;
}

// T_meas_tool for joint = q + dtheta(q) (the offsets are added here). If frames is
// given it receives T_meas_i for i = 0..n (frame 0 is the base).
template <typename T>
Frame<T> forward_kinematics(const ChainStructure& s, const ChainConstants<T>& c, const T* joint,
                            Frame<T>* frames = nullptr) {
  std::array<Frame<T>, kMaxDof + 1> local;
  if (!frames) frames = local.data();
  frames[0] = c.base;
  for (int i = 0; i < s.dof; ++i) {
    compose_joint(s.joints[i], frames[s.before(i)], c.links[i], joint[i], frames[i + 1]);
  }
  return frames[s.last_frame()] * c.tool;
}

template <typename T>
Frame<T> forward_kinematics(const ChainStructure& s, const T* params, const T* joint,
                            Frame<T>* frames = nullptr) {
  return forward_kinematics(s, chain_constants(s, params), joint, frames);
}

// Joint i's axis (unit, measurement frame) and a point on it, from the frames of
// forward_kinematics: DH turns about z of frame i-1, MDH about z of frame i, an
// origin joint about its axis in frame i.
template <typename T>
HAPTICCAL_INLINE void joint_axis(const ChainStructure& s, const Frame<T>* frames, int i,
                                 Vec3<T>& axis, Vec3<T>& point) {
  const JointStructure& j = s.joints[i];
  if (j.geometry == Geometry::kDh) {
    axis = frames[s.before(i)].R.col(2);
    point = frames[s.before(i)].p;
  } else if (j.geometry == Geometry::kMdh) {
    axis = frames[i + 1].R.col(2);
    point = frames[i + 1].p;
  } else {
    axis = axis_of(frames[i + 1].R, j.axis);
    point = frames[i + 1].p;
  }
}

// Geometric Jacobian (6 x n, linear rows first) of the tool point with respect to
// the joint values, from the frames of forward_kinematics, into J already 6 x n
// (a Jacobian6 or a Map of a caller's buffer).
template <typename T, typename Derived>
void geometric_jacobian_into(const ChainStructure& s, const Frame<T>* frames,
                             const Frame<T>& T_meas_tool, JacobianFrame expressed_in,
                             Eigen::MatrixBase<Derived>& J) {
  assert(J.rows() == 6 && J.cols() == s.dof);
  for (int i = 0; i < s.dof; ++i) {
    Vec3<T> z, o;
    joint_axis(s, frames, i, z, o);
    if (s.joints[i].prismatic()) {
      J.template block<3, 1>(0, i) = z;
      J.template block<3, 1>(3, i).setZero();
    } else {
      J.template block<3, 1>(0, i) = z.cross(T_meas_tool.p - o);
      J.template block<3, 1>(3, i) = z;
    }
  }
  if (expressed_in == JacobianFrame::kTool) {
    const Mat3<T> Rt = T_meas_tool.R.transpose();
    for (int i = 0; i < s.dof; ++i) {
      J.template block<3, 1>(0, i) = (Rt * J.template block<3, 1>(0, i)).eval();
      J.template block<3, 1>(3, i) = (Rt * J.template block<3, 1>(3, i)).eval();
    }
  }
}

template <typename T>
void geometric_jacobian(const ChainStructure& s, const Frame<T>* frames,
                        const Frame<T>& T_meas_tool, JacobianFrame expressed_in, Jacobian6<T>& J) {
  J.resize(6, s.dof);
  geometric_jacobian_into(s, frames, T_meas_tool, expressed_in, J);
}

// J: d (p, w) / d params of the tool pose, Rows = 3 (position) or 6 (position,
// then the small rotation w of the tool frame, measurement frame), rows x
// num_slots. Analytic: a parameter that turns about an axis u through o moves p by
// u x (p - o) and turns the tool by u; one that translates along u moves p by u.
// This overload takes the chain constants of `params`, for many samples.
template <int Rows, typename T>
Frame<T> pose_parameter_jacobian(const ChainStructure& s, const ChainConstants<T>& constants,
                                 const T* params, const T* joint,
                                 Eigen::Matrix<T, Rows, Eigen::Dynamic>& J) {
  static_assert(Rows == 3 || Rows == 6);
  using std::cos;
  using std::sin;
  assert(s.dof <= kMaxDof);
  std::array<Frame<T>, kMaxDof + 1> frames;
  const Frame<T> tool = forward_kinematics(s, constants, joint, frames.data());
  const Vec3<T>& p = tool.p;
  J.setZero(Rows, s.num_slots());
  auto turn = [&](int slot, const Vec3<T>& u, const Vec3<T>& o) {
    J.template block<3, 1>(0, slot) = u.cross(p - o);
    if constexpr (Rows == 6) J.template block<3, 1>(3, slot) = u;
  };
  auto shift = [&](int slot, const Vec3<T>& u) { J.template block<3, 1>(0, slot) = u; };
  // Pose x, y, z, roll, pitch, yaw of a frame `at` = parent * pose.
  auto pose_columns = [&](int slot, const Mat3<T>& parent, const Frame<T>& at, const T& cos_yaw,
                          const T& sin_yaw) {
    for (int k = 0; k < 3; ++k) shift(slot + k, Vec3<T>(parent.col(k)));
    turn(slot + kOriginRoll, Vec3<T>(at.R.col(0)), at.p);
    turn(slot + kOriginPitch, Vec3<T>(cos_yaw * parent.col(1) - sin_yaw * parent.col(0)), at.p);
    turn(slot + kOriginYaw, Vec3<T>(parent.col(2)), at.p);
  };
  // Standard DH transform prev -> next, slots a, alpha, d, theta, beta. The x axis
  // after Rz(theta) is next's x with Ry(beta) undone: c_beta x_next + s_beta z_next.
  auto dh_columns = [&](const Frame<T>& prev, const Frame<T>& next, const T& cos_beta,
                        const T& sin_beta, int slot, bool with_beta) {
    const Vec3<T> z = prev.R.col(2);
    const Vec3<T> x = cos_beta * next.R.col(0) + sin_beta * next.R.col(2);
    shift(slot + kLinkA, x);
    turn(slot + kLinkAlpha, x, next.p);
    shift(slot + kLinkD, z);
    turn(slot + kLinkTheta, z, prev.p);
    if (with_beta) turn(slot + kLinkBeta, Vec3<T>(next.R.col(1)), next.p);
  };

  const Frame<T>& B = frames[0];
  if (s.base_kind == BaseKind::kDh) {
    dh_columns(Frame<T>::Identity(), B, T(1), T(0), 0, false);
  } else {
    pose_columns(0, Mat3<T>::Identity(), B, T(cos(params[5])), T(sin(params[5])));
  }
  for (int i = 0; i < s.dof; ++i) {
    const JointStructure& j = s.joints[i];
    const int slot = j.slot;
    const Frame<T>& prev = frames[s.before(i)];
    const Frame<T>& next = frames[i + 1];
    const LinkConstants<T>& k = constants.links[i];
    if (j.geometry == Geometry::kDh) {
      dh_columns(prev, next, k.cos_beta, k.sin_beta, slot, true);
    } else if (j.geometry == Geometry::kMdh) {
      // Ry(beta) turns about y of prev * Rx(alpha) through the foot of the new
      // axis on the common normal, next.p - d z.
      const Vec3<T> x = prev.R.col(0);
      const Vec3<T> y = k.cos_alpha * prev.R.col(1) + k.sin_alpha * prev.R.col(2);
      const Vec3<T> z = next.R.col(2);
      const T length = j.prismatic() ? T(joint[i] + k.offset) : k.d;
      shift(slot + kLinkA, x);
      turn(slot + kLinkAlpha, x, prev.p);
      shift(slot + kLinkD, z);
      turn(slot + kLinkTheta, z, next.p);
      turn(slot + kLinkBeta, y, Vec3<T>(next.p - length * z));
    } else {
      Frame<T> at;  // the joint frame before its motion
      at.R = prev.R * k.origin.R;
      at.p = prev.p + prev.R * k.origin.p;
      pose_columns(slot, prev.R, at, k.cos_yaw, k.sin_yaw);
      const Vec3<T> u = axis_of(at.R, j.axis);
      if (j.prismatic()) {
        shift(slot + kOriginOffset, u);
      } else {
        turn(slot + kOriginOffset, u, at.p);
      }
    }
  }
  const Frame<T>& flange = frames[s.dof];
  const T* t = params + s.tool_slot();
  pose_columns(s.tool_slot(), flange.R, tool, T(cos(t[5])), T(sin(t[5])));
  return tool;
}

// d p_meas / d params (3 x num_slots) of the tool point.
template <typename T>
Vec3<T> position_parameter_jacobian(const ChainStructure& s, const ChainConstants<T>& constants,
                                    const T* params, const T* joint,
                                    Eigen::Matrix<T, 3, Eigen::Dynamic>& J_p_params) {
  return pose_parameter_jacobian<3>(s, constants, params, joint, J_p_params).p;
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

// Gravity torques of the links' masses (joint compliance, issue 25) from the
// frames of forward_kinematics: tau_i = a_i . ((S_i - M_i o_i) x g) for a
// turning joint with axis a_i through o_i, M_i a_i . g for a sliding one, M_i
// and S_i the mass and first moment of links i..n (link j's centre com_j in
// frame j + 1), g `gravity` (base frame) turned into the measurement frame.
void gravity_torques(const ChainStructure& s, const Frame<double>* frames, const double* mass,
                     const Eigen::Vector3d* com, const Eigen::Vector3d& gravity, double* tau);

// Lateral compliance (Link::lateral_compliance): the slot a bend turns (DH,
// MDH: alpha; URDF origin: roll), and the axis and a point of that turn from
// the frames of forward_kinematics (DH: the x axis after Rz(theta) T(a, 0, d),
// through frame i + 1's origin; MDH: x of frame i, through its origin; URDF:
// x of the origin frame, through its origin): the alpha / roll columns' axes
// of pose_parameter_jacobian. A URDF joint whose axis is along its origin's x
// has its own turn for a bend (the lateral family leaves it out).
inline int lateral_slot(const JointStructure& j) {
  return j.geometry == Geometry::kOrigin ? kOriginRoll : kLinkAlpha;
}
void lateral_axis(const ChainStructure& s, const LinkConstants<double>& k,
                  const Frame<double>* frames, int i, Vec3<double>& axis, Vec3<double>& point);
// The link constants with the lateral slot turned by `turn` [rad] (what
// link_constants gives for the slot's value + turn).
void turn_laterally(const JointStructure& j, double turn, LinkConstants<double>& k);
// Each link's constants turned by its bend (dof values; 0: unbent).
inline void bend_links(const ChainStructure& s, const double* bend, LinkConstants<double>* links) {
  for (int i = 0; i < s.dof; ++i) {
    if (bend[i] != 0) turn_laterally(s.joints[i], bend[i], links[i]);
  }
}
// The gravity torques about each joint's lateral axis: tau_i = u_i . ((S_i -
// M_i o_i) x g), M_i and S_i as in gravity_torques (links i..n), u_i and o_i
// lateral_axis'.
void lateral_torques(const ChainStructure& s, const ChainConstants<double>& constants,
                     const Frame<double>* frames, const double* mass, const Eigen::Vector3d* com,
                     const Eigen::Vector3d& gravity, double* tau);

// A model's masses and compliances, prepared: the gravity torques at joint
// values (compensated, without offsets) and the deflection joint += k tau
// (compliance as compensate applies it: 0 for a link whose k step 2 fits);
// the lateral torques and the link constants bent by them (lateral: 0 for a
// link whose lateral compliance step 2 fits).
struct GravityModel {
  explicit GravityModel(const DeviceModel& model);
  void torques(const double* joint, double* tau) const;
  void deflect(double* joint) const;
  void lateral_torques(const double* joint, double* tau) const;
  // Each link's lateral bend c tau_x [rad] at joint values before any
  // deflection (PreparedModel::rigid_joints: the joint compliance's torques
  // and the bends come from one chain).
  void bends(const double* rigid_joint, double* bend) const;
  // The chain constants with each link bent so (rigid_joint as for bends).
  ChainConstants<double> pose_constants(const double* rigid_joint) const;
  // The bends from that chain's frames, applied to `links`.
  void bend(const Frame<double>* frames, LinkConstants<double>* links) const;
  bool lateral_any() const;

  ChainStructure structure;
  ChainConstants<double> constants;
  Eigen::Vector3d gravity;
  std::array<double, kMaxDof> mass{}, compliance{}, lateral{};
  std::array<Eigen::Vector3d, kMaxDof> com;
  bool any_lateral = false;     // some lateral[i] != 0
  bool any_compliance = false;  // some compliance[i] != 0
};

// The calibrated model in the form a 1 kHz controller uses: transmissions and
// constant link terms prepared once; no allocation per call.
class PreparedModel {
 public:
  explicit PreparedModel(const DeviceModel& model);

  int dof() const { return structure_.dof; }
  // A tree's tips (DeviceModel::tips; 1: a chain).
  int tips() const { return structure_.tips; }
  // The joint values q + dtheta(q) for the readings q (n values); coupled:
  // C (q + dtheta(q)) (DeviceModel::coupling).
  void compensate(const double* q, double* joint) const;
  // T_meas_tool from the readings q (a tree's: its first tip's).
  Frame<double> forward(const double* q) const;
  // T_meas_tool of tip `tip` of a tree (0 <= tip < tips(), else
  // std::out_of_range): every link's frame composed once on its parent's, then
  // the tip's link and tool.
  Frame<double> forward(const double* q, int tip) const;
  // Its geometric Jacobian w.r.t. the tree's joint values (zero columns for
  // the joints off the tip's path), into 6 x dof column-major storage.
  Frame<double> forward_jacobian(const double* q, int tip, JacobianFrame expressed_in,
                                 double* J_col_major) const;
  // T_meas_tool and the geometric Jacobian w.r.t. the joint values.
  Frame<double> forward_jacobian(const double* q, JacobianFrame expressed_in,
                                 Jacobian6<double>& J) const;
  // The same into a caller's buffer: J_col_major holds the 6 x n Jacobian
  // column by column (Jacobian6's storage). Allocates nothing.
  Frame<double> forward_jacobian(const double* q, JacobianFrame expressed_in,
                                 double* J_col_major) const;
  // d theta / d q = C diag(1 + dtheta_k'(q_k)) at the readings q: n x n,
  // column-major (diagonal unless the model is coupled). Allocates nothing.
  void reading_jacobian(const double* q, double* J_joint_reading_col_major) const;
  bool coupled() const { return !coupling_.empty(); }
  bool compliant() const { return gravity_ != nullptr; }
  // The joint values without a compliant model's deflection (the chain its
  // gravity torques and lateral bends are formed on).
  void rigid_joints(const double* q, double* joint) const;
  // A laterally compliant model's chain constants at the readings q, each
  // link bent (GravityModel::pose_constants at q's rigid joint values), for
  // kinematics formed from joint values moved otherwise (a backlash, the rows
  // of a fit); none for any other model, whose constants do not depend on q.
  std::optional<ChainConstants<double>> bent_constants(const double* q) const;

 private:
  void check_tip(int tip) const;  // std::out_of_range outside [0, tips())
  Frame<double> chain(const double* q, Frame<double>* frames) const;
  // dtheta_k(q_k) of every reading, the capstans' sines, cosines and arc
  // tangents in batches (the coupled path's compensation).
  void transmission_errors(const double* q, double* error) const;
  // joint += k tau(joint) (a compliant model).
  void deflect(double* joint) const;
  Frame<double> compliant_chain(const double* q, Frame<double>* frames) const;
  // Each joint's cos and sin of theta and its length from joint values.
  void joint_angles(const double* joint, double* cos_theta, double* sin_theta,
                    double* length) const;
  // The chain from joint values (compensated, without offsets): the coupled path.
  Frame<double> chain_from_joints(const double* joint, Frame<double>* frames) const;
  // The frames from each joint's cos and sin of theta and its length (d of a
  // revolute joint; d + q of a prismatic one).
  // The same with each link bent laterally, the bends formed from `frames`
  // (the undeflected chain's), which it then overwrites.
  Frame<double> compose_bent(const double* cos_theta, const double* sin_theta, const double* length,
                             Frame<double>* frames) const;
  // `links`: the link constants to use (a bent chain's), or the model's.
  Frame<double> compose(const double* cos_theta, const double* sin_theta, const double* length,
                        Frame<double>* frames, const LinkConstants<double>* links = nullptr) const;

  ChainStructure structure_;
  Frame<double> base_, tool_;
  // A tree's: each tip's tool (tool_ is the first's) and the links on its path.
  std::vector<Frame<double>> tip_tools_;
  std::vector<std::vector<int>> tip_paths_;
  std::vector<LinkConstants<double>> links_;
  std::vector<PreparedTransmission> transmissions_;
  std::vector<int> capstan_joints_;  // revolute joints whose transmission is a capstan
  // A coupled model's C as (joint, reading, coefficient) terms, row by row; empty: C = I.
  struct CouplingTerm {
    int joint, reading;
    double coefficient;
  };
  std::vector<CouplingTerm> coupling_;
  // The joint effects (model/joint_effect.hpp): c f(q_joint) added to a
  // reading's value where its transmission's error is.
  struct EffectTerm {
    int joint;
    const JointEffect* effect;
    double c;
  };
  std::vector<EffectTerm> effects_;
  // 1 + dtheta_k'(q_k) + the effects' slopes: each reading's own slope.
  void reading_slopes(const double* q, double* slope) const;
  std::shared_ptr<const GravityModel> gravity_;  // a compliant model's; else null
  // kDh / kMdh: every joint revolute with that geometry (the register recursion);
  // else per joint through compose_link.
  enum class Path { kDh, kMdh, kGeneric } path_ = Path::kGeneric;
};

// Where a reach moves the tool point (in the measurement frame): onto a point,
// or onto the plane n . p = c (n a unit normal).
struct ToolTarget {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  double offset = 0;  // c
  bool plane = false;

  static ToolTarget at(const Eigen::Vector3d& p) { return {p, Eigen::Vector3d::Zero(), 0, false}; }
  static ToolTarget on_plane(const Eigen::Vector3d& n, double c) {
    return {Eigen::Vector3d::Zero(), n, c, true};
  }
};

struct ReachOptions {
  int max_steps = 100;
  double damping = 1e-10;    // lambda of the damped least squares [m^2]
  double tolerance = 1e-12;  // m: stop once the tool point is this close
};

struct ReachResult {
  Eigen::VectorXd q;     // the readings reached
  double error = 0;      // distance of the tool point from its target (point or plane) [m]
  bool reached = false;  // error <= tolerance
};

// Readings near `q` that put `model`'s tool point on `target`: damped least
// squares on the position Jacobian, q += A^T (A A^T + lambda I)^-1 e, with e
// the error (target - p, or c - n . p for a plane) and A its rows of J_p (for a
// plane n^T J_p). The Jacobian is w.r.t. the compensated angles (through a
// coupling's C, ignoring the transmissions' slopes), near enough for the steps. Joint limits are
// not imposed: the caller checks them.
ReachResult reach(const PreparedModel& model, const Eigen::VectorXd& q, const ToolTarget& target,
                  const ReachOptions& options = {});

}  // namespace hapticcal
