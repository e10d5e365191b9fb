// Device models for tests: the shipped files and randomly perturbed variants.
#pragma once

#include <fstream>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "hapticcal/data_io/log.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model/frame.hpp"
#include "hapticcal/model/model.hpp"
#include "hapticcal/model_io/device.hpp"

#ifndef HAPTICCAL_SOURCE_DIR
#error "HAPTICCAL_SOURCE_DIR must be defined"
#endif

namespace hapticcal::testing {

inline std::string source_path(const std::string& relative) {
  return std::string(HAPTICCAL_SOURCE_DIR) + "/" + relative;
}
// A file of the real data sets shipped in data/real (see their READMEs), e.g.
// real_data_path("mukca/panda.urdf"). Part of the repository: a test that reads
// one fails, never skips, when it is missing.
inline std::string real_data_path(const std::string& relative) {
  return std::string(HAPTICCAL_SOURCE_DIR) + "/data/real/" + relative;
}

// A log of `rows` rows of `dof` readings (to be filled) and `markers` points
// (x1, y1, z1, ...), no encoders or directions; the lines from 2 on.
inline Log blank_marker_log(const std::string& origin, int rows, int dof, int markers) {
  Log log;
  log.origin = origin;
  log.rows = rows;
  log.q.resize(rows, dof);
  log.ext.setZero(rows, dof);
  log.direction.setZero(rows, dof);
  log.has_ext.assign(static_cast<size_t>(dof), false);
  log.has_direction.assign(static_cast<size_t>(dof), false);
  log.q_unit.assign(static_cast<size_t>(dof), ReadingUnit::kNone);
  log.q_column.assign(static_cast<size_t>(dof), "q");
  log.marker_count = markers;
  log.markers.resize(rows, 3 * markers);
  for (int r = 0; r < rows; ++r) log.line.push_back(r + 2);
  return log;
}

inline DeviceModel builtin(const std::string& name) {
  return load_device(source_path("data/devices/" + name + ".yaml"));
}
// The Meca500 example in the robot's own base frame.
inline DeviceModel meca500() { return load_device(source_path("examples/meca500/meca500.yaml")); }
// The same model placed in the laser tracker's frame by the data set's own
// placement (data/real/meca500/T_base.txt, tracker <- robot base, mm): the
// nominal model whose errors on the tracker logs the data set's authors state.
inline DeviceModel meca500_on_tracker() {
  DeviceModel model = meca500();
  std::ifstream in(real_data_path("meca500/T_base.txt"));
  Eigen::Matrix4d T;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      if (!(in >> T(r, c))) throw std::runtime_error("T_base.txt: expected 4x4 numbers");
  const Eigen::Vector3d rpy = matrix_rpy(T.topLeftCorner<3, 3>());
  model.base = {T(0, 3) / 1000, T(1, 3) / 1000, T(2, 3) / 1000, rpy[0], rpy[1], rpy[2]};
  return model;
}
// meca500_on_tracker() written as a device file at `path`; returns `path`.
inline std::string write_meca500_on_tracker(const std::string& path) {
  save_device(meca500_on_tracker(), path);
  return path;
}

// The seven Meca500 laser-tracker sets (examples/meca500/, converted from data/real/meca500).
inline constexpr const char* kMeca500Sets[] = {
    "norm_dist_data_0deg_80cube",    "norm_dist_data_0deg_160cube", "norm_dist_data_90deg_80cube",
    "norm_dist_data_90deg_160cube",  "norm_dist_data_n90_80cube",   "norm_dist_data_n90_160cube",
    "uniform_dist_data_0deg_160cube"};
// A set's calibration ("cal") or validation ("val") log.
inline Log meca500_log(const std::string& kind, const std::string& set) {
  return read_log(source_path("examples/meca500/" + kind + "-" + set + ".csv"));
}

// Every meaningful kinematic parameter moved by up to +-scale (m or rad), so that
// no term (beta, tool rotation, base DH) is tested only at zero.
// The MUKCa recordings (data/real/mukca) of some placements as one fixture
// log's CSV: a row a configuration, labelled <placement>_<socket>.
inline std::string mukca_csv(const std::vector<std::string>& placements) {
  std::string csv = "q1,q2,q3,q4,q5,q6,q7,point\n";
  for (const std::string& placement : placements) {
    for (int socket = 0; socket < 2; ++socket) {
      std::ifstream in(real_data_path("mukca/panda_1/" + placement + "/hole_" +
                                      std::to_string(socket) + ".csv"));
      if (!in) throw std::runtime_error("no MUKCa recording of " + placement);
      std::string line;
      while (std::getline(in, line)) {
        if (!line.empty()) csv += line + "," + placement + "_" + std::to_string(socket) + "\n";
      }
    }
  }
  return csv;
}

inline DeviceModel perturbed(DeviceModel m, std::mt19937_64& rng, double scale = 0.05) {
  std::uniform_real_distribution<double> u(-scale, scale);
  Eigen::VectorXd p = m.kinematic_parameters();
  for (const ParameterInfo& info : m.parameter_info()) p[info.slot] += u(rng);
  m.set_kinematic_parameters(p);
  return m;
}

// A 7-DOF chain in URDF origin + axis geometry with the Franka Emika Panda's
// published joint origins (franka_description, panda_arm.xacro: xyz / rpy) and
// joint limits, every axis z, no base pose, and the tool 0.2104 m along the
// flange's z (flange 0.107 + hand 0.1034). No transmissions.
inline DeviceModel panda_like() {
  constexpr double h = std::numbers::pi / 2;
  struct Joint {
    std::array<double, 6> origin;
    double lower, upper;
  };
  const Joint joints[] = {
      {{0, 0, 0.333, 0, 0, 0}, -2.8973, 2.8973},        {{0, 0, 0, -h, 0, 0}, -1.7628, 1.7628},
      {{0, -0.316, 0, h, 0, 0}, -2.8973, 2.8973},       {{0.0825, 0, 0, h, 0, 0}, -3.0718, -0.0698},
      {{-0.0825, 0.384, 0, -h, 0, 0}, -2.8973, 2.8973}, {{0, 0, 0, h, 0, 0}, -0.0175, 3.7525},
      {{0.088, 0, 0, h, 0, 0}, -2.8973, 2.8973}};
  DeviceModel m;
  m.name = "panda-like";
  m.base_kind = BaseKind::kPose;
  for (int i = 0; i < 7; ++i) {
    Link l;
    l.name = "panda_joint" + std::to_string(i + 1);
    l.geometry = Geometry::kOrigin;
    l.type = JointType::kRevolute;
    l.origin = joints[i].origin;
    l.lower = joints[i].lower;
    l.upper = joints[i].upper;
    m.links.push_back(l);
  }
  m.tool = {0, 0, 0.2104, 0, 0, 0};
  return m;
}

// A random unit vector (uniform on the sphere).
inline Eigen::Vector3d random_axis(std::mt19937_64& rng) {
  std::normal_distribution<double> n;
  Eigen::Vector3d u(n(rng), n(rng), n(rng));
  return u.normalized();
}

// Every other origin-geometry joint (the 2nd, 4th, ...) turned about or sliding
// along a random unit axis instead of z.
inline DeviceModel with_random_axes(DeviceModel m, std::mt19937_64& rng) {
  for (int i = 1; i < m.dof(); i += 2) {
    if (m.links[i].geometry == Geometry::kOrigin) m.links[i].axis = random_axis(rng);
  }
  return m;
}

// One chain with every geometry and joint type: DH, MDH and origin links;
// revolute, continuous and prismatic joints (DH, MDH and origin prismatic);
// non-zero betas, non-z axes, a capstan on a DH, an MDH and an origin revolute
// joint (the origin one with a large offset) and polynomials on two prismatic
// joints. The base is a DH transform or a pose.
inline DeviceModel mixed_chain(BaseKind base_kind) {
  struct Spec {
    Geometry geometry;
    JointType type;
    double a, alpha, d, theta, beta;
    std::array<double, 6> origin;
    Eigen::Vector3d axis;
    double offset;
  };
  using G = Geometry;
  using J = JointType;
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
  const Spec specs[] = {
      {G::kDh, J::kRevolute, 0.05, -1.4, 0.12, 0.3, 0.01, {}, z, 0},
      {G::kMdh, J::kPrismatic, 0.02, 1.2, 0.1, -0.4, -0.02, {}, z, 0},
      {G::kOrigin,
       J::kContinuous,
       0,
       0,
       0,
       0,
       0,
       {0.03, -0.05, 0.2, 0.4, -0.3, 1.1},
       Eigen::Vector3d(0.3, -0.5, 0.8).normalized(),
       0.2},
      {G::kDh, J::kPrismatic, -0.04, 0.7, 0.08, 0.9, 0.015, {}, z, 0},
      {G::kOrigin,
       J::kPrismatic,
       0,
       0,
       0,
       0,
       0,
       {-0.02, 0.1, 0.05, -1.2, 0.5, -0.2},
       Eigen::Vector3d(-0.6, 0.2, 0.4).normalized(),
       0.03},
      {G::kMdh, J::kRevolute, 0.15, -0.8, 0.04, 1.3, 0.02, {}, z, 0},
      {G::kOrigin, J::kRevolute, 0, 0, 0, 0, 0, {0.1, 0, 0.02, 1.5, 0, 0.1}, z, 1.0},
      {G::kDh, J::kContinuous, 0.0, 0.5, 0.06, -0.2, -0.01, {}, z, 0},
      {G::kMdh, J::kRevolute, 0.03, 1.1, -0.05, 0.2, 0.005, {}, z, 0},
  };
  DeviceModel m;
  m.name = "mixed";
  m.base_kind = base_kind;
  m.base = base_kind == BaseKind::kDh ? std::array<double, 6>{0.2, -0.6, 0.15, 0.4, 0, 0}
                                      : std::array<double, 6>{0.1, -0.2, 0.3, 0.2, -0.4, 0.7};
  for (size_t i = 0; i < std::size(specs); ++i) {
    const Spec& sp = specs[i];
    Link l;
    l.name = "j" + std::to_string(i + 1);
    l.geometry = sp.geometry;
    l.type = sp.type;
    l.a = sp.a;
    l.alpha = sp.alpha;
    l.d = sp.d;
    l.theta = sp.theta;
    l.beta = sp.beta;
    l.origin = sp.origin;
    l.axis = sp.axis;
    l.offset = sp.offset;
    if (l.prismatic()) {
      l.lower = -0.1;
      l.upper = 0.2;
    } else if (l.type == JointType::kContinuous) {
      l.lower = -2 * std::numbers::pi;
      l.upper = 2 * std::numbers::pi;
    } else {
      l.lower = -2.5;
      l.upper = 2.5;
    }
    m.links.push_back(l);
  }
  m.links[0].transmission = Transmission(Capstan{8, 0.04, 0, 0.01, 0.1e-3, -0.7, 0.05e-3, 1.3});
  m.links[5].transmission = Transmission(Capstan{12, 0.05, 0, -0.02, 0.2e-3, 2.1, 0.02e-3, -0.4});
  m.links[6].transmission = Transmission(Capstan{10, 0.05, 0, 0.015, 0.1e-3, 0.3, 0.04e-3, 2.2});
  for (int i : {1, 4}) {
    const Polynomial p{PolynomialBasis::kChebyshev,
                       m.links[i].lower,
                       m.links[i].upper,
                       {0, 1e-3, -5e-4, 2e-4, 1e-4}};
    m.links[i].transmission = Transmission(p);
  }
  m.tool = {0.01, -0.02, 0.08, 0.3, -0.2, 0.5};
  return m;
}

// Readings the device can take: within the limits, a coupled joint within its range.
inline Eigen::VectorXd random_readings(const DeviceModel& m, std::mt19937_64& rng) {
  return m.draw_readings(rng);
}

// A 6-D pose log (x, y, z and a unit quaternion, exact) of `truth` at `rows`
// random readings within its limits.
inline Log pose_log(const DeviceModel& truth, int rows, std::mt19937_64& rng) {
  const PreparedModel actual(truth);
  Log log;
  log.origin = "simulated poses";
  log.rows = rows;
  log.q.resize(rows, truth.dof());
  log.ext = Eigen::MatrixXd::Zero(rows, truth.dof());
  log.has_ext.assign(truth.dof(), false);
  log.position.resize(rows, 3);
  log.orientation.resize(rows, 4);
  log.has_position = log.has_orientation = true;
  for (int r = 0; r < rows; ++r) {
    const Eigen::VectorXd q = random_readings(truth, rng);
    log.q.row(r) = q.transpose();
    log.line.push_back(r + 2);
    const Frame<double> tool = actual.forward(q.data());
    log.position.row(r) = tool.p.transpose();
    const Eigen::Quaterniond quat(tool.R);
    log.orientation.row(r) << quat.w(), quat.x(), quat.y(), quat.z();
  }
  return log;
}

}  // namespace hapticcal::testing
