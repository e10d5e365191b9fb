// A simulated hand-guided session on two clocks (study/session.hpp).
#include "hapticcal/study/session.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/measurement.hpp"
#include "hapticcal/kinematics/kinematics.hpp"

namespace hapticcal {
namespace {

constexpr int kSinusoids = 5;
constexpr double kSpread = 2.5;

// Each reading a sum of sinusoids within `coverage` of its half range about
// the middle of its limits: smooth, bounded, and wandering over the workspace.
class HandMotion {
 public:
  HandMotion(const DeviceModel& model, const SessionOptions& o, std::mt19937_64& rng)
      : box_(model.limit_coordinates()) {
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (int i = 0; i < model.dof(); ++i) {
      Joint j;
      j.centre = (box_.lower[i] + box_.upper[i]) / 2;
      j.half = o.coverage * (box_.upper[i] - box_.lower[i]) / 2;
      double total = 0;
      for (int k = 0; k < kSinusoids; ++k) {
        j.frequency[k] = 0.05 + (o.max_frequency_hz - 0.05) * unit(rng);
        j.phase[k] = 2 * std::numbers::pi * unit(rng);
        j.amplitude[k] = 0.2 + unit(rng);
        total += j.amplitude[k];
      }
      for (double& a : j.amplitude) a /= total;
      joints_.push_back(j);
    }
    // At rest: home (every reading 0) where the limits hold it, else the middle.
    home_ = Eigen::VectorXd::Zero(model.dof());
    if (!model.within_limits(home_)) home_ = box_.middle();
    rest_ = o.rest_seconds;
  }
  void at(double t, double* q) const {
    Eigen::Map<Eigen::VectorXd> out(q, static_cast<Eigen::Index>(joints_.size()));
    for (size_t i = 0; i < joints_.size(); ++i) {
      const Joint& j = joints_[i];
      double v = 0;
      for (int k = 0; k < kSinusoids; ++k)
        v += j.amplitude[k] * std::sin(2 * std::numbers::pi * j.frequency[k] * t + j.phase[k]);
      // A smooth saturation spreads the sum (RMS about a third of its bound)
      // over the range, as a hand sweeping the workspace does.
      out[static_cast<Eigen::Index>(i)] =
          j.centre + j.half * std::tanh(kSpread * v) / std::tanh(kSpread);
    }
    if (box_.ranged) out = box_.readings(out);
    if (rest_ > 0) {  // at home, then picked up over kPickUpSeconds
      const double u = std::clamp((t - rest_) / kPickUpSeconds, 0.0, 1.0);
      out = home_ + u * u * (3 - 2 * u) * (out - home_);
    }
  }

 private:
  static constexpr double kPickUpSeconds = 2;
  struct Joint {
    double centre = 0, half = 0;
    double frequency[kSinusoids], phase[kSinusoids], amplitude[kSinusoids];
  };
  DeviceModel::LimitCoordinates box_;
  std::vector<Joint> joints_;
  Eigen::VectorXd home_;
  double rest_ = 0;
};

Log empty_log(const DeviceModel& model, const char* origin, Eigen::Index rows, bool readings) {
  Log log;
  log.origin = origin;
  const int n = readings ? model.dof() : 0;
  log.q.resize(rows, n);
  log.ext.resize(0, n);
  log.direction.resize(0, n);
  log.has_ext.assign(static_cast<size_t>(n), false);
  log.has_direction.assign(static_cast<size_t>(n), false);
  log.q_unit.assign(static_cast<size_t>(n), ReadingUnit::kNone);
  for (int j = 0; j < n; ++j) log.q_column.push_back("q" + std::to_string(j + 1));
  log.has_time = true;
  log.t.resize(rows);
  return log;
}

// What the tracker records of the actual device at readings q: each tip's point
// (a tree's), or the tool point with its orientation (a 6-D tracker's:
// x, y, z, qw, qx, qy, qz), or a marker body's markers, with their noise.
// `gauss` is the session's: the positions' noise draws as they always did.
Eigen::VectorXd tracked(const DeviceModel& actual, const PreparedModel& prepared,
                        const Eigen::VectorXd& q, const SessionOptions& o, std::mt19937_64& rng,
                        std::normal_distribution<double>& gauss) {
  const auto noise = [&] {
    Eigen::Vector3d v;
    for (int k = 0; k < 3; ++k) v[k] = gauss(rng);
    return v;
  };
  const int tips = actual.tips();
  if (actual.tree() || (!o.orientation && o.marker_body.cols() == 0)) {
    Eigen::VectorXd p(3 * tips);
    for (int t = 0; t < tips; ++t)
      p.segment<3>(3 * t) = prepared.forward(q.data(), t).p + o.sigma_position * noise();
    return p;
  }
  const Frame<double> pose = prepared.forward(q.data());
  if (o.marker_body.cols() > 0) {
    Eigen::VectorXd p(3 * o.marker_body.cols());
    for (Eigen::Index k = 0; k < o.marker_body.cols(); ++k)
      p.segment<3>(3 * k) =
          pose * Eigen::Vector3d(o.marker_body.col(k)) + o.sigma_position * noise();
    return p;
  }
  const Eigen::Vector3d turn = o.sigma_orientation * noise();
  const Eigen::Matrix3d R =
      pose.R *
      Eigen::AngleAxisd(turn.norm(), turn.norm() > 0 ? turn.normalized() : Eigen::Vector3d::UnitX())
          .toRotationMatrix();
  const Eigen::Quaterniond quaternion(R);
  Eigen::VectorXd p(7);
  p << pose.p + o.sigma_position * noise(), quaternion.w(), quaternion.x(), quaternion.y(),
      quaternion.z();
  return p;
}

}  // namespace

Session simulate_session(const DeviceModel& actual, const SessionOptions& o, std::uint64_t seed) {
  if (!(o.clock_drift > -0.5 && o.clock_drift < 0.5) || !(o.tracker_rate_hz > 0) ||
      !(o.device_rate_hz > 0) || !(o.seconds > 0)) {
    throw InputError("simulate_session: rates and seconds must be positive and |drift| < 0.5");
  }
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const HandMotion motion(actual, o, rng);
  const int n = actual.dof();
  Session s;
  s.clock = {o.clock_offset, o.clock_drift, o.tracker_start};

  // The device: its clock is the session's time; a stamp's jitter is its error.
  const auto rows = static_cast<Eigen::Index>(std::floor(o.seconds * o.device_rate_hz)) + 1;
  s.device = empty_log(actual, "simulated device stream", rows, true);
  double last = -1;
  for (Eigen::Index r = 0; r < rows; ++r) {
    const double t = static_cast<double>(r) / o.device_rate_hz;
    Eigen::VectorXd q(n);
    motion.at(t, q.data());
    s.device.q.row(r) = q.transpose();
    const double stamp = std::max(t + o.device_jitter * gauss(rng), last + 1e-3 / o.device_rate_hz);
    s.device.t[r] = last = stamp;
    s.device.line.push_back(static_cast<int>(r) + 2);
  }
  s.device.rows = static_cast<int>(rows);

  // The tracker: its clock ticks at its rate from tracker_start; a sample's
  // instant (device time) follows from the clocks, plus the stamp's jitter.
  const PreparedModel prepared(actual);
  std::vector<double> stamps;
  // A tree's: each tip's marker (x1, y1, z1, ...); a chain's: the tool point.
  const int tips = actual.tips();
  std::vector<Eigen::VectorXd> points;
  const double period = 1 / o.tracker_rate_hz;
  // Dropouts start at random with the rate that loses dropout_share of the time.
  const double start_rate = o.dropout_share / std::max(o.dropout_seconds, 1e-9);
  double occluded_until = -1;
  Eigen::VectorXd q(n);
  // The first sample at or after the session's start, in closed form (a clock
  // far from the device's need not be walked through).
  const double first =
      std::ceil(-(o.tracker_start + o.clock_offset) / (period * (1 + o.clock_drift)));
  for (long j = static_cast<long>(std::max(0.0, first - 2));; ++j) {
    const double stamp = o.tracker_start + static_cast<double>(j) * period;
    const double instant = s.clock.device_time(stamp) + o.tracker_jitter * gauss(rng);
    if (instant > o.seconds) break;
    if (instant < 0) continue;
    if (o.dropout_share > 0 && unit(rng) < start_rate * period)
      occluded_until = instant + o.dropout_seconds * -std::log(1 - unit(rng));
    if (instant < occluded_until) {
      ++s.dropped;
      continue;
    }
    motion.at(instant, q.data());
    stamps.push_back(stamp);
    points.push_back(tracked(actual, prepared, q, o, rng, gauss));
  }
  const auto m = static_cast<Eigen::Index>(stamps.size());
  s.tracker = empty_log(actual, "simulated tracker stream", m, false);
  const int markers = actual.tree() ? tips : static_cast<int>(o.marker_body.cols());
  // Each sample's values: the markers' (or a tree's tips') points, else the
  // tool's position or pose, which that kind puts in the log.
  const MeasurementType kind = o.orientation ? MeasurementType::kPose : MeasurementType::kPosition;
  MeasuredValues values(m, markers > 0 ? 3 * markers : traits(kind).width);
  for (Eigen::Index r = 0; r < m; ++r) {
    s.tracker.t[r] = stamps[static_cast<size_t>(r)];
    values.row(r) = points[static_cast<size_t>(r)].head(values.cols()).transpose();
    s.tracker.line.push_back(static_cast<int>(r) + 2);
  }
  if (markers > 0) {
    s.tracker.marker_count = markers;
    s.tracker.markers = values;
  } else {
    kind_of(kind).to_log(values, s.tracker);
  }
  s.tracker.rows = static_cast<int>(m);
  return s;
}

}  // namespace hapticcal
