#include "hapticcal/study/paper.hpp"

#include <cassert>
#include <map>
#include <numbers>

namespace hapticcal {

DeviceModel paper_actual_device(const DeviceModel& nominal) {
  assert(nominal.dof() >= 4 && "default_scenario refuses devices of fewer than 4 joints");
  DeviceModel m = nominal;
  constexpr double mrad = 1e-3, mm = 1e-3, deg = std::numbers::pi / 180;
  // Table 3: alpha_1..7 [mrad], a_1..7 [mm], d_1..7 [mm], theta_1..7 [mrad].
  const double d_alpha[] = {-1.5, 1.3, -1.4, 1.2, -1.1, -1.6, 1.7};
  const double d_a[] = {-1.1, 1.6, -1.2, 1.4, -1.5, 1.4, -1.3};
  const double d_d[] = {1.2, -1.5, 1.3, -1.3, 1.4, -1.2, 1.0};
  const double d_theta[] = {1.0, 1.7, -1.3, 1.0, -1.2, -1.0, 1.1};
  m.base[0] += 1.9 * mm;    // a0
  m.base[1] += 1.5 * mrad;  // alpha0
  for (int i = 0; i < 7 && i < m.dof(); ++i) {
    m.links[i].alpha += d_alpha[i] * mrad;
    m.links[i].a += d_a[i] * mm;
    m.links[i].d += d_d[i] * mm;
    m.links[i].theta += d_theta[i] * mrad;
  }
  // Table 2: Re, ro [mm], ri [mm], bo [deg], bi [deg] for drums 1-4.
  const double Re[] = {-0.025, -0.020, 0.015, 0.02};
  const double ro[] = {0.200, 0.250, 0.200, 0.1};
  const double ri[] = {0.005, 0.0025, 0.004, 0.002};
  const double bo[] = {-105, -10, 150, -40};
  const double bi[] = {-15, 140, -100, -120};
  auto capstan = [&](int k) {
    Capstan c;
    c.ratio = 10;
    c.drum_distance = 0.005;
    c.ratio_error = Re[k];
    c.r_out = ro[k] * mm;
    c.r_in = ri[k] * mm;
    c.beta_out = bo[k] * deg;
    c.beta_in = bi[k] * deg;
    return c;
  };
  for (int k = 0; k < 3; ++k) m.links[k].transmission = Transmission(capstan(k));
  m.links[3].transmission = Transmission(
      Chain{{Transmission(capstan(3)),
             Transmission(Parallelogram{0.05 - 0.5 * mm, 0.21 - 0.7 * mm, 0.05, 0.21})}});
  return m;
}

std::optional<double> paper_improvement_pct(const std::string& name) {
  // Baser & Konukseven (2013), Table 3 (kinematic) and Table 2 (capstans 1-3).
  static const std::map<std::string, double> kPaper = {
      {"j1.alpha", 98.47},       {"j2.alpha", 99.30},       {"j3.alpha", 99.73},
      {"j4.alpha", 81.35},       {"j5.alpha", 80.01},       {"j6.alpha", 96.60},
      {"base.a", 99.99},         {"j1.a", 98.97},           {"j2.a", 99.47},
      {"j3.a", 99.99},           {"j4.a", 99.44},           {"j5.a", 99.99},
      {"j6.a", 99.86},           {"j7.a", 99.99},           {"j1.d", 99.44},
      {"j2.d", 99.71},           {"j3.d", 99.37},           {"j4.d", 97.64},
      {"j5.d", 99.55},           {"j6.d", 99.99},           {"j7.d", 99.92},
      {"j1.theta", 99.44},       {"j2.theta", 96.69},       {"j3.theta", 91.29},
      {"j4.theta", 97.24},       {"j5.theta", 96.22},       {"j6.theta", 90.66},
      {"j7.theta", 76.45},       {"j1.ratio_error", 99.72}, {"j2.ratio_error", 98.54},
      {"j3.ratio_error", 92.89}, {"j1.r_out", 99.76},       {"j2.r_out", 99.28},
      {"j3.r_out", 95.02},       {"j1.r_in", 99.36},        {"j2.r_in", 99.12},
      {"j3.r_in", 99.75},        {"j1.beta_out", 99.74},    {"j2.beta_out", 99.22},
      {"j3.beta_out", 99.20},    {"j1.beta_in", 97.24},     {"j2.beta_in", 99.99},
      {"j3.beta_in", 99.14}};
  const auto it = kPaper.find(name);
  if (it == kPaper.end()) return std::nullopt;
  return it->second;
}

Eigen::VectorXd default_posture(const DeviceModel& model) {
  Eigen::VectorXd q = Eigen::VectorXd::Zero(model.dof());
  if (model.dof() == 7) q[5] = 0.3;
  // Else the middle of the limits' coordinates (a coupled joint's range).
  return model.within_limits(q) ? q : model.limit_coordinates().middle();
}

}  // namespace hapticcal
