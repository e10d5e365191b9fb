// Device models for tests: the shipped files and randomly perturbed variants.
#pragma once

#include <random>
#include <string>

#include "hapticcal/io.hpp"
#include "hapticcal/model.hpp"

#ifndef HAPTICCAL_SOURCE_DIR
#error "HAPTICCAL_SOURCE_DIR must be defined"
#endif

namespace hapticcal::testing {

inline std::string source_path(const std::string& relative) {
  return std::string(HAPTICCAL_SOURCE_DIR) + "/" + relative;
}
inline std::string shared_path(const std::string& relative) {
  return std::string(HAPTICCAL_SOURCE_DIR) + "/../shared/" + relative;
}

inline DeviceModel builtin(const std::string& name) {
  return load_device(source_path("data/devices/" + name + ".yaml"));
}
inline DeviceModel meca500() { return load_device(source_path("examples/meca500/meca500.yaml")); }

// Every meaningful kinematic parameter moved by up to +-scale (m or rad), so that
// no term (beta, tool rotation, base DH) is tested only at zero.
inline DeviceModel perturbed(DeviceModel m, std::mt19937_64& rng, double scale = 0.05) {
  std::uniform_real_distribution<double> u(-scale, scale);
  Eigen::VectorXd p = m.kinematic_parameters();
  for (const ParameterInfo& info : m.parameter_info()) p[info.slot] += u(rng);
  m.set_kinematic_parameters(p);
  return m;
}

inline Eigen::VectorXd random_readings(const DeviceModel& m, std::mt19937_64& rng) {
  Eigen::VectorXd q(m.dof());
  for (int i = 0; i < m.dof(); ++i) {
    q[i] = std::uniform_real_distribution<double>(m.links[i].lower, m.links[i].upper)(rng);
  }
  return q;
}

}  // namespace hapticcal::testing
