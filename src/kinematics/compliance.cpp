// Joint compliance: gravity torques from the links' masses and the deflection
// k tau they cause (GravityModel), which DeviceModel::compensate adds to the
// joint values (joint_values.cpp).
#include <algorithm>
#include <array>
#include <cmath>

#include "hapticcal/kinematics/kinematics.hpp"

namespace hapticcal {

namespace {

// The mass a joint carries and its first moment: of the links after it on a
// chain, of its subtree on a tree (each link's added to its parent's, from the
// last link back: a parent comes before its children).
class CarriedMass {
 public:
  CarriedMass(const ChainStructure& s, const Frame<double>* frames, const double* mass,
              const Eigen::Vector3d* com)
      : s_(s), frames_(frames), mass_(mass), com_(com) {
    if (s.tips > 1) {
      std::fill(M_.begin(), M_.begin() + s.dof, 0.0);
      std::fill(S_.begin(), S_.begin() + s.dof, Eigen::Vector3d::Zero());
    }
  }
  // Link i's (called for i = dof - 1 down to 0).
  void add(int i, double& M, Eigen::Vector3d& S) {
    const Eigen::Vector3d own = mass_[i] * (frames_[i + 1].R * com_[i] + frames_[i + 1].p);
    if (s_.tips == 1) {  // a chain: links i..n
      chain_M_ += mass_[i];
      chain_S_ += own;
      M = chain_M_;
      S = chain_S_;
      return;
    }
    M_[i] += mass_[i];
    S_[i] += own;
    M = M_[i];
    S = S_[i];
    if (const int p = s_.parent[i]; p >= 0) {
      M_[p] += M_[i];
      S_[p] += S_[i];
    }
  }

 private:
  const ChainStructure& s_;
  const Frame<double>* frames_;
  const double* mass_;
  const Eigen::Vector3d* com_;
  double chain_M_ = 0;
  Eigen::Vector3d chain_S_ = Eigen::Vector3d::Zero();
  std::array<double, kMaxDof> M_;
  std::array<Eigen::Vector3d, kMaxDof> S_;
};

}  // namespace

void gravity_torques(const ChainStructure& s, const Frame<double>* frames, const double* mass,
                     const Eigen::Vector3d* com, const Eigen::Vector3d& gravity, double* tau) {
  const Eigen::Vector3d g = frames[0].R * gravity;  // in the measurement frame
  CarriedMass carried(s, frames, mass, com);
  double M = 0;                                 // the mass joint i carries
  Eigen::Vector3d S = Eigen::Vector3d::Zero();  // its first moment
  for (int i = s.dof - 1; i >= 0; --i) {
    carried.add(i, M, S);
    Vec3<double> axis, point;
    joint_axis(s, frames, i, axis, point);
    tau[i] = s.joints[i].prismatic() ? M * axis.dot(g) : axis.dot((S - M * point).cross(g));
  }
}

void lateral_axis(const ChainStructure& s, const LinkConstants<double>& k,
                  const Frame<double>* frames, int i, Vec3<double>& axis, Vec3<double>& point) {
  const JointStructure& j = s.joints[i];
  if (j.geometry == Geometry::kDh) {
    axis = k.cos_beta * frames[i + 1].R.col(0) + k.sin_beta * frames[i + 1].R.col(2);
    point = frames[i + 1].p;
  } else if (j.geometry == Geometry::kMdh) {
    axis = frames[s.before(i)].R.col(0);
    point = frames[s.before(i)].p;
  } else {
    const Frame<double>& before = frames[s.before(i)];
    axis = before.R * k.origin.R.col(0);
    point = before.p + before.R * k.origin.p;
  }
}

void turn_laterally(const JointStructure& j, double turn, LinkConstants<double>& k) {
  const double c = std::cos(turn), s = std::sin(turn);
  if (j.geometry == Geometry::kOrigin) {
    turn_x(k.origin.R, c, s);  // Rz Ry Rx(roll) Rx(turn)
    return;
  }
  const double c0 = k.cos_alpha;
  k.cos_alpha = c0 * c - k.sin_alpha * s;
  k.sin_alpha = k.sin_alpha * c + c0 * s;
}

void lateral_torques(const ChainStructure& s, const ChainConstants<double>& constants,
                     const Frame<double>* frames, const double* mass, const Eigen::Vector3d* com,
                     const Eigen::Vector3d& gravity, double* tau) {
  const Eigen::Vector3d g = frames[0].R * gravity;
  CarriedMass carried(s, frames, mass, com);
  double M = 0;
  Eigen::Vector3d S = Eigen::Vector3d::Zero();
  for (int i = s.dof - 1; i >= 0; --i) {
    carried.add(i, M, S);
    Vec3<double> axis, point;
    lateral_axis(s, constants.links[i], frames, i, axis, point);
    tau[i] = axis.dot((S - M * point).cross(g));
  }
}

GravityModel::GravityModel(const DeviceModel& model) : structure(model.structure()) {
  const Eigen::VectorXd p = model.kinematic_parameters();
  constants = chain_constants(structure, p.data());
  gravity = model.gravity;
  for (int i = 0; i < model.dof(); ++i) {
    mass[i] = model.links[i].mass;
    com[i] = model.links[i].com;
    compliance[i] = model.compliance_fitted(i) ? 0.0 : model.links[i].compliance;
    lateral[i] = model.fitted_element("lateral", i) ? 0.0 : model.links[i].lateral_compliance;
    any_lateral = any_lateral || lateral[i] != 0;
    any_compliance = any_compliance || compliance[i] != 0;
  }
}

bool GravityModel::lateral_any() const { return any_lateral; }

void GravityModel::lateral_torques(const double* joint, double* tau) const {
  std::array<Frame<double>, kMaxDof + 1> frames;
  forward_kinematics(structure, constants, joint, frames.data());
  hapticcal::lateral_torques(structure, constants, frames.data(), mass.data(), com.data(), gravity,
                             tau);
}

void GravityModel::bend(const Frame<double>* frames, LinkConstants<double>* links) const {
  std::array<double, kMaxDof> tau;
  hapticcal::lateral_torques(structure, constants, frames, mass.data(), com.data(), gravity,
                             tau.data());
  for (int i = 0; i < structure.dof; ++i) tau[i] *= lateral[i];
  bend_links(structure, tau.data(), links);
}

void GravityModel::bends(const double* rigid_joint, double* bend) const {
  lateral_torques(rigid_joint, bend);
  for (int i = 0; i < structure.dof; ++i) bend[i] *= lateral[i];
}

ChainConstants<double> GravityModel::pose_constants(const double* rigid_joint) const {
  ChainConstants<double> bent = constants;
  if (!lateral_any()) return bent;
  std::array<Frame<double>, kMaxDof + 1> frames;
  forward_kinematics(structure, constants, rigid_joint, frames.data());
  bend(frames.data(), bent.links.data());
  return bent;
}

void GravityModel::torques(const double* joint, double* tau) const {
  std::array<Frame<double>, kMaxDof + 1> frames;
  forward_kinematics(structure, constants, joint, frames.data());
  gravity_torques(structure, frames.data(), mass.data(), com.data(), gravity, tau);
}

void GravityModel::deflect(double* joint) const {
  std::array<double, kMaxDof> tau;
  torques(joint, tau.data());
  for (int i = 0; i < structure.dof; ++i) joint[i] += compliance[i] * tau[i];
}

}  // namespace hapticcal
