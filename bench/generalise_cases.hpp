// The generalisation benchmark's simulated cases (bench/generalise.cpp): a
// robot, the errors its truth has, an instrument, the poses measured and how
// they were chosen, and the held-out poses the calibrated model is scored on
// against the truth. Every draw comes from the case's seed.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <numbers>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "hapticcal/data_io/log.hpp"
#include "hapticcal/design/plan.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/model_io/model_source.hpp"
#include "hapticcal/model_io/urdf.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "hapticcal/study/paper.hpp"
#include "hapticcal/study/simulation.hpp"
#include "test_models.hpp"

namespace hapticcal::generalise {

// One case as written in the table of generalise.cpp.
struct CaseSpec {
  const char* robot;       // meca500, arm6, panda, panda-mass, torso, touch, paper
  const char* errors;      // iso, cad, compliance, harmonic, zero, joined by '+'
  const char* instrument;  // tracker, pose, mocap, cable, fixture
  int poses;
  const char* design;  // random, planned, sweeps
  std::uint64_t seed;
};

// A case made: the nominal model, the truth, the log to fit, the calibration's
// fixed options (a fixture's known distances), and how to score a model.
struct Case {
  std::string name;
  DeviceModel nominal, truth;
  Log log;
  CalibrationOptions options;
  std::set<std::string> truth_families;           // joint-error families the truth has
  bool geometric = true;                          // the truth differs from nominal in geometry only
  Log held_out;                                   // noise-free, of the truth device, never fitted
  bool distance = false;                          // scored on distances (else positions)
  bool fixture = false;                           // scored by the held-out sockets' point deviation
  std::vector<PointDistance> held_out_distances;  // a fixture's known distances there
  bool mean_deviation = false;  // a fixture scored by the mean point deviation (MUKCa's)
  double noise_effect = 0;      // the noise's RMS effect on one measurement [m]
};

// The score: RMS error of `model` on the held-out poses against the truth [m].
inline double score(const Case& c, const DeviceModel& model) {
  if (c.fixture) {
    const Evaluation e = evaluate(model, c.held_out, c.held_out_distances);
    return c.mean_deviation ? *e.mean_point_deviation : *e.rms_point_deviation;
  }
  const Evaluation e = evaluate(model, c.held_out);
  return c.distance ? e.figure("distance")->stats.rms : e.figure("position")->stats.rms;
}

inline bool has(const std::string& list, const char* item) {
  return ("+" + list + "+").find(std::string("+") + item + "+") != std::string::npos;
}

// Invented masses of a light arm's order for a chain of `dof` joints, heavier
// near the base, each centre 5 cm out along the link frame's x.
inline void give_masses(DeviceModel& m) {
  for (int i = 0; i < m.dof(); ++i) {
    m.links[i].mass = std::max(0.5, 5.0 - 0.7 * i);
    m.links[i].com = Eigen::Vector3d(0.05, 0, 0.01);
  }
}

// A 3-joint torso (yaw, two pitches) whose fourth joint is passive and keeps
// the shoulder level, theta4 = -(u2 + u3), under a 7R arm of the Panda's
// published geometry (test_models.hpp's panda_like): 11 joints, 10 readings.
inline DeviceModel torso_arm() {
  const DeviceModel arm = testing::panda_like();
  DeviceModel m;
  m.name = "torso-arm";
  m.base_kind = BaseKind::kPose;
  const double h = std::numbers::pi / 2;
  const std::array<std::array<double, 6>, 4> torso = {{{0, 0, 0.35, 0, 0, 0},
                                                       {0, 0, 0.12, -h, 0, 0},
                                                       {0.30, 0, 0, 0, 0, 0},
                                                       {0.25, 0, 0, 0, 0, 0}}};
  const std::array<std::array<double, 2>, 4> limits = {
      {{-1.5, 1.5}, {-0.4, 0.6}, {-0.6, 0.4}, {-3, 3}}};
  for (int i = 0; i < 4; ++i) {
    Link l;
    l.name = "torso" + std::to_string(i + 1);
    l.geometry = Geometry::kOrigin;
    l.type = JointType::kRevolute;
    l.origin = torso[i];
    l.lower = limits[i][0];
    l.upper = limits[i][1];
    m.links.push_back(l);
  }
  for (Link l : arm.links) {
    l.name = "arm_" + l.name;
    m.links.push_back(l);
  }
  m.links[4].origin = {0.08, 0, 0, h, 0, 0};  // the shoulder on the level link
  m.tool = arm.tool;
  const int n = m.dof();
  m.coupling = Eigen::MatrixXd::Identity(n, n);
  m.coupling(3, 3) = 0;
  m.coupling(3, 1) = -1;
  m.coupling(3, 2) = -1;
  return m;
}

inline DeviceModel robot(const std::string& name) {
  if (name == "meca500") return testing::meca500();
  if (name == "arm6") {
    return load_urdf(testing::source_path("tests/data/urdf/compliant-arm.urdf"), "tool");
  }
  if (name == "panda") return testing::panda_like();
  if (name == "panda-mass") {
    DeviceModel m = testing::panda_like();
    give_masses(m);
    return m;
  }
  if (name == "torso") {
    DeviceModel m = torso_arm();
    give_masses(m);
    return m;
  }
  if (name == "touch") return testing::builtin("geomagic-touch");
  return testing::builtin("baser-7dof");
}

// The slots calibrate offers of the model's links.
inline std::vector<int> link_candidates(const DeviceModel& m) {
  std::vector<int> out;
  const std::vector<ParameterInfo> info = m.parameter_info();
  for (int slot : candidate_slots(m, {}, {})) {
    if (info[slot].joint >= 0 && info[slot].joint < m.dof()) out.push_back(slot);
  }
  return out;
}

// The truth: the nominal with the case's errors.
inline DeviceModel make_truth(const CaseSpec& spec, const DeviceModel& nominal, Case& c,
                              std::mt19937_64& rng) {
  DeviceModel truth = spec.robot == std::string("paper") ? paper_actual_device(nominal) : nominal;
  std::uniform_real_distribution<double> unit(-1, 1), coin(0, 1);
  const std::vector<ParameterInfo> info = truth.parameter_info();
  Eigen::VectorXd p = truth.kinematic_parameters();
  const std::vector<int> links = link_candidates(nominal);
  const Tolerances iso;
  for (int slot : links) {
    p[slot] += unit(rng) * (info[slot].unit == ParameterUnit::kAngle ? iso.angle : iso.length);
  }
  if (has(spec.errors, "cad")) {
    // Three joints' origins off by CAD-level amounts: 2-20 mm, 10-50 mrad.
    std::set<int> joints;
    while (joints.size() < 3) joints.insert(static_cast<int>(coin(rng) * nominal.dof()));
    for (int slot : links) {
      if (!joints.count(info[slot].joint)) continue;
      const bool angle = info[slot].unit == ParameterUnit::kAngle;
      const double size = angle ? 0.010 + 0.040 * coin(rng) : 0.002 + 0.018 * coin(rng);
      p[slot] += (coin(rng) < 0.5 ? -1 : 1) * size * (coin(rng) < 0.5 ? 1.0 : 0.3);
    }
  }
  truth.set_kinematic_parameters(p);
  if (has(spec.errors, "compliance")) {
    // The truth's own masses (a model without them: unknown to the fit).
    bool masses = false;
    for (const Link& l : truth.links) masses = masses || l.mass > 0;
    if (!masses) give_masses(truth);
    const double log_k = -5 + 2 * coin(rng);  // 1e-5 .. 1e-3 rad / N m
    for (int i = 1; i < truth.dof(); i += 2) {
      truth.links[i].compliance = std::pow(10.0, log_k + 0.3 * unit(rng));
    }
    c.truth_families.insert("compliance");
    c.geometric = false;
  }
  if (has(spec.errors, "harmonic")) {
    for (int i = 1; i < truth.dof(); i += 2) {
      if (truth.links[i].prismatic() || (truth.coupled() && truth.coupling(i, i) != 1)) continue;
      Harmonic h;
      h.frequencies = {1, 2};
      h.coefficients = {3e-4 * unit(rng), 3e-4 * unit(rng), 2e-4 * unit(rng), 2e-4 * unit(rng)};
      h.coefficients[0] += h.coefficients[0] > 0 ? 2e-4 : -2e-4;
      Transmission& t = truth.links[i].transmission;
      t = t.is_none() ? Transmission(h) : Transmission(Chain{{t, Transmission(h)}});
    }
    c.truth_families.insert("harmonic");
    c.geometric = false;
  }
  return truth;
}

// Single-joint sweeps: from the middle of the ranges, each joint alone over
// most of its range, then a few poses moving every joint.
inline Eigen::MatrixXd sweeps(const DeviceModel& m, int poses, std::mt19937_64& rng) {
  const int n = m.dof();
  Eigen::MatrixXd q(poses, n);
  Eigen::RowVectorXd mid(n), lo(n), hi(n);
  for (int j = 0; j < n; ++j) {
    lo[j] = m.links[j].lower;
    hi[j] = m.links[j].upper;
    mid[j] = 0.5 * (lo[j] + hi[j]);
  }
  std::uniform_real_distribution<double> u(0, 1);
  const int swept = poses * 4 / 5;
  for (int r = 0; r < poses; ++r) {
    q.row(r) = mid;
    if (r < swept) {
      const int j = r % n;
      const double s = static_cast<double>(r / n) / std::max(1, swept / n - 1);
      q(r, j) = lo[j] + (0.1 + 0.8 * std::min(s, 1.0)) * (hi[j] - lo[j]);
    } else {
      for (int j = 0; j < n; ++j) q(r, j) = lo[j] + u(rng) * (hi[j] - lo[j]);
    }
  }
  return q;
}

}  // namespace hapticcal::generalise

namespace hapticcal::generalise {

// The shared real data sets as cases (no truth: scored on their own held-out
// measurements): the Meca500's seven sets, each on its validation log; the
// MUKCa Panda, each placement held out of a calibration on the other two
// (its known socket distances given; the mean point deviation, MUKCa's KPI).
inline std::vector<Case> real_cases() {
  std::vector<Case> out;
  for (const char* set : testing::kMeca500Sets) {
    Case c;
    c.name = std::string("real Meca500 ") + set;
    c.nominal = testing::meca500();
    c.truth = c.nominal;
    c.log = testing::meca500_log("cal", set);
    c.held_out = testing::meca500_log("val", set);
    out.push_back(c);
  }
  const char* placements[] = {"back-high", "front", "right"};
  const DeviceModel panda =
      load_model(testing::real_data_path("mukca/panda.urdf"), "ball_link", "panda_link0");
  const auto distances = [](const std::vector<std::string>& names) {
    std::vector<PointDistance> d;
    for (const std::string& p : names) d.push_back({p + "_0", p + "_1", 0.05});
    return d;
  };
  for (const char* held : placements) {
    std::vector<std::string> train;
    for (const char* p : placements) {
      if (std::string(p) != held) train.push_back(p);
    }
    Case c;
    c.name = std::string("real MUKCa Panda, ") + held + " held out";
    c.nominal = c.truth = panda;
    c.log = parse_log(testing::mukca_csv(train), "mukca");
    c.options.point_distances = distances(train);
    c.held_out = parse_log(testing::mukca_csv({held}), "mukca");
    c.held_out_distances = distances({held});
    c.fixture = c.mean_deviation = true;
    out.push_back(c);
  }
  return out;
}

}  // namespace hapticcal::generalise
