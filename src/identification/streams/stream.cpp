// Two streams on two clocks (identification/stream.hpp): the readings between
// their samples, the checks of a pair of streams and the coarse search of the
// clocks' offset.
#include "hapticcal/identification/stream.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <unordered_map>

#include "hapticcal/core/cancel.hpp"
#include "hapticcal/core/error.hpp"
#include "hapticcal/core/log_rows.hpp"
#include "hapticcal/identification/measurement.hpp"
#include "hapticcal/kinematics/kinematics.hpp"

namespace hapticcal {
namespace {

// The coarse search's grid step [s] and the speeds' smoothing (a centred box
// of this many grid steps, the same on both streams so that it adds no lag).
constexpr double kGridStep = 0.01;
constexpr int kSmoothing = 5;
// An offset is a candidate only where the streams share at least this share
// of the shorter one's valid speeds (and kMinPairs): a short overlap can
// correlate by chance.
constexpr double kMinOverlapShare = 0.5;
constexpr int kMinPairs = 100;
// A stream's samples are at most this far apart (median) [s]: a time in
// milliseconds read as seconds puts a 1 kHz stream's 1 s apart, a 120 Hz one's 8 s.
constexpr double kMaxMedianInterval = 0.5;
// A stream may span at most this many grid steps a sample (its gaps
// included): the search's grids then hold at most 4 kB a sample of the input.
constexpr double kMaxGridPerSample = 100;
// The coarse search's work (offsets x grid points) at most: about 5 s.
constexpr double kMaxSearchWork = 4e9;
// Below this correlation of the speeds the streams do not show the same motion.
constexpr double kMinCorrelation = 0.3;
// A tracker sample further from its neighbourhood's median (two samples either
// side, no gap between) than this many times the stream's 99th percentile of
// that distance is a glitch: a clean 120 Hz stream's largest is 2x its 99th
// percentile; the percentile holds while glitches are fewer than 1 %.
constexpr double kGlitchFactor = 10;
constexpr double kGlitchQuantile = 0.99;
constexpr double kGlitchStepShare = 0.1;

double median_step(const Eigen::VectorXd& t) {
  std::vector<double> dt(static_cast<size_t>(t.size() - 1));
  for (Eigen::Index i = 0; i + 1 < t.size(); ++i) dt[static_cast<size_t>(i)] = t[i + 1] - t[i];
  std::nth_element(dt.begin(), dt.begin() + static_cast<std::ptrdiff_t>(dt.size() / 2), dt.end());
  return dt[dt.size() / 2];
}

void check_times(const Log& log, const char* role) {
  if (!log.has_time) {
    throw InputError(log.origin, 0, "t",
                     fmt::format("the {} log has no time column t: each stream needs its own "
                                 "clock's time [s] (or [ms]) to be aligned",
                                 role));
  }
  if (log.rows < 2 * kSmoothing) {
    throw InputError(log.origin, log.rows > 0 ? log.line.front() : 0, "t",
                     fmt::format("the {} stream has {} samples; a stream needs at least {}", role,
                                 log.rows, 2 * kSmoothing));
  }
  for (int r = 1; r < log.rows; ++r) {
    if (!(log.t[r] > log.t[r - 1])) {
      throw InputError(
          log.origin, log.line[static_cast<size_t>(r)], "t",
          fmt::format("time {} s does not follow {} s of line {}: a stream's times must increase",
                      log.t[r], log.t[r - 1], log.line[static_cast<size_t>(r - 1)]));
    }
  }
  // The time's unit, before any grid is sized: milliseconds read as seconds
  // put the samples a thousand times too far apart.
  const double interval = median_step(log.t);
  if (interval > kMaxMedianInterval) {
    throw InputError(
        log.origin, log.line.front(), "t",
        fmt::format("the {} stream's samples are {:g} s apart (the median of {} intervals; at most "
                    "{:g} s): is t in seconds? A time in milliseconds is read with t [ms] in the "
                    "header",
                    role, interval, log.rows - 1, kMaxMedianInterval));
  }
  // A stream's span in grid steps, against its samples: long gaps would ask
  // for a grid far larger than the input.
  const double span = log.t[log.rows - 1] - log.t[0];
  if (!std::isfinite(span) || span / kGridStep > kMaxGridPerSample * log.rows + 1e5) {
    throw InputError(log.origin, log.line.back(), "t",
                     fmt::format("the {} stream's {} samples span {:g} s: more than {:g} s a "
                                 "sample, its gaps far longer than its samples (calibrate the "
                                 "parts between the long pauses on their own)",
                                 role, log.rows, span, kMaxGridPerSample * kGridStep));
  }
}

// Smoothed speeds on a uniform grid (NaN where not known) from positions
// given at the grid's times (NaN where not known).
std::vector<double> grid_speeds(const std::vector<Eigen::Vector3d>& p, double h) {
  const size_t n = p.size();
  std::vector<double> v(n, std::nan("")), out(n, std::nan(""));
  for (size_t i = 1; i + 1 < n; ++i) v[i] = (p[i + 1] - p[i - 1]).norm() / (2 * h);
  const int half = kSmoothing / 2;
  for (size_t i = half; i + half < n; ++i) {
    double sum = 0;
    for (int k = -half; k <= half; ++k) sum += v[i + static_cast<size_t>(k)];
    out[i] = sum / kSmoothing;  // NaN if any is
  }
  return out;
}

std::vector<Eigen::Vector3d> device_grid_positions(const DeviceModel& nominal, const Log& device,
                                                   double t0, size_t n) {
  const ReadingInterpolator readings(device);
  const PreparedModel prepared(nominal);
  Eigen::VectorXd q(device.dof());
  std::vector<Eigen::Vector3d> p(n, Eigen::Vector3d::Constant(std::nan("")));
  for (size_t i = 0; i < n; ++i) {
    if (readings.at(t0 + static_cast<double>(i) * kGridStep, q.data()))
      p[i] = prepared.forward(q.data()).p;
  }
  return p;
}

// The tracker's positions on the grid, linear between samples, none across a gap.
std::vector<Eigen::Vector3d> tracker_grid_positions(const Log& tracker, double t0, size_t n) {
  const double gap = ReadingInterpolator::kGapFactor * median_step(tracker.t);
  std::vector<Eigen::Vector3d> p(n, Eigen::Vector3d::Constant(std::nan("")));
  Eigen::Index k = 0;
  for (size_t i = 0; i < n; ++i) {
    const double t = t0 + static_cast<double>(i) * kGridStep;
    while (k + 1 < tracker.rows && tracker.t[k + 1] < t) ++k;
    if (k + 1 >= tracker.rows || t < tracker.t[k]) continue;
    const double h = tracker.t[k + 1] - tracker.t[k];
    if (h > gap) continue;
    const double s = (t - tracker.t[k]) / h;
    p[i] =
        (1 - s) * tracker.position.row(k).transpose() + s * tracker.position.row(k + 1).transpose();
  }
  return p;
}

struct Correlation {
  double r = -2;
  int pairs = 0;
};

// Pearson correlation of a[i + lag] and b[i] over the pairs both know.
Correlation correlate(const std::vector<double>& a, const std::vector<double>& b, long lag) {
  double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
  int n = 0;
  const long lo = std::max(0L, -lag),
             hi = std::min<long>(static_cast<long>(b.size()), static_cast<long>(a.size()) - lag);
  for (long j = lo; j < hi; ++j) {
    const double x = a[static_cast<size_t>(j + lag)], y = b[static_cast<size_t>(j)];
    if (std::isnan(x) || std::isnan(y)) continue;
    sa += x, sb += y, saa += x * x, sbb += y * y, sab += x * y;
    ++n;
  }
  Correlation c;
  c.pairs = n;
  if (n < 2) return c;
  const double cov = sab - sa * sb / n, va = saa - sa * sa / n, vb = sbb - sb * sb / n;
  c.r = va > 0 && vb > 0 ? cov / std::sqrt(va * vb) : 0;
  return c;
}

int known(const std::vector<double>& v) {
  return static_cast<int>(
      std::count_if(v.begin(), v.end(), [](double x) { return !std::isnan(x); }));
}

// How far each tracker sample lies from the componentwise median of the five
// samples about it (NaN where they span a gap or the stream's ends).
std::vector<double> neighbourhood_distances(const Eigen::MatrixXd& p, const Eigen::VectorXd& t,
                                            double gap) {
  const Eigen::Index n = p.rows();
  std::vector<double> d(static_cast<size_t>(n), std::nan(""));
  std::array<double, 5> w{};
  for (Eigen::Index r = 2; r + 2 < n; ++r) {
    bool spans_gap = false;
    for (Eigen::Index k = r - 2; k < r + 2; ++k) spans_gap |= t[k + 1] - t[k] > gap;
    if (spans_gap) continue;
    Eigen::Vector3d median;
    for (int c = 0; c < 3; ++c) {
      for (int k = 0; k < 5; ++k) w[static_cast<size_t>(k)] = p(r - 2 + k, c);
      std::nth_element(w.begin(), w.begin() + 2, w.end());
      median[c] = w[2];
    }
    const double distance = (p.row(r).transpose() - median).norm();
    d[static_cast<size_t>(r)] = std::isfinite(distance) ? distance : HUGE_VAL;
  }
  return d;
}

}  // namespace

std::vector<int> tracker_glitches(const Log& tracker) {
  if (tracker.rows < 5 || !tracker.has_time) return {};
  const double gap = ReadingInterpolator::kGapFactor * median_step(tracker.t);
  // Each marker's (a tree's, one a tip) positions, or the tool point's.
  std::vector<Eigen::MatrixXd> points;
  if (tracker.marker_count > 0) {
    for (int m = 0; m < tracker.marker_count; ++m)
      points.push_back(tracker.markers.middleCols(3 * m, 3));
  } else if (holds(tracker, MeasurementType::kPosition)) {
    points.push_back(tracker.position);
  }
  std::vector<bool> glitch(static_cast<size_t>(tracker.rows), false);
  for (const Eigen::MatrixXd& p : points) {
    const std::vector<double> d = neighbourhood_distances(p, tracker.t, gap);
    std::vector<double> known;
    for (const double x : d)
      if (!std::isnan(x)) known.push_back(x);
    if (known.size() < 100) continue;
    const auto q = static_cast<std::ptrdiff_t>(kGlitchQuantile * static_cast<double>(known.size()));
    std::nth_element(known.begin(), known.begin() + q, known.end());
    // Not below a tenth of the median step between samples: a stream without
    // noise has distances of 0 wherever it moves monotonically.
    std::vector<double> steps;
    for (Eigen::Index r = 0; r + 1 < p.rows(); ++r)
      steps.push_back((p.row(r + 1) - p.row(r)).norm());
    std::nth_element(steps.begin(), steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2),
                     steps.end());
    const double limit = kGlitchFactor * std::max(known[static_cast<size_t>(q)],
                                                  kGlitchStepShare * steps[steps.size() / 2]);
    for (size_t r = 0; r < d.size(); ++r)
      if (d[r] > limit) glitch[r] = true;
  }
  std::vector<int> out;
  for (int r = 0; r < tracker.rows; ++r)
    if (glitch[static_cast<size_t>(r)]) out.push_back(r);
  return out;
}

std::string fast_motion_note(const Log& tracker, const std::vector<int>& lines) {
  constexpr size_t kFewest = 3;
  if (lines.size() < kFewest || tracker.rows < 3 || !tracker.has_time ||
      !holds(tracker, MeasurementType::kPosition))
    return "";
  std::vector<double> speed(static_cast<size_t>(tracker.rows), 0.0);
  std::unordered_map<int, int> row_of;
  for (int r = 0; r < tracker.rows; ++r) {
    if (r < static_cast<int>(tracker.line.size())) row_of[tracker.line[r]] = r;
    const int a = std::max(r - 1, 0), b = std::min(r + 1, tracker.rows - 1);
    const double dt = tracker.t[b] - tracker.t[a];
    speed[r] = dt > 0 ? (tracker.position.row(b) - tracker.position.row(a)).norm() / dt : 0.0;
  }
  std::vector<double> sorted = speed;
  const auto quartile = static_cast<std::ptrdiff_t>(3 * sorted.size() / 4);
  std::nth_element(sorted.begin(), sorted.begin() + quartile, sorted.end());
  const double fast = sorted[static_cast<size_t>(quartile)];
  size_t at_speed = 0, found = 0;
  for (const int line : lines) {
    const auto it = row_of.find(line);
    if (it == row_of.end()) continue;
    ++found;
    at_speed += speed[static_cast<size_t>(it->second)] > fast;
  }
  if (found < kFewest || 3 * at_speed < 2 * found) return "";
  return fmt::format(
      "{} of the {} samples flagged as outliers are at fast motion (the tool above {:.0f} mm/s, "
      "the session's upper quartile): residuals that grow with the speed are the clocks' (an "
      "offset or a lag left between the streams), not bad measurements",
      at_speed, found, 1e3 * fast);
}

Log without_rows(const Log& log, const std::vector<int>& rows) {
  std::vector<int> keep;
  size_t next = 0;
  for (int r = 0; r < log.rows; ++r) {
    if (next < rows.size() && rows[next] == r) {
      ++next;
      continue;
    }
    keep.push_back(r);
  }
  return select_rows(log, keep);
}

ReadingInterpolator::ReadingInterpolator(const Log& device) : log_(device) {
  if (device.rows < 2 || device.t.size() != device.rows) {
    throw InputError(device.origin, 0, "t", "a stream to interpolate needs times and 2 samples");
  }
  t_.assign(device.t.data(), device.t.data() + device.t.size());
  median_dt_ = median_step(device.t);
  max_gap_ = kGapFactor * median_dt_;
}

bool ReadingInterpolator::at(double t, double* q, double* ext) const {
  const size_t n = t_.size();
  if (!(t >= t_.front() && t <= t_.back())) return false;
  size_t k = static_cast<size_t>(std::upper_bound(t_.begin(), t_.end(), t) - t_.begin());
  k = std::min(k == 0 ? 0 : k - 1, n - 2);
  const double h = t_[k + 1] - t_[k];
  if (h > max_gap_) return false;
  // The slope at a sample: the chord of its neighbours, one-sided at an end or a gap.
  const auto slope = [&](const Eigen::MatrixXd& y, Eigen::Index c, size_t i) {
    const size_t lo = i > 0 && t_[i] - t_[i - 1] <= max_gap_ ? i - 1 : i;
    const size_t hi = i + 1 < n && t_[i + 1] - t_[i] <= max_gap_ ? i + 1 : i;
    const auto a = static_cast<Eigen::Index>(lo), b = static_cast<Eigen::Index>(hi);
    return (y(b, c) - y(a, c)) / (t_[hi] - t_[lo]);
  };
  const double s = (t - t_[k]) / h, s2 = s * s, s3 = s2 * s;
  const double h00 = 2 * s3 - 3 * s2 + 1, h10 = s3 - 2 * s2 + s, h01 = -2 * s3 + 3 * s2,
               h11 = s3 - s2;
  const auto a = static_cast<Eigen::Index>(k);
  const auto value = [&](const Eigen::MatrixXd& y, Eigen::Index c) {
    return h00 * y(a, c) + h10 * h * slope(y, c, k) + h01 * y(a + 1, c) +
           h11 * h * slope(y, c, k + 1);
  };
  for (int j = 0; j < log_.dof(); ++j) q[j] = value(log_.q, j);
  if (ext) {
    for (int j = 0; j < log_.dof(); ++j)
      ext[j] = log_.has_ext[static_cast<size_t>(j)] ? value(log_.ext, j) : 0.0;
  }
  return true;
}

void check_streams(const Log& device, const Log& tracker) {
  check_times(device, "device");
  check_times(tracker, "tracker");
  if (device.dof() == 0) {
    throw InputError(device.origin, 0, "q1",
                     "the device log has no joint readings q<i>: the readings come from the "
                     "device's stream, the positions from the tracker's");
  }
  if (!holds(tracker, MeasurementType::kPosition)) {
    throw InputError(tracker.origin, 0, "x",
                     "the tracker log has no positions x, y, z: the tracker's stream gives the "
                     "measurements, the device's the readings");
  }
  if (tracker.marker_count > 0) {
    throw InputError(tracker.origin, 0, "x1",
                     "a marker body's stream is aligned as the body's poses (calibrate_streams "
                     "turns the markers into poses first)");
  }
  if (const std::vector<MeasurementType> held = kinds_in(device); !held.empty()) {
    throw InputError(device.origin, 0, traits(held.front()).name,
                     "the device log has measurements: with --tracker they come from the tracker "
                     "log only");
  }
}

std::pair<double, double> coarse_clock_offset(const DeviceModel& nominal, const Log& device,
                                              const Log& tracker, double range) {
  const double d0 = device.t[0], t0 = tracker.t[0];
  const auto count = [](double span) { return static_cast<size_t>(span / kGridStep) + 1; };
  const std::vector<double> a = grid_speeds(
      device_grid_positions(nominal, device, d0, count(device.t[device.rows - 1] - d0)), kGridStep);
  const std::vector<double> b = grid_speeds(
      tracker_grid_positions(tracker, t0, count(tracker.t[tracker.rows - 1] - t0)), kGridStep);
  // Tracker grid j (time t0 + j h) against device grid j + k: offset d0 - t0 + k h.
  const double base = d0 - t0;
  const long k_lo = static_cast<long>(std::ceil((-range - base) / kGridStep));
  const long k_hi = static_cast<long>(std::floor((range - base) / kGridStep));
  const int needed =
      std::max(kMinPairs, static_cast<int>(kMinOverlapShare * std::min(known(a), known(b))));
  const double work = static_cast<double>(std::max(0L, k_hi - k_lo + 1)) *
                      static_cast<double>(std::min(a.size(), b.size()));
  if (work > kMaxSearchWork) {
    throw InputError(
        tracker.origin, tracker.line.front(), "t",
        fmt::format("searching +-{:g} s for the clocks' offset over a {:.0f} s "
                    "stream is {:.2g} products (at most {:.2g}): give a smaller "
                    "--clock-search",
                    range, static_cast<double>(b.size()) * kGridStep, work, kMaxSearchWork));
  }
  std::vector<double> r(static_cast<size_t>(std::max(0L, k_hi - k_lo + 1)), -2);
  long best = -1;
  for (long k = k_lo; k <= k_hi; ++k) {
    if ((k - k_lo) % 64 == 0) throw_if_cancelled();
    const Correlation c = correlate(a, b, k);
    if (c.pairs < needed) continue;
    const auto i = static_cast<size_t>(k - k_lo);
    r[i] = c.r;
    if (best < 0 || c.r > r[static_cast<size_t>(best)]) best = static_cast<long>(i);
  }
  if (best < 0) {
    throw InputError(
        tracker.origin, tracker.line.front(), "t",
        fmt::format("no overlap between the clocks: the device stream covers {:.6g} to {:.6g} s, "
                    "the tracker's {:.6g} to {:.6g} s, and no offset within +-{:g} s makes them "
                    "share {} samples of motion (widen the search with --clock-search)",
                    device.t[0], device.t[device.rows - 1], tracker.t[0],
                    tracker.t[tracker.rows - 1], range, needed));
  }
  const auto i = static_cast<size_t>(best);
  const double found = base + static_cast<double>(k_lo + best) * kGridStep;
  if (r.size() > 2 && (i == 0 || i + 1 == r.size())) {
    throw InputError(
        tracker.origin, tracker.line.front(), "t",
        fmt::format("the tool point's speeds in {} and {} correlate best ({:.3f}) at an offset of "
                    "{:.3f} s, the edge of the search (+-{:g} s): the clocks' offset may lie "
                    "beyond it (widen --clock-search)",
                    device.origin, tracker.origin, r[i], found, range));
  }
  if (!(r[i] >= kMinCorrelation)) {
    throw InputError(tracker.origin, tracker.line.front(), "t",
                     fmt::format("the tool point's speed in the two streams correlates at most "
                                 "{:.3f} (at an offset of {:.3f} s; at least {:g} is needed): "
                                 "the handle hardly moved, or the streams are not of one session",
                                 r[i], found, kMinCorrelation));
  }
  double shift = 0;
  if (i > 0 && i + 1 < r.size() && r[i - 1] > -2 && r[i + 1] > -2) {
    const double curvature = r[i - 1] - 2 * r[i] + r[i + 1];
    if (curvature < 0) shift = 0.5 * (r[i - 1] - r[i + 1]) / curvature;
  }
  return {base + (static_cast<double>(k_lo + best) + shift) * kGridStep, r[i]};
}

Log readings_at_tracker(const ReadingInterpolator& readings, const Log& device, const Log& tracker,
                        const std::vector<int>& samples, const StreamClock& clock,
                        std::vector<int>& kept) {
  const int n = device.dof();
  const auto most = static_cast<Eigen::Index>(samples.size());
  Eigen::MatrixXd q_at(most, n), ext_at(most, n);
  Eigen::VectorXd q(n), ext(n);
  kept.clear();
  for (const int r : samples) {
    const double t = clock.device_time(tracker.t[r]);
    // The velocity (the clock's column) needs readings either side.
    if (!readings.around(t, q.data(), ext.data()) || !readings.at(t, q.data(), ext.data()))
      continue;
    const auto row = static_cast<Eigen::Index>(kept.size());
    q_at.row(row) = q.transpose();
    ext_at.row(row) = ext.transpose();
    kept.push_back(r);
  }
  // The tracker's samples kept, with whatever they measure, and the device's
  // readings at each.
  Log out = select_rows(tracker, kept);
  const auto m = static_cast<Eigen::Index>(kept.size());
  out.q = q_at.topRows(m);
  out.ext = ext_at.topRows(m);
  out.direction.setZero(m, n);
  out.q_unit = device.q_unit;
  out.q_column = device.q_column;
  out.ext_unit = device.ext_unit;
  out.ext_column = device.ext_column;
  out.has_ext = device.has_ext;
  out.has_direction.assign(static_cast<size_t>(n), false);
  out.comment.clear();  // the tracker's file's, not the readings'
  return out;
}

}  // namespace hapticcal
