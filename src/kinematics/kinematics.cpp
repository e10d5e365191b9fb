#include "hapticcal/kinematics/kinematics.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <stdexcept>
#include <string>

#include "hapticcal/model/joint_effect.hpp"
#include "kinematics/fast_math.hpp"

namespace hapticcal {
namespace {

// A 3-vector of plain doubles: the running frame of the prepared recursion is
// held in five of these so that the compiler keeps it in registers.
struct V3 {
  double x, y, z;
};
inline V3 operator*(double a, const V3& v) { return {a * v.x, a * v.y, a * v.z}; }
inline V3 operator+(const V3& u, const V3& v) { return {u.x + v.x, u.y + v.y, u.z + v.z}; }
inline V3 operator-(const V3& u, const V3& v) { return {u.x - v.x, u.y - v.y, u.z - v.z}; }

// sincos_batch of x[0, n), which the caller has written: GCC cannot follow
// that through the std::array and warns of an uninitialised read.
inline void sincos_written(const double* x, double* s, double* c, int n) {
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
  sincos_batch(x, s, c, n);
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif
}

// (c, s), the cosine and sine of an angle, turned by `turn`: a small-angle
// rotation for |turn| <= 0.1, else afresh from the turned angle `turned`.
inline void turn_angle(double turn, double turned, double& c, double& s) {
  if (std::abs(turn) <= 0.1) {
    double st, ct;
    small_angle_sincos(turn, st, ct);
    const double c0 = c;
    c = c0 * ct - s * st;
    s = s * ct + c0 * st;
  } else {
    c = std::cos(turned);
    s = std::sin(turned);
  }
}

}  // namespace

Eigen::Vector3d matrix_rpy(const Eigen::Matrix3d& R) {
  // R = Rz(y) Ry(p) Rx(r): R(2,0) = -sin p, R(2,1) = cos p sin r, R(1,0) = sin y cos p.
  const double pitch = std::atan2(-R(2, 0), std::hypot(R(0, 0), R(1, 0)));
  const double roll = std::atan2(R(2, 1), R(2, 2));
  const double yaw = std::atan2(R(1, 0), R(0, 0));
  return {roll, pitch, yaw};
}

PreparedModel::PreparedModel(const DeviceModel& model) : structure_(model.structure()) {
  assert(structure_.dof <= kMaxDof);
  const Eigen::VectorXd params = model.kinematic_parameters();
  base_ = base_frame(structure_, params.data());
  tool_ = tool_frame(structure_, params.data());
  bool all_dh = true, all_mdh = true;
  for (int i = 0; i < structure_.dof; ++i) {
    const JointStructure& j = structure_.joints[i];
    LinkConstants<double> k = link_constants(j, params.data() + structure_.link_slot(i));
    k.apply_beta = j.geometry != Geometry::kOrigin && model.links[i].beta != 0.0;
    links_.push_back(k);
    transmissions_.emplace_back(model.links[i].transmission);
    if (transmissions_.back().is_capstan() && !j.prismatic()) capstan_joints_.push_back(i);
    all_dh = all_dh && j.geometry == Geometry::kDh && !j.prismatic();
    all_mdh = all_mdh && j.geometry == Geometry::kMdh && !j.prismatic();
  }
  path_ = all_dh ? Path::kDh : all_mdh ? Path::kMdh : Path::kGeneric;
  if (structure_.tips > 1) {  // the register recursions run down one chain
    path_ = Path::kGeneric;
    for (int k = 0; k < structure_.tips; ++k) {
      tip_tools_.push_back(tool_frame(structure_.tip(k), params.data()));
      std::array<int, kMaxDof> links;
      tip_paths_.emplace_back(links.begin(), links.begin() + structure_.path(k, links.data()));
    }
  }
  if (model.compliant() || model.laterally_compliant())
    gravity_ = std::make_shared<const GravityModel>(model);
  if (model.coupled()) {
    for (int i = 0; i < structure_.dof; ++i) {
      for (int k = 0; k < structure_.dof; ++k) {
        if (model.coupling(i, k) != 0) coupling_.push_back({i, k, model.coupling(i, k)});
      }
    }
  }
  for (int i = 0; i < structure_.dof; ++i) {
    for (const auto& [name, c] : model.links[i].effects) {
      const JointEffect* effect = find_joint_effect(name);
      if (!effect) throw std::invalid_argument("joint effect '" + name + "' is not registered");
      effects_.push_back({i, effect, c});
    }
  }
}

void PreparedModel::compensate(const double* q, double* joint) const {
  rigid_joints(q, joint);
  if (gravity_ && gravity_->any_compliance) deflect(joint);
}

std::optional<ChainConstants<double>> PreparedModel::bent_constants(const double* q) const {
  if (!gravity_ || !gravity_->lateral_any()) return std::nullopt;
  std::array<double, kMaxDof> rigid;
  rigid_joints(q, rigid.data());
  return gravity_->pose_constants(rigid.data());
}

void PreparedModel::rigid_joints(const double* q, double* joint) const {
  const int n = structure_.dof;
  if (coupling_.empty() && !gravity_ && effects_.empty()) {
    for (int i = 0; i < n; ++i) joint[i] = q[i] + transmissions_[i].error(q[i]);
    return;
  }
  std::array<double, kMaxDof> u;  // each reading through its own transmission and effects
  transmission_errors(q, u.data());
  for (int k = 0; k < n; ++k) u[k] += q[k];
  for (const EffectTerm& e : effects_) u[e.joint] += e.c * e.effect->feature(q[e.joint]);
  if (coupling_.empty()) {
    std::copy(u.begin(), u.begin() + n, joint);
  } else {
    for (int i = 0; i < n; ++i) joint[i] = 0;
    for (const CouplingTerm& t : coupling_) joint[t.joint] += t.coefficient * u[t.reading];
  }
}

// The gravity torques from the prepared chain's frames at the undeflected
// joint values (the same frames as forward_kinematics'), then joint += k tau.
void PreparedModel::deflect(double* joint) const {
  if (structure_.tips > 1) return gravity_->deflect(joint);  // a tree: every branch's frames
  std::array<Frame<double>, kMaxDof + 1> frames;
  chain_from_joints(joint, frames.data());
  std::array<double, kMaxDof> tau;
  const GravityModel& g = *gravity_;
  gravity_torques(structure_, frames.data(), g.mass.data(), g.com.data(), g.gravity, tau.data());
  for (int i = 0; i < structure_.dof; ++i) joint[i] += g.compliance[i] * tau[i];
}

void PreparedModel::transmission_errors(const double* q, double* error) const {
  const int n = structure_.dof;
  const int m = 2 * static_cast<int>(capstan_joints_.size());
  std::array<double, 2 * kMaxDof> x, s, c, t, at;
  for (int j = 0; j < m / 2; ++j) {
    const int i = capstan_joints_[j];
    x[2 * j] = q[i];
    x[2 * j + 1] = transmissions_[i].ratio() * q[i];
  }
  sincos_written(x.data(), s.data(), c.data(), m);
  for (int j = 0; j < m / 2; ++j) {
    transmissions_[capstan_joints_[j]].capstan_tangents(s[2 * j], c[2 * j], s[2 * j + 1],
                                                        c[2 * j + 1], t[2 * j], t[2 * j + 1]);
  }
  atan_batch(t.data(), at.data(), m);
  for (int i = 0, j = 0; i < n; ++i) {
    if (j < m / 2 && capstan_joints_[j] == i) {
      error[i] = transmissions_[i].capstan_error(q[i], at[2 * j], at[2 * j + 1]);
      ++j;
    } else {
      error[i] = transmissions_[i].error(q[i]);
    }
  }
}

void PreparedModel::reading_jacobian(const double* q, double* J_joint_reading) const {
  const int n = structure_.dof;
  if (gravity_ && gravity_->any_compliance) {  // the deflection's slope by central differences
    const double h = 1e-6;
    std::array<double, kMaxDof> q_step, plus, minus;
    std::copy(q, q + n, q_step.begin());
    for (int k = 0; k < n; ++k) {
      q_step[k] = q[k] + h;
      compensate(q_step.data(), plus.data());
      q_step[k] = q[k] - h;
      compensate(q_step.data(), minus.data());
      q_step[k] = q[k];
      for (int i = 0; i < n; ++i) J_joint_reading[k * n + i] = (plus[i] - minus[i]) / (2 * h);
    }
    return;
  }
  std::fill(J_joint_reading, J_joint_reading + n * n, 0.0);
  std::array<double, kMaxDof> slope;
  reading_slopes(q, slope.data());
  if (coupling_.empty()) {
    for (int i = 0; i < n; ++i) J_joint_reading[i * n + i] = slope[i];
    return;
  }
  for (const CouplingTerm& t : coupling_)
    J_joint_reading[t.reading * n + t.joint] += t.coefficient * slope[t.reading];
}

void PreparedModel::reading_slopes(const double* q, double* slope) const {
  for (int k = 0; k < structure_.dof; ++k) slope[k] = 1 + transmissions_[k].derivative(q[k]);
  for (const EffectTerm& e : effects_) slope[e.joint] += e.c * e.effect->slope(q[e.joint]);
}

void PreparedModel::joint_angles(const double* joint, double* cos_theta, double* sin_theta,
                                 double* length) const {
  const int n = structure_.dof;
  std::array<double, kMaxDof> x, s, c;
  std::array<int, kMaxDof> slot;
  int used = 0;
  for (int i = 0; i < n; ++i) {
    if (structure_.joints[i].prismatic()) continue;
    x[used] = joint[i] + links_[i].offset;
    slot[i] = used++;
  }
  sincos_written(x.data(), s.data(), c.data(), used);
  for (int i = 0; i < n; ++i) {
    if (structure_.joints[i].prismatic()) {
      cos_theta[i] = links_[i].cos_theta;
      sin_theta[i] = links_[i].sin_theta;
      length[i] = joint[i] + links_[i].offset;
    } else {
      cos_theta[i] = c[slot[i]];
      sin_theta[i] = s[slot[i]];
      length[i] = links_[i].d;
    }
  }
}

Frame<double> PreparedModel::chain_from_joints(const double* joint, Frame<double>* frames) const {
  std::array<double, kMaxDof> cos_theta, sin_theta, length;
  joint_angles(joint, cos_theta.data(), sin_theta.data(), length.data());
  return compose(cos_theta.data(), sin_theta.data(), length.data(), frames);
}

// A compliant model's chain: the undeflected chain's frames give the gravity
// torques; each joint then turns by its small deflection k tau, its cosine and
// sine turned from the undeflected ones (no second batch of sines), and the
// chain is composed again.
Frame<double> PreparedModel::compliant_chain(const double* q, Frame<double>* frames) const {
  const int n = structure_.dof;
  std::array<double, kMaxDof> joint, cos_theta, sin_theta, length, tau;
  rigid_joints(q, joint.data());
  joint_angles(joint.data(), cos_theta.data(), sin_theta.data(), length.data());
  compose(cos_theta.data(), sin_theta.data(), length.data(), frames);
  const GravityModel& g = *gravity_;
  gravity_torques(structure_, frames, g.mass.data(), g.com.data(), g.gravity, tau.data());
  for (int i = 0; i < n; ++i) {
    const double turn = g.compliance[i] * tau[i];
    if (structure_.joints[i].prismatic()) {
      length[i] += turn;
    } else {
      turn_angle(turn, joint[i] + turn + links_[i].offset, cos_theta[i], sin_theta[i]);
    }
  }
  // The lateral bends from the same (undeflected) chain, whose frames these still are.
  if (g.lateral_any())
    return compose_bent(cos_theta.data(), sin_theta.data(), length.data(), frames);
  return compose(cos_theta.data(), sin_theta.data(), length.data(), frames);
}

Frame<double> PreparedModel::compose_bent(const double* cos_theta, const double* sin_theta,
                                          const double* length, Frame<double>* frames) const {
  std::array<LinkConstants<double>, kMaxDof> bent;
  std::copy(links_.begin(), links_.end(), bent.begin());
  gravity_->bend(frames, bent.data());
  return compose(cos_theta, sin_theta, length, frames, bent.data());
}

// The transcendental functions of all joints are evaluated in one batch: sin
// and cos of q and R q of every capstan joint and of the angles of the other
// joints; then the arc tangents of eq. (1). A capstan joint's angle
// theta = q + (error + offset) is turned from (cos q, sin q) by that small angle.
Frame<double> PreparedModel::chain(const double* q, Frame<double>* frames) const {
  if (gravity_) return compliant_chain(q, frames);
  if (!coupling_.empty() || !effects_.empty()) {
    std::array<double, kMaxDof> joint;
    compensate(q, joint.data());
    return chain_from_joints(joint.data(), frames);
  }
  const int n = structure_.dof;
  const int m = 2 * static_cast<int>(capstan_joints_.size());
  std::array<double, 2 * kMaxDof> x, s, c, t, at;  // first m + (n - m / 2) entries used
  std::array<int, kMaxDof> slot;                   // where joint i's angle sits in x
  int used = m;
  for (int j = 0; j < m / 2; ++j) {
    const int i = capstan_joints_[j];
    x[2 * j] = q[i];
    x[2 * j + 1] = transmissions_[i].ratio() * q[i];
    slot[i] = 2 * j;
  }
  for (int i = 0, j = 0; i < n; ++i) {
    if (j < m / 2 && capstan_joints_[j] == i) {
      ++j;
      continue;
    }
    if (structure_.joints[i].prismatic()) continue;
    x[used] = q[i] + transmissions_[i].error(q[i]) + links_[i].offset;
    slot[i] = used++;
  }
  sincos_written(x.data(), s.data(), c.data(), used);
  for (int j = 0; j < m / 2; ++j) {
    transmissions_[capstan_joints_[j]].capstan_tangents(s[2 * j], c[2 * j], s[2 * j + 1],
                                                        c[2 * j + 1], t[2 * j], t[2 * j + 1]);
  }
  atan_batch(t.data(), at.data(), m);

  std::array<double, kMaxDof> cos_theta, sin_theta, length;
  for (int i = 0; i < n; ++i) {
    if (structure_.joints[i].prismatic()) {
      cos_theta[i] = links_[i].cos_theta;
      sin_theta[i] = links_[i].sin_theta;
      length[i] = q[i] + transmissions_[i].error(q[i]) + links_[i].offset;
    } else {
      cos_theta[i] = c[slot[i]];
      sin_theta[i] = s[slot[i]];
      length[i] = links_[i].d;
    }
  }
  for (int j = 0; j < m / 2; ++j) {
    const int i = capstan_joints_[j];
    const double turn =
        transmissions_[i].capstan_error(q[i], at[2 * j], at[2 * j + 1]) + links_[i].offset;
    cos_theta[i] = c[2 * j];
    sin_theta[i] = s[2 * j];
    turn_angle(turn, q[i] + turn, cos_theta[i], sin_theta[i]);  // a large offset: afresh
  }
  return compose(cos_theta.data(), sin_theta.data(), length.data(), frames);
}

Frame<double> PreparedModel::compose(const double* cos_theta, const double* sin_theta,
                                     const double* length, Frame<double>* frames,
                                     const LinkConstants<double>* links) const {
  const int n = structure_.dof;
  if (!links) links = links_.data();
  frames[0] = base_;
  if (path_ == Path::kGeneric) {  // a tree's links each on its parent's frame
    for (int i = 0; i < n; ++i) {
      compose_link(structure_.joints[i], frames[structure_.before(i)], links[i], cos_theta[i],
                   sin_theta[i], length[i], frames[i + 1]);
    }
    return frames[structure_.last_frame()] * tool_;
  }
  // compose_link's column operations on a running frame held in registers
  // (columns ex, ey, ez and origin o); frames[] is only written.
  V3 ex{base_.R(0, 0), base_.R(1, 0), base_.R(2, 0)};
  V3 ey{base_.R(0, 1), base_.R(1, 1), base_.R(2, 1)};
  V3 ez{base_.R(0, 2), base_.R(1, 2), base_.R(2, 2)};
  V3 o{base_.p[0], base_.p[1], base_.p[2]};
  const bool dh = path_ == Path::kDh;
  for (int i = 0; i < n; ++i) {
    const LinkConstants<double>& k = links[i];
    const double ct = cos_theta[i], st = sin_theta[i];
    if (dh) {
      const V3 ex1 = ct * ex + st * ey, ey1 = ct * ey - st * ex;  // Rz(theta)
      o = o + k.a * ex1 + k.d * ez;                               // T(a, 0, d)
      const V3 ey2 = k.cos_alpha * ey1 + k.sin_alpha * ez,
               ez2 = k.cos_alpha * ez - k.sin_alpha * ey1;  // Rx
      ex = ex1;
      ey = ey2;
      ez = ez2;
      if (k.apply_beta) {  // Ry(beta)
        const V3 ex3 = k.cos_beta * ex - k.sin_beta * ez, ez3 = k.sin_beta * ex + k.cos_beta * ez;
        ex = ex3;
        ez = ez3;
      }
    } else {
      const V3 ey1 = k.cos_alpha * ey + k.sin_alpha * ez;  // Rx
      V3 ez1 = k.cos_alpha * ez - k.sin_alpha * ey;
      o = o + k.a * ex;    // Tx(a)
      if (k.apply_beta) {  // Ry(beta)
        const V3 ex1 = k.cos_beta * ex - k.sin_beta * ez1;
        ez1 = k.sin_beta * ex + k.cos_beta * ez1;
        ex = ex1;
      }
      o = o + k.d * ez1;                                            // Tz(d)
      const V3 ex2 = ct * ex + st * ey1, ey2 = ct * ey1 - st * ex;  // Rz(theta)
      ex = ex2;
      ey = ey2;
      ez = ez1;
    }
    Frame<double>& f = frames[i + 1];
    f.R << ex.x, ey.x, ez.x, ex.y, ey.y, ez.y, ex.z, ey.z, ez.z;
    f.p << o.x, o.y, o.z;
  }
  return frames[n] * tool_;
}

Frame<double> PreparedModel::forward(const double* q) const {
  std::array<Frame<double>, kMaxDof + 1> frames;
  return chain(q, frames.data());
}

Frame<double> PreparedModel::forward_jacobian(const double* q, JacobianFrame expressed_in,
                                              Jacobian6<double>& J) const {
  J.resize(6, structure_.dof);
  return forward_jacobian(q, expressed_in, J.data());
}

void PreparedModel::check_tip(int tip) const {
  if (tip < 0 || tip >= structure_.tips)
    throw std::out_of_range("tip " + std::to_string(tip) + " of a model with " +
                            std::to_string(structure_.tips) + " tip(s)");
}

Frame<double> PreparedModel::forward(const double* q, int tip) const {
  check_tip(tip);
  std::array<Frame<double>, kMaxDof + 1> frames;
  const Frame<double> first = chain(q, frames.data());
  if (tip == 0) return first;
  return frames[structure_.tip_link[tip] + 1] * tip_tools_[tip];
}

Frame<double> PreparedModel::forward_jacobian(const double* q, int tip, JacobianFrame expressed_in,
                                              double* J_col_major) const {
  check_tip(tip);
  if (structure_.tips == 1) return forward_jacobian(q, expressed_in, J_col_major);
  std::array<Frame<double>, kMaxDof + 1> frames;
  chain(q, frames.data());
  const Frame<double> T_meas_tool = frames[structure_.tip_link[tip] + 1] * tip_tools_[tip];
  const int n = structure_.dof;
  Eigen::Map<Jacobian6<double>> J(J_col_major, 6, n);
  geometric_jacobian_into(structure_, frames.data(), T_meas_tool, expressed_in, J);
  std::array<bool, kMaxDof> on_path{};
  for (int i : tip_paths_[static_cast<size_t>(tip)]) on_path[i] = true;
  for (int i = 0; i < n; ++i) {
    if (!on_path[i]) J.col(i).setZero();
  }
  return T_meas_tool;
}

Frame<double> PreparedModel::forward_jacobian(const double* q, JacobianFrame expressed_in,
                                              double* J_col_major) const {
  if (structure_.tips > 1) return forward_jacobian(q, 0, expressed_in, J_col_major);
  std::array<Frame<double>, kMaxDof + 1> frames;
  const Frame<double> T_meas_tool = chain(q, frames.data());
  // geometric_jacobian in plain doubles, written straight into J's storage: 2511
  // instead of 2986 instructions per FK + Jacobian call (callgrind, 7-DOF) on
  // the controller's hot path. Both are checked against KDL.
  const int n = structure_.dof;
  if (path_ == Path::kGeneric) {
    Eigen::Map<Jacobian6<double>> J(J_col_major, 6, n);
    geometric_jacobian_into(structure_, frames.data(), T_meas_tool, expressed_in, J);
    return T_meas_tool;
  }
  const int shift = path_ == Path::kDh ? 0 : 1;
  const Eigen::Matrix3d Rt = T_meas_tool.R.transpose();
  const bool in_tool = expressed_in == JacobianFrame::kTool;
  const double pe[3] = {T_meas_tool.p[0], T_meas_tool.p[1], T_meas_tool.p[2]};
  for (int i = 0; i < n; ++i) {
    const Frame<double>& axis = frames[i + shift];
    const double z[3] = {axis.R(0, 2), axis.R(1, 2), axis.R(2, 2)};
    const double r[3] = {pe[0] - axis.p[0], pe[1] - axis.p[1], pe[2] - axis.p[2]};
    double* col = J_col_major + 6 * i;
    col[0] = z[1] * r[2] - z[2] * r[1];
    col[1] = z[2] * r[0] - z[0] * r[2];
    col[2] = z[0] * r[1] - z[1] * r[0];
    col[3] = z[0];
    col[4] = z[1];
    col[5] = z[2];
    if (in_tool) {
      Eigen::Map<Eigen::Vector3d> linear(col), angular(col + 3);
      linear = (Rt * linear).eval();
      angular = (Rt * angular).eval();
    }
  }
  return T_meas_tool;
}

ReachResult reach(const PreparedModel& model, const Eigen::VectorXd& q, const ToolTarget& target,
                  const ReachOptions& options) {
  ReachResult out;
  out.q = q;
  Jacobian6<double> J(6, model.dof());
  Eigen::MatrixXd J_joint_reading(model.dof(), model.dof());
  auto error_at = [&](const Eigen::Vector3d& p) {
    return target.plane ? std::abs(target.offset - target.normal.dot(p))
                        : (target.point - p).norm();
  };
  for (int step = 0; step < options.max_steps; ++step) {
    const Eigen::Vector3d p =
        model.forward_jacobian(out.q.data(), JacobianFrame::kMeasurement, J).p;
    if (error_at(p) < options.tolerance) break;
    if (model.coupled()) {  // the steps are in the readings: J d theta / d q
      model.reading_jacobian(out.q.data(), J_joint_reading.data());
      J = (J * J_joint_reading).eval();
    }
    if (target.plane) {
      const Eigen::RowVectorXd a = target.normal.transpose() * J.topRows<3>();
      out.q += a.transpose() *
               ((target.offset - target.normal.dot(p)) / (a.squaredNorm() + options.damping));
    } else {
      const Eigen::Matrix<double, 3, Eigen::Dynamic> Jp = J.topRows<3>();
      out.q +=
          Jp.transpose() * (Jp * Jp.transpose() + options.damping * Eigen::Matrix3d::Identity())
                               .ldlt()
                               .solve(target.point - p);
    }
  }
  out.error = error_at(model.forward(out.q.data()).p);
  out.reached = out.error <= options.tolerance;
  return out;
}

}  // namespace hapticcal
