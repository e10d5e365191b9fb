// The static log of a recording (import --static): one row a pose the device
// stood still at, its readings and the tracker's samples averaged. A window's
// tracker samples must be of that pose: a window in which the tracker moved is
// left out, and so is one whose samples the clocks place at another time. The
// clocks are compared as calibrate's coarse search (coarse_clock_offset, in the
// library that links this one, so not callable here) compares them: the speed
// of the tool point (the model's, from the readings; without a model, of the
// readings themselves) against the tracker's, on a 10 ms grid, correlated over
// lags. A tracker stopping and starting a pose period late still stops where
// the readings stop, but its speeds match the readings' at the lag alone.
#include <fmt/format.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <optional>

#include "hapticcal/core/cancel.hpp"
#include "hapticcal/core/error.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "recording/import_streams.hpp"

namespace hapticcal::recording {
namespace {

constexpr double kStillTolerance = 1e-4;  // rad or m, unless --still-tolerance
constexpr double kTrackerStill = 1e-3;    // m, unless --tracker-still
constexpr double kGridSeconds = 0.01;
constexpr double kLagSearchSeconds = 10;  // +- this, as calibrate's default --clock-search
constexpr double kMaxGridPoints = 2e6;    // 5.5 h of 10 ms: a longer session is not compared
constexpr double kMaxLagWork = 1e9;       // products of the correlations over lags
constexpr double kMinLagSeconds = 0.05;   // a smaller lag is not named (5 grid steps)
constexpr double kMinCorrelation = 0.5;   // the speeds' at the lag found
constexpr double kMinGain = 0.1;          // over the correlation as stamped

// A still window's row: the mean of its readings (device rows [a, b]) and of
// the tracker's samples stamped within it less a tenth of it at either end (a
// quaternion's mean its sign-aligned sum normalised). Empty when the tracker
// has no sample there, or moved: a sample further than `tracker_still` from the
// samples' median (the tracker's clock not the device's?); `why` says which.
// The tracker's stamps are the device's times + `shift_ns` (--clock-offset).
std::optional<std::vector<double>> still_row(const Stream& device, const Stream& tracker,
                                             std::size_t a, std::size_t b, std::int64_t shift_ns,
                                             double tracker_still, std::string& why) {
  const std::vector<std::int64_t>& td = device.samples->stamp_ns;
  const std::vector<std::int64_t>& tt = tracker.samples->stamp_ns;
  const std::int64_t margin = (td[b] - td[a]) / 10;
  const auto first = std::lower_bound(tt.begin(), tt.end(), td[a] + margin + shift_ns);
  const auto last = std::upper_bound(tt.begin(), tt.end(), td[b] - margin + shift_ns);
  if (first >= last) return why = "empty", std::nullopt;
  std::vector<double> values, row(device.columns.size(), 0.0);
  for (std::size_t i = a; i <= b; ++i) {
    row_values(device, i, values);
    for (std::size_t k = 0; k < row.size(); ++k)
      row[k] += values[k] / static_cast<double>(b - a + 1);
  }
  std::vector<std::vector<double>> samples;
  for (auto it = first; it != last; ++it) {
    row_values(tracker, static_cast<std::size_t>(it - tt.begin()), values);
    samples.push_back(values);
  }
  // A pose or point topic's tracker still: every sample near the median point
  // (--field columns carry their own units and order: not checked).
  if (tracker.topic->kind != TopicKind::kFields) {
    Eigen::Vector3d median;
    for (int k = 0; k < 3; ++k) {
      std::vector<double> c;
      for (const auto& v : samples) c.push_back(v[k]);
      std::nth_element(c.begin(), c.begin() + static_cast<std::ptrdiff_t>(c.size() / 2), c.end());
      median[k] = c[c.size() / 2];
    }
    for (const auto& v : samples)
      if ((Eigen::Vector3d(v[0], v[1], v[2]) - median).norm() > tracker_still)
        return why = "moved", std::nullopt;
  }
  const bool quaternion = tracker.columns.size() == 7 && tracker.columns[3] == "qw";
  std::vector<double> mean(tracker.columns.size(), 0.0);
  for (std::vector<double>& v : samples) {
    if (quaternion &&
        v[3] * samples[0][3] + v[4] * samples[0][4] + v[5] * samples[0][5] + v[6] * samples[0][6] <
            0)
      for (int k = 3; k < 7; ++k) v[k] = -v[k];  // a quaternion and its negative are one turn
    for (std::size_t k = 0; k < mean.size(); ++k)
      mean[k] += v[k] / static_cast<double>(samples.size());
  }
  if (quaternion) {
    const double norm =
        std::sqrt(mean[3] * mean[3] + mean[4] * mean[4] + mean[5] * mean[5] + mean[6] * mean[6]);
    for (int k = 3; k < 7; ++k) mean[k] /= norm;
  }
  row.insert(row.end(), mean.begin(), mean.end());
  return row;
}

// A stream's speed on the grid T0 + i h (i < n): its values (a point, or the
// readings) interpolated linearly between samples no further apart than 5
// median intervals, differenced over 4 steps (40 ms); NaN where not covered.
std::vector<double> grid_speed(const std::vector<std::int64_t>& stamps, std::int64_t shift_ns,
                               const std::function<void(std::size_t, std::vector<double>&)>& value,
                               std::int64_t t0, std::int64_t h, std::size_t n) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> speed(n, nan);
  if (stamps.size() < 2) return speed;
  std::vector<std::int64_t> dt(stamps.size() - 1);
  for (std::size_t i = 1; i < stamps.size(); ++i) dt[i - 1] = stamps[i] - stamps[i - 1];
  std::nth_element(dt.begin(), dt.begin() + static_cast<std::ptrdiff_t>(dt.size() / 2), dt.end());
  const std::int64_t gap = 5 * dt[dt.size() / 2];
  std::vector<double> left, right, p;  // p: n rows of the values' width, NaN where not covered
  std::size_t j = 0, at = std::numeric_limits<std::size_t>::max(), width = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const std::int64_t t = t0 + static_cast<std::int64_t>(i) * h + shift_ns;
    while (j + 2 < stamps.size() && stamps[j + 1] <= t) ++j;
    if (t < stamps[j] || t > stamps[j + 1] || stamps[j + 1] - stamps[j] > gap) continue;
    if (at != j) value(j, left), value(j + 1, right), at = j;
    if (width == 0) width = left.size(), p.assign(n * width, nan);
    const double s =
        static_cast<double>(t - stamps[j]) / static_cast<double>(stamps[j + 1] - stamps[j]);
    for (std::size_t k = 0; k < width; ++k) p[i * width + k] = (1 - s) * left[k] + s * right[k];
  }
  for (std::size_t i = 2; width > 0 && i + 2 < n; ++i) {
    double sum = 0;
    for (std::size_t k = 0; k < width; ++k)
      sum += std::pow(p[(i + 2) * width + k] - p[(i - 2) * width + k], 2);
    speed[i] = std::sqrt(sum) / (4e-9 * static_cast<double>(h));  // NaN where either is
  }
  return speed;
}

// Pearson's correlation of a[i] and b[i + k] where both are known; NaN with
// fewer than `needed` pairs.
double correlation_at(const std::vector<double>& a, const std::vector<double>& b, long k,
                      std::size_t needed) {
  double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
  std::size_t m = 0;
  const long n = static_cast<long>(a.size());
  for (long i = std::max(0L, -k); i < std::min(n, n - k); ++i) {
    const double x = a[static_cast<std::size_t>(i)], y = b[static_cast<std::size_t>(i + k)];
    if (std::isnan(x) || std::isnan(y)) continue;
    sa += x, sb += y, saa += x * x, sbb += y * y, sab += x * y, ++m;
  }
  if (m < needed) return std::numeric_limits<double>::quiet_NaN();
  const double c = static_cast<double>(m);
  const double va = saa - sa * sa / c, vb = sbb - sb * sb / c;
  return va > 0 && vb > 0 ? (sab - sa * sb / c) / std::sqrt(va * vb) : 0.0;
}

// How far the tracker's clock seems ahead of the readings' (after --clock-offset).
struct TrackerLag {
  bool found = false;  // a lag of at least kMinLagSeconds, clearly the speeds' best
  double ahead = 0;    // s: the tracker's stamps less the readings' times
  double r = 0, r_stamped = 0;
};

TrackerLag tracker_lag(const Stream& device, const Stream& tracker, const DeviceModel* model,
                       std::int64_t shift_ns) {
  TrackerLag lag;
  const std::vector<std::int64_t>& td = device.samples->stamp_ns;
  const std::vector<std::int64_t>& tt = tracker.samples->stamp_ns;
  const bool positions = tracker.topic->kind != TopicKind::kFields && tracker.columns.size() >= 3;
  if (!positions || td.size() < 10 || tt.size() < 10) return lag;
  const std::int64_t h = static_cast<std::int64_t>(kGridSeconds * 1e9);
  const std::int64_t t0 = std::min(td.front(), tt.front() - shift_ns);
  const double span = static_cast<double>(std::max(td.back(), tt.back() - shift_ns) - t0);
  if (!(span / static_cast<double>(h) < kMaxGridPoints)) return lag;
  const auto n = static_cast<std::size_t>(span / static_cast<double>(h)) + 1;
  std::optional<PreparedModel> prepared;
  if (model != nullptr && static_cast<std::size_t>(model->dof()) == device.columns.size())
    prepared.emplace(*model);
  std::vector<double> readings;
  const std::vector<double> a = grid_speed(
      td, 0,
      [&](std::size_t i, std::vector<double>& out) {
        row_values(device, i, prepared ? readings : out);
        if (!prepared) return;
        const Eigen::Vector3d p = prepared->forward(readings.data()).p;
        out.assign(p.data(), p.data() + 3);
      },
      t0, h, n);
  const std::vector<double> b = grid_speed(
      tt, shift_ns,
      [&](std::size_t i, std::vector<double>& out) {
        row_values(tracker, i, out);
        out.resize(3);
      },
      t0, h, n);
  const auto known = [](const std::vector<double>& v) {
    return static_cast<std::size_t>(
        std::count_if(v.begin(), v.end(), [](double x) { return !std::isnan(x); }));
  };
  const std::size_t needed = std::max<std::size_t>(100, std::min(known(a), known(b)) / 2);
  const long steps = static_cast<long>(
      std::min(kLagSearchSeconds / kGridSeconds, kMaxLagWork / 2 / static_cast<double>(n)));
  std::vector<double> r(static_cast<std::size_t>(2 * steps + 1));
  long best = -1;
  for (long k = -steps; k <= steps; ++k) {
    throw_if_cancelled();  // up to kMaxLagWork products: Python's Ctrl-C (core/cancel.hpp)
    const auto i = static_cast<std::size_t>(k + steps);
    r[i] = correlation_at(a, b, k, needed);
    if (!std::isnan(r[i]) && (best < 0 || r[i] > r[static_cast<std::size_t>(best)]))
      best = static_cast<long>(i);
  }
  if (best <= 0 || best + 1 >= static_cast<long>(r.size())) return lag;  // none, or at an edge
  const auto i = static_cast<std::size_t>(best);
  double shift = 0;  // a parabola through the best and its neighbours
  if (!std::isnan(r[i - 1]) && !std::isnan(r[i + 1])) {
    const double curvature = r[i - 1] - 2 * r[i] + r[i + 1];
    if (curvature < 0) shift = 0.5 * (r[i - 1] - r[i + 1]) / curvature;
  }
  lag.ahead = (static_cast<double>(best - steps) + shift) * kGridSeconds;
  lag.r = r[i];
  lag.r_stamped = r[static_cast<std::size_t>(steps)];
  lag.found = std::abs(lag.ahead) >= kMinLagSeconds && lag.r >= kMinCorrelation &&
              !(lag.r_stamped > lag.r - kMinGain);
  return lag;
}

// What the lag found says, for the note and the refusal.
std::string lag_text(const TrackerLag& lag, double given) {
  return fmt::format(
      "the tracker's clock seems {:.3f} s {} the readings'{} (their speeds correlate best there, "
      "{:.2f}, against {:.2f} as stamped): give --clock-offset {:.3f}",
      std::abs(lag.ahead), lag.ahead > 0 ? "ahead of" : "behind",
      given != 0 ? fmt::format(" after --clock-offset {:g}", given) : "", lag.r,
      std::isnan(lag.r_stamped) ? 0.0 : lag.r_stamped, given + lag.ahead);
}

}  // namespace

std::string static_csv(const Stream& device, const Stream& tracker, const ImportRequest& request,
                       const DeviceModel* model, std::int64_t origin, const std::string& comment,
                       ImportResult& result) {
  const std::vector<std::int64_t>& td = device.samples->stamp_ns;
  const auto shift_ns = static_cast<std::int64_t>(std::llround(request.clock_offset * 1e9));
  const TrackerLag lag = tracker_lag(device, tracker, model, shift_ns);
  std::string out = comment + "t";
  for (const std::string& c : device.columns) out += "," + c;
  for (const std::string& c : tracker.columns) out += "," + c;
  out += "\n";
  const double still_tolerance = request.still_tolerance.value_or(kStillTolerance);
  const double tracker_still = request.tracker_still.value_or(kTrackerStill);
  std::vector<double> values, low, high;
  std::size_t windows = 0, empty = 0, moved = 0, elsewhere = 0;
  const auto close = [&](std::size_t a, std::size_t b) {  // device rows [a, b]
    if (1e-9 * static_cast<double>(td[b] - td[a]) < request.still_seconds) return;
    ++windows;
    // The tracker's samples chosen were taken `lag.ahead` earlier: still within
    // the window (before the readings' first sample or after their last: unknown)?
    const double margin = 1e-10 * static_cast<double>(td[b] - td[a]);
    if (lag.found && ((lag.ahead > margin && a > 0) || (lag.ahead < -margin && b + 1 < td.size())))
      return void(++elsewhere);
    std::string why;
    const std::optional<std::vector<double>> row =
        still_row(device, tracker, a, b, shift_ns, tracker_still, why);
    if (!row) return void(++(why == "moved" ? moved : empty));
    out += seconds_text((td[a] + td[b]) / 2 - origin);
    for (const double v : *row) out += fmt::format(",{}", v);
    out += "\n";
    ++result.static_rows;
  };
  std::size_t start = 0;
  for (std::size_t i = 0; i < td.size(); ++i) {
    if ((i & 4095) == 0) throw_if_cancelled();  // Python's Ctrl-C (core/cancel.hpp)
    row_values(device, i, values);
    if (i == start) {
      low = high = values;
      continue;
    }
    bool still = true;
    for (std::size_t k = 0; k < values.size(); ++k) {
      low[k] = std::min(low[k], values[k]), high[k] = std::max(high[k], values[k]);
      still = still && high[k] - low[k] <= still_tolerance;
    }
    if (still) continue;
    close(start, i - 1);
    start = i;
    low = high = values;
  }
  if (!td.empty()) close(start, td.size() - 1);
  const std::string clocks =
      lag.found ? "; " + lag_text(lag, request.clock_offset)
      : model == nullptr
          ? "; the clocks were compared by the readings' own speed (no --model): a tracker a "
            "whole pose period off passes so, --model compares the tool point's speed"
          : "";
  result.notes.push_back(fmt::format(
      "{} still windows of at least {:g} s (readings within {:g}); left out: {} without a "
      "tracker sample, {} in which the tracker moved by more than {:g} m (its clock not the "
      "device's?), {} whose tracker samples are of another time{}",
      windows, request.still_seconds, still_tolerance, empty, moved, tracker_still, elsewhere,
      clocks));
  if (result.static_rows == 0) {
    throw InputError(
        request.recording, 0, "--static",
        fmt::format("no window of at least {:g} s with the readings within {:g} and the tracker "
                    "still ({} still windows: {} without a tracker sample, {} with the tracker "
                    "moving, {} with another time's tracker samples){}",
                    request.still_seconds, still_tolerance, windows, empty, moved, elsewhere,
                    lag.found ? "; " + lag_text(lag, request.clock_offset)
                              : std::string("; if the clocks differ, --time receive takes the "
                                            "recorder's stamps, --clock-offset shifts the "
                                            "tracker's")));
  }
  return out;
}

}  // namespace hapticcal::recording
