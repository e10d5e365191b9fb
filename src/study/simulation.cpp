#include "hapticcal/study/simulation.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <functional>
#include <numbers>
#include <optional>
#include <random>

#include "hapticcal/core/cancel.hpp"
#include "hapticcal/core/error.hpp"
#include "hapticcal/kinematics/kinematics.hpp"

namespace hapticcal {

double quantized_reading(double q, double ratio, double counts) {
  if (counts <= 0) return q;
  const double step = 2 * std::numbers::pi / (counts * ratio);
  return std::round(q / step) * step;
}

namespace {

// Each joint's motor-to-joint ratio: its capstan's, 1 without one.
std::vector<double> drive_ratios(const DeviceModel& model) {
  std::vector<double> ratios(model.dof(), 1.0);
  for (int j = 0; j < model.dof(); ++j) ratios[j] = model.links[j].transmission.drive_ratio();
  return ratios;
}

}  // namespace

namespace {

// What a simulated log measures: its kinds, each a sample's values drawn in
// this order (a log of distances and positions: distance, then position).
using Kinds = std::vector<MeasurementType>;

// The kinds of simulate_log's columns.
Kinds columns(bool distance, bool position) {
  Kinds kinds;
  if (distance) kinds.push_back(MeasurementType::kDistance);
  if (position) kinds.push_back(MeasurementType::kPosition);
  return kinds;
}

// The joints a simulated external encoder is on: those whose angle a
// transmission acts on (coupled: whose row uses a reading with a transmission).
std::vector<bool> encoder_joints(const DeviceModel& actual) {
  const int n = actual.dof();
  std::vector<bool> has(n, false);
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < n; ++k) {
      const double c = actual.coupled() ? actual.coupling(i, k) : (i == k ? 1.0 : 0.0);
      if (c != 0 && !actual.links[k].transmission.is_none()) has[i] = true;
    }
  }
  return has;
}

// The model an external encoder reads: step 1 fits transmissions, so its
// encoders measure the joint angle the drive sets, before a joint's elastic
// deflection under gravity (without the links' compliance).
DeviceModel encoder_model(DeviceModel actual) {
  for (Link& l : actual.links) l.compliance = 0;
  return actual;
}

// Row r's external encoder columns at readings q: each joint's angle without
// its offset (encoder_model's compensate), the encoder's own zero 1e-3 (j + 1)
// rad and noise; the draws in joint order.
template <typename Rng>
void simulated_encoders(const DeviceModel& encoders, const Eigen::VectorXd& q, double sigma_ext,
                        Rng& rng, std::normal_distribution<double>& gauss, Log& log, int r) {
  if (std::find(log.has_ext.begin(), log.has_ext.end(), true) == log.has_ext.end()) return;
  const Eigen::VectorXd theta = encoders.compensate(q);
  for (int j = 0; j < encoders.dof(); ++j) {
    if (log.has_ext[j]) log.ext(r, j) = theta[j] + 1e-3 * (j + 1) + sigma_ext * gauss(rng);
  }
}

// A log of `poses` rows; each row's readings from `draw(row, rng, q)` (in
// order, from the same generator as the noise that follows them).
template <typename Draw>
Log measure(const DeviceModel& actual, int poses, const SimulationNoise& noise, std::uint64_t seed,
            const Kinds& kinds, Draw draw) {
  // A tree's measurement: every tip's point, one marker a tip (x1 .. z<tips>).
  const int tips = actual.tree() ? actual.tips() : 0;
  if (tips && kinds != Kinds{MeasurementType::kPosition}) {
    throw InputError(actual.name, 0, "measurement",
                     "a tree of several tips is simulated with one point a tip (position)");
  }
  if (tips && actual.has_backlash()) {
    throw InputError(actual.name, 0, "backlash", "backlash on a tree is not simulated");
  }
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const int n = actual.dof();
  const PreparedModel prepared(actual);
  const DeviceModel ext_model = encoder_model(actual);
  const std::vector<double> ratio = drive_ratios(actual);
  Log log;
  log.origin = "simulated";
  log.rows = poses;
  log.q.resize(poses, n);
  log.ext.setZero(poses, n);
  log.has_ext.resize(n);
  log.has_ext = encoder_joints(actual);
  log.marker_count = tips;
  if (tips) log.markers.resize(poses, 3 * tips);
  // Each kind's values, one row a sample (a tree's are its markers).
  std::vector<MeasuredValues> values;
  for (MeasurementType kind : kinds) values.emplace_back(tips ? 0 : poses, traits(kind).width);
  const InstrumentNoise instrument = noise.instrument();
  const std::function<double()> draw_noise = [&] { return gauss(rng); };
  // A joint with backlash approaches each pose from a side drawn at random,
  // written as its dir<i> column (the encoders read the drive's side).
  const bool backlash = actual.has_backlash();
  if (backlash) {
    log.direction.setZero(poses, n);
    log.has_direction.assign(n, false);
    for (int j = 0; j < n; ++j) log.has_direction[j] = actual.links[j].backlash != 0;
  }
  const ChainStructure s = actual.structure();
  const Eigen::VectorXd params = actual.kinematic_parameters();
  const ChainConstants<double> constants = chain_constants(s, params.data());
  for (int r = 0; r < poses; ++r) {
    log.line.push_back(r + 2);
    draw(r, rng, log.q);
    const Eigen::VectorXd q = log.q.row(r).transpose();
    simulated_encoders(ext_model, q, noise.sigma_ext, rng, gauss, log, r);
    Frame<double> T_meas_tool;
    if (backlash) {
      for (int j = 0; j < n; ++j) {
        if (log.has_direction[j]) log.direction(r, j) = rng() % 2 ? 1.0 : -1.0;
      }
      Eigen::VectorXd joint = actual.compensate(q);
      actual.apply_backlash(log.direction.row(r), joint);
      const std::optional<ChainConstants<double>> bent = prepared.bent_constants(q.data());
      T_meas_tool = forward_kinematics(s, bent ? *bent : constants, joint.data());
    } else {
      T_meas_tool = prepared.forward(q.data());
    }
    for (int j = 0; j < n; ++j) {
      log.q(r, j) = quantized_reading(q[j], ratio[j], noise.motor_counts_per_rev);
    }
    if (!tips) {
      for (size_t k = 0; k < kinds.size(); ++k)
        kind_of(kinds[k]).simulate(T_meas_tool, instrument, draw_noise, values[k].row(r).data());
      continue;
    }
    for (int t = 0; t < tips; ++t) {  // tip 0's frame is T_meas_tool
      const Eigen::Vector3d p = t == 0 ? T_meas_tool.p : prepared.forward(q.data(), t).p;
      for (int k = 0; k < 3; ++k)
        log.markers(r, 3 * t + k) = p[k] + noise.sigma_position * gauss(rng);
    }
  }
  if (!tips) {
    for (size_t k = 0; k < kinds.size(); ++k) kind_of(kinds[k]).to_log(values[k], log);
  }
  return log;
}

}  // namespace

namespace {

// Readings drawn uniformly within the joint limits and ranges.
auto uniform_readings(const DeviceModel& actual) {
  return [&actual](int r, std::mt19937_64& rng, Eigen::MatrixXd& q) {
    q.row(r) = actual.draw_readings(rng).transpose();
  };
}

// The given readings, row by row.
auto given_readings(const DeviceModel& actual, const Eigen::MatrixXd& readings) {
  assert(readings.cols() == actual.dof());
  (void)actual;
  return [&readings](int r, std::mt19937_64&, Eigen::MatrixXd& q) { q.row(r) = readings.row(r); };
}

}  // namespace

Log simulate_log(const DeviceModel& actual, int poses, const SimulationNoise& noise,
                 std::uint64_t seed, bool distance, bool position) {
  return measure(actual, poses, noise, seed, columns(distance, position), uniform_readings(actual));
}

Log simulate_log_at(const DeviceModel& actual, const Eigen::MatrixXd& readings,
                    const SimulationNoise& noise, std::uint64_t seed, bool distance,
                    bool position) {
  return measure(actual, static_cast<int>(readings.rows()), noise, seed,
                 columns(distance, position), given_readings(actual, readings));
}

Log simulate_measurement_log(const DeviceModel& actual, MeasurementType type, int poses,
                             const Eigen::MatrixXd& readings, const SimulationNoise& noise,
                             std::uint64_t seed) {
  const Kinds c{type};
  if (readings.size()) {
    return measure(actual, static_cast<int>(readings.rows()), noise, seed, c,
                   given_readings(actual, readings));
  }
  return measure(actual, poses, noise, seed, c, uniform_readings(actual));
}

std::vector<std::pair<std::string, Eigen::Vector3d>> default_sockets(const DeviceModel& model) {
  Eigen::VectorXd q(model.dof());
  for (int j = 0; j < model.dof(); ++j)
    q[j] = model.links[j].lower + 0.45 * (model.links[j].upper - model.links[j].lower);
  const PreparedModel prepared(model);
  const Eigen::Vector3d a = prepared.forward(q.data()).p;
  // The first of +x, -x, +y, -y, +z, -z that the tool reaches from there
  // within the limits (a device whose +x leaves its workspace gets another).
  for (int axis = 0; axis < 6; ++axis) {
    const Eigen::Vector3d b = a + (axis % 2 ? -0.05 : 0.05) * Eigen::Vector3d::Unit(axis / 2);
    const ReachResult r = reach(prepared, q, ToolTarget::at(b));
    if (r.error < 1e-9 && model.within_limits(r.q)) return {{"a", a}, {"b", b}};
  }
  return {{"a", a}, {"b", a + Eigen::Vector3d(0.05, 0, 0)}};  // contact_log names it
}

namespace {

// A fixture log of `per_label` rows a label (column `point`, or `plane`): each
// row random readings within the limits moved by reach() onto the target that
// target(label, rng) draws for it (a start that ends outside the limits or
// farther than 1e-9 m from the target is drawn again, up to 1000 times).
template <typename DrawTarget>
Log contact_log(const DeviceModel& actual, const std::vector<std::string>& labels, int per_label,
                bool planes, std::uint64_t seed, bool encoders, double sigma_ext,
                DrawTarget draw_target) {
  constexpr int kStarts = 1000;
  constexpr double kReached = 1e-9;  // m
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const PreparedModel prepared(actual);
  const DeviceModel ext_model = encoder_model(actual);
  const int n = actual.dof();
  Log log;
  log.origin = planes ? "simulated plane contacts" : "simulated fixture";
  log.rows = static_cast<int>(labels.size()) * per_label;
  log.q.resize(log.rows, n);
  log.ext.setZero(log.rows, n);
  log.has_ext.assign(n, false);
  if (encoders) log.has_ext = encoder_joints(actual);
  (planes ? log.has_plane : log.has_point) = true;
  int row = 0;
  for (size_t l = 0; l < labels.size(); ++l) {
    for (int k = 0; k < per_label; ++k) {
      const ToolTarget target = draw_target(l, rng, gauss);
      bool reached = false;
      for (int start = 0; start < kStarts && !reached; ++start) {
        const ReachResult r = reach(prepared, actual.draw_readings(rng), target);
        reached = actual.within_limits(r.q) && r.error < kReached;
        if (reached) log.q.row(row) = r.q.transpose();
      }
      if (!reached) {
        throw InputError(fmt::format("{} '{}' cannot be reached within the joint limits of {}",
                                     planes ? "plane" : "socket", labels[l], actual.name));
      }
      simulated_encoders(ext_model, log.q.row(row).transpose(), sigma_ext, rng, gauss, log, row);
      log.label.push_back(labels[l]);
      log.line.push_back(row + 2);
      ++row;
    }
  }
  return log;
}

}  // namespace

Log simulate_fixture_log(const DeviceModel& actual,
                         const std::vector<std::pair<std::string, Eigen::Vector3d>>& sockets,
                         int per_socket, double placement, std::uint64_t seed, bool encoders,
                         double sigma_ext) {
  std::vector<std::string> labels;
  for (const auto& socket : sockets) labels.push_back(socket.first);
  return contact_log(actual, labels, per_socket, false, seed, encoders, sigma_ext,
                     [&](size_t l, std::mt19937_64& rng, std::normal_distribution<double>& gauss) {
                       Eigen::Vector3d p = sockets[l].second;
                       for (int a = 0; a < 3; ++a) p[a] += placement * gauss(rng);
                       return ToolTarget::at(p);
                     });
}

Log simulate_plane_log(const DeviceModel& actual, const std::vector<SimulatedPlane>& planes,
                       int per_plane, double contact_sd, std::uint64_t seed, bool encoders,
                       double sigma_ext) {
  std::vector<std::string> labels;
  for (const SimulatedPlane& plane : planes) {
    assert(std::abs(plane.normal.norm() - 1) < 1e-12);
    labels.push_back(plane.name);
  }
  return contact_log(actual, labels, per_plane, true, seed, encoders, sigma_ext,
                     [&](size_t l, std::mt19937_64& rng, std::normal_distribution<double>& gauss) {
                       const SimulatedPlane& plane = planes[l];
                       return ToolTarget::on_plane(
                           plane.normal, plane.normal.dot(plane.point) + contact_sd * gauss(rng));
                     });
}

std::vector<SimulatedPlane> default_planes(const DeviceModel& model) {
  const Eigen::Vector3d a = default_sockets(model).front().second;
  // "Forward": from the measurement frame's z axis towards the tool point.
  Eigen::Vector3d forward(a.x(), a.y(), 0);
  forward = forward.norm() > 1e-6 ? forward.normalized() : Eigen::Vector3d::UnitX();
  const Eigen::Vector3d up = Eigen::Vector3d::UnitZ(), side = up.cross(forward);
  const double reach = std::max(a.norm(), 0.05);
  return {{"floor", a - 0.05 * reach * up, (up + 0.2 * forward).normalized()},
          {"front", a + 0.05 * reach * forward, (-forward + 0.3 * side).normalized()},
          {"side", a + 0.05 * reach * side, (-side + 0.3 * up).normalized()}};
}

Log simulate_trajectory(const DeviceModel& actual, double seconds, double rate_hz,
                        const SimulationNoise& noise, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const int n = actual.dof();
  constexpr int kHarmonics = 4;
  std::vector<std::array<double, kHarmonics>> freq(n), phase(n), amp(n);
  for (int j = 0; j < n; ++j) {
    double total = 0;
    for (int k = 0; k < kHarmonics; ++k) {
      freq[j][k] = 0.02 + 0.25 * unit(rng);  // Hz: slow, hand-guided motion
      phase[j][k] = 2 * std::numbers::pi * unit(rng);
      amp[j][k] = 0.2 + unit(rng);
      total += amp[j][k];
    }
    for (double& a : amp[j]) a /= total;  // |sum| <= 1
  }
  const int rows = static_cast<int>(seconds * rate_hz);
  const double rest = std::min(5.0, seconds / 10);  // at home, then a smooth start and stop
  Log log;
  log.origin = "simulated trajectory";
  log.rows = rows;
  log.q.resize(rows, n);
  log.ext.setZero(rows, n);
  log.has_ext.assign(n, false);
  log.has_time = true;
  log.t.resize(rows);
  MeasuredValues distance(rows, 1);  // a cable encoder's, which the kind puts in the log
  const PreparedModel prepared(actual);
  const std::vector<double> ratio = drive_ratios(actual);
  // The motion sweeps the limits' coordinates (a coupled joint's value within
  // its range), then the readings are kept within their limits.
  const DeviceModel::LimitCoordinates box = actual.limit_coordinates();
  Eigen::VectorXd x(n), q(n);
  for (int r = 0; r < rows; ++r) {
    if ((r & 4095) == 4095) throw_if_cancelled();  // Python's Ctrl-C (core/cancel.hpp)
    const double t = r / rate_hz;
    const double u = std::clamp((std::min(t, seconds - t) - rest) / rest, 0.0, 1.0);
    const double envelope = u * u * (3 - 2 * u);
    for (int j = 0; j < n; ++j) {
      const double lower = box.lower[j], upper = box.upper[j];
      // Home (0) stays the centre; a coordinate whose limits exclude it moves
      // about their middle instead.
      const bool home_inside = lower <= 0 && 0 <= upper;
      const double centre = home_inside ? 0.0 : (lower + upper) / 2;
      const double half = 0.45 * (home_inside ? std::min(-lower, upper) : (upper - lower) / 2);
      double v = 0;
      for (int k = 0; k < kHarmonics; ++k) {
        v += amp[j][k] * (std::sin(2 * std::numbers::pi * freq[j][k] * t + phase[j][k]) -
                          std::sin(phase[j][k]));
      }
      x[j] = std::clamp(home_inside ? envelope * half * v : centre + envelope * half * v, lower,
                        upper);
    }
    q = box.readings(x);
    log.t[r] = t;
    distance(r, 0) = prepared.forward(q.data()).p.norm() + noise.sigma_distance * gauss(rng);
    for (int j = 0; j < n; ++j)
      q[j] = quantized_reading(q[j], ratio[j], noise.motor_counts_per_rev);
    log.q.row(r) = q.transpose();
    log.line.push_back(r + 2);
  }
  kind_of(MeasurementType::kDistance).to_log(distance, log);
  return log;
}

}  // namespace hapticcal
