// Two streams on two clocks (identification/stream.hpp): the kinematics and
// the clock estimated together, by variable projection.
#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "hapticcal/core/cancel.hpp"
#include "hapticcal/core/error.hpp"
#include "hapticcal/core/option_ranges.hpp"
#include "hapticcal/identification/markers.hpp"
#include "hapticcal/identification/measurement.hpp"
#include "hapticcal/identification/stream.hpp"
#include "hapticcal/identification/tree.hpp"
#include "hapticcal/identification/two_step.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "identification/problem/stack.hpp"
#include "identification/streams/clock_step.hpp"

namespace hapticcal {
namespace {

using detail::check_clock;
using detail::clock_step;
using detail::clock_verdict;
using detail::ClockCheck;
using detail::ClockStep;
using detail::held_clock_step;
using detail::tool_velocity;

// The clock has converged when a step moves it by less than this anywhere in
// the session [s].
constexpr double kClockTolerance = 1e-7;
// ... or by less than this share of its sd.
constexpr double kClockSds = 0.01;
// The residual curve of the report: this many offsets over +-max(kCurveMin,
// kCurveSds sd) about the estimate, on at most kCurveSamples samples.
constexpr int kCurvePoints = 81;
constexpr double kCurveMin = 0.02, kCurveSds = 10;
constexpr int kCurveSamples = 2000;
// The glitches named one by one on the terminal.
constexpr size_t kGlitchesNamed = 5;

// A tree's tracker stream (x1, y1, z1 the first tip's marker, ...) as its
// first tip's positions: the clock's search, the samples and the residual
// curve follow that tip (the prepared tree's forward(q) is its pose).
Log first_tip_stream(const Log& tracker) {
  Log first = tracker;  // one marker a tip (calibrate_streams checks)
  first.marker_count = 0;
  first.markers.resize(0, 0);
  kind_of(MeasurementType::kPosition).to_log(tracker.markers.leftCols(3), first);
  return first;
}

// The samples at a clock: the readings at the tracker's times with its
// positions; a tree's as one sample a tip of its markers (tip_samples).
Log samples_at(const DeviceModel& nominal, const ReadingInterpolator& readings, const Log& device,
               const Log& tracker, const Log& first, const std::vector<int>& rows,
               const StreamClock& clock, std::vector<int>& kept) {
  if (!nominal.tree()) return readings_at_tracker(readings, device, first, rows, clock, kept);
  return tip_samples(nominal, readings_at_tracker(readings, device, tracker, rows, clock, kept));
}

// The tracker rows the fit may use at a clock: those whose device time the
// readings cover, the fastest (above the speed quantile) left out, then at most
// max_fit_samples spread evenly.
std::vector<int> fit_rows(const DeviceModel& nominal, const ReadingInterpolator& readings,
                          const Log& device, const Log& tracker, const StreamClock& clock,
                          const StreamOptions& options, ClockEstimate& estimate) {
  const PreparedModel prepared(nominal);
  const int n = device.dof();
  Eigen::VectorXd a(n), b(n);
  Eigen::Vector3d v;
  std::vector<int> rows;
  std::vector<double> speed;
  estimate.dropped_gap = 0;
  for (int r = 0; r < tracker.rows; ++r) {
    const double t = clock.device_time(tracker.t[r]);
    if (t < readings.begin() || t > readings.end()) continue;
    if (!tool_velocity(prepared, readings, t, a, b, v)) {
      ++estimate.dropped_gap;
      continue;
    }
    rows.push_back(r);
    speed.push_back(v.norm());
  }
  estimate.overlapping = static_cast<int>(rows.size()) + estimate.dropped_gap;
  std::vector<double> sorted = speed;
  const auto q = static_cast<size_t>(options.speed_quantile * static_cast<double>(sorted.size()));
  std::vector<int> slow;
  if (q < sorted.size()) {
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(q), sorted.end());
    const double limit = sorted[q];
    for (size_t i = 0; i < rows.size(); ++i)
      if (speed[i] <= limit) slow.push_back(rows[i]);
  } else {
    slow = rows;
  }
  estimate.dropped_speed = static_cast<int>(rows.size() - slow.size());
  const auto m = std::min(slow.size(), static_cast<size_t>(std::max(options.max_fit_samples, 1)));
  std::vector<int> out;
  for (size_t i = 0; i < m; ++i) out.push_back(slow[i * slow.size() / m]);
  return out;
}

// A tracker's stream as the fits read it: its glitches (a marker swapped or
// reflected for a sample, which would decide the coarse search and the inner
// least squares) left out, each named later, and a chain's marker body turned
// into the body's poses, aligned as a 6-D tracker's (the clock from their
// positions, the kinematics from positions and orientations).
struct ScreenedTracker {
  std::vector<int> glitches;
  Log log;
  MarkerPoses markers;  // a marker body's
  bool body = false;
};

ScreenedTracker screen_tracker(const DeviceModel& model, const Log& tracker,
                               const Eigen::Matrix3Xd& marker_body) {
  ScreenedTracker s;
  s.glitches = tracker_glitches(tracker);
  s.body = !model.tree() && tracker.marker_count > 0;
  Log screened = s.glitches.empty() ? tracker : without_rows(tracker, s.glitches);
  if (!s.body) {
    s.log = std::move(screened);
    return s;
  }
  s.markers = markers_to_poses(screened, marker_body);
  s.log = s.markers.poses;
  return s;
}

void check_readings(const Log& device, const DeviceModel& model) {
  if (device.dof() == model.dof()) return;
  throw InputError(device.origin, 0, "q",
                   fmt::format("the device log has {} joint readings; the model has {} joints",
                               device.dof(), model.dof()));
}

// RMS position residual of a model against the offset about the estimate.
std::vector<std::pair<double, double>> residual_curve(const DeviceModel& model,
                                                      const ReadingInterpolator& readings,
                                                      const Log& device, const Log& tracker,
                                                      const std::vector<int>& rows,
                                                      const ClockEstimate& estimate) {
  std::vector<int> sample;
  const size_t m = std::min(rows.size(), static_cast<size_t>(kCurveSamples));
  for (size_t i = 0; i < m; ++i) sample.push_back(rows[i * rows.size() / m]);
  const double half =
      std::max(kCurveMin, kCurveSds * (std::isnan(estimate.offset_sd) ? 0 : estimate.offset_sd));
  const PreparedModel prepared(model);
  Eigen::VectorXd q(device.dof());
  std::vector<std::pair<double, double>> out;
  for (int k = 0; k < kCurvePoints; ++k) {
    StreamClock clock = estimate.clock;
    clock.offset += half * (2.0 * k / (kCurvePoints - 1) - 1);
    double sum = 0;
    int count = 0;
    for (const int r : sample) {
      if (!readings.at(clock.device_time(tracker.t[r]), q.data())) continue;
      sum += (tracker.position.row(r).transpose() - prepared.forward(q.data()).p).squaredNorm();
      ++count;
    }
    if (count > 0) out.emplace_back(clock.offset, std::sqrt(sum / count));
  }
  return out;
}

// One warning a glitch left out (the first kGlitchesNamed; results.json lists
// them all, from the estimate's glitch_lines).
void glitch_notes(const Log& tracker, const std::vector<int>& glitches,
                  std::vector<std::string>& notes, ClockEstimate& estimate) {
  estimate.glitch_lines.clear();
  for (const int r : glitches)
    estimate.glitch_lines.push_back(tracker.line[static_cast<size_t>(r)]);
  const Eigen::MatrixXd& p = tracker.marker_count > 0 ? tracker.markers : tracker.position;
  for (size_t i = 0; i < glitches.size() && i < kGlitchesNamed; ++i) {
    const auto r = static_cast<Eigen::Index>(glitches[i]);
    const double jump = (p.row(r) - p.row(r - 1)).stableNorm();
    notes.push_back(fmt::format(
        "warning: {} line {}: a glitch, {:.4g} mm from line {}'s sample and far from the median "
        "of the two samples either side: left out of the clock's search and the fits",
        tracker.origin, tracker.line[static_cast<size_t>(r)], 1e3 * jump,
        tracker.line[static_cast<size_t>(r - 1)]));
  }
  if (glitches.size() > kGlitchesNamed) {
    notes.push_back(
        fmt::format("warning: {}: and {} more glitches left out (results.json lists them all)",
                    tracker.origin, glitches.size() - kGlitchesNamed));
  }
}

// The inner fits: plain least squares of one model (no search), no
// cross-validation, no reweighting.
CalibrationOptions inner_options(const CalibrationOptions& options) {
  CalibrationOptions inner = options;
  inner.search = false;
  inner.force = true;  // a clock far off looks implausible: the clock's check says why
  inner.keep_all = true;
  inner.select = false;
  inner.folds = 0;
  inner.loss = RobustLoss::kNone;
  inner.samples = 0;  // the clock's step uses every sample the fit does
  inner.joint_errors.clear();
  return inner;
}

// The final calibration at the clock found; refused there, the refusal says
// which clock and what would change it.
CalibrationResult final_fit(const DeviceModel& nominal, const Log& poses,
                            const CalibrationOptions& options, const ClockEstimate& estimate,
                            const StreamOptions& stream, const std::string& tracker,
                            const std::string& drift_note) {
  try {
    return calibrate(nominal, poses, options);
  } catch (const InputError& e) {
    throw InputError(
        tracker, 0, "t",
        fmt::format("{}at the clocks' offset found, {:.4f} s (the speeds correlate {:.3f} there; "
                    "searched +-{:g} s), the fit is refused: {}{}",
                    drift_note.empty() ? "" : drift_note + "; ", estimate.clock.offset,
                    estimate.coarse_correlation, stream.search_range, e.message(),
                    drift_note.empty() ? fmt::format("; if the clocks differ by more than {:g} s, "
                                                     "widen --clock-search",
                                                     stream.search_range)
                                       : ""));
  }
}

// The clocks' summary line.
std::string clock_note(const ClockEstimate& estimate, const StreamOptions& stream,
                       const std::string& device, const std::string& tracker, bool held = false) {
  return fmt::format(
      "clocks of {} and {}: the speeds correlate best ({:.3f}) at an offset of {:.4f} s "
      "(searched +-{:g} s); "
      "{}: offset {:.4f} ms +- {:.4f} ms{}, after {} step(s); {} of {} tracker samples within "
      "the device stream, {} in its gaps, {} faster than the {:g} % quantile left out, {} {}",
      device, tracker, estimate.coarse_correlation, estimate.coarse_offset, stream.search_range,
      held ? "aligned with the model held" : "fitted", 1e3 * estimate.clock.offset,
      1e3 * estimate.offset_sd,
      stream.drift ? fmt::format(", drift {:.3f} ppm +- {:.3f} ppm", 1e6 * estimate.clock.drift,
                                 1e6 * estimate.drift_sd)
                   : std::string(),
      estimate.iterations, estimate.overlapping, estimate.tracker_rows, estimate.dropped_gap,
      estimate.dropped_speed, 100 * stream.speed_quantile, estimate.fit_samples,
      held ? "scored" : "fitted");
}

// The clocks before any step: the streams' sizes, the options, and the coarse
// search's offset (the reference: the tracker stream's first stamp).
ClockEstimate coarse_estimate(const DeviceModel& model, const Log& device, const Log& tracker,
                              int tracker_rows, const StreamOptions& stream) {
  ClockEstimate estimate;
  estimate.search_range = stream.search_range;
  estimate.drift_fitted = stream.drift;
  estimate.device_rows = device.rows;
  estimate.tracker_rows = tracker_rows;
  const auto [coarse, correlation] =
      coarse_clock_offset(model, device, tracker, stream.search_range);
  estimate.coarse_offset = coarse;
  estimate.coarse_correlation = correlation;
  estimate.clock = {coarse, 0, tracker.t[0]};
  return estimate;
}

// Moves the clock by a Gauss-Newton step (step `it`) and takes its sd; whether
// it settled: moved (the offset, and the drift over the session's span) by less
// than kClockSds of its sd, or kClockTolerance.
bool take_clock_step(const ClockStep& step, double span, bool drift, int it,
                     ClockEstimate& estimate) {
  estimate.clock.offset += step.step[0];
  if (drift) estimate.clock.drift += step.step[1];
  estimate.offset_sd = std::sqrt(step.covariance(0, 0));
  if (drift) estimate.drift_sd = std::sqrt(step.covariance(1, 1));
  estimate.iterations = it + 1;
  const double moved = std::abs(step.step[0]) + (drift ? std::abs(step.step[1]) * span : 0.0);
  if (std::getenv("HAPTICCAL_DEBUG_STREAM"))
    fmt::print(stderr, "clock step {}: offset {:.7f} s (+{:.3g}), drift {:.4g}, sd {:.3g}\n", it,
               estimate.clock.offset, step.step[0], estimate.clock.drift, estimate.offset_sd);
  estimate.converged = moved < std::max(kClockTolerance, kClockSds * estimate.offset_sd);
  return estimate.converged;
}

}  // namespace

StreamAlignment align_streams(const DeviceModel& model, const Log& device, const Log& tracker_in,
                              const StreamOptions& stream, const Eigen::Matrix3Xd& marker_body) {
  check_option("--clock-search", stream.search_range, option_range::kClockSearch);
  if (model.tree())
    throw InputError(tracker_in.origin, 0, "--tracker",
                     "a tree's second session is not aligned yet: give a chain");
  const ScreenedTracker screen = screen_tracker(model, tracker_in, marker_body);
  const std::vector<int>& glitches = screen.glitches;
  const Log& tracker = screen.log;
  check_streams(device, tracker);
  check_readings(device, model);
  StreamAlignment out;
  out.clock = coarse_estimate(model, device, tracker, tracker_in.rows, stream);
  ClockEstimate& estimate = out.clock;
  const ReadingInterpolator readings(device);
  const std::vector<int> rows =
      fit_rows(model, readings, device, tracker, estimate.clock, stream, estimate);
  const double span = tracker.t[tracker.rows - 1] - tracker.t[0];
  std::vector<int> kept;
  for (int it = 0; it < stream.max_iterations; ++it) {
    throw_if_cancelled();
    out.poses = readings_at_tracker(readings, device, tracker, rows, estimate.clock, kept);
    const ClockStep step =
        held_clock_step(model, readings, out.poses, estimate.clock, stream.drift);
    if (std::isnan(step.covariance(0, 0))) {
      throw InputError(
          tracker_in.origin, 0, "t",
          "the motion does not determine the clocks' offset (the tool point hardly moves)");
    }
    if (take_clock_step(step, span, stream.drift, it, estimate)) break;
  }
  out.poses = readings_at_tracker(readings, device, tracker, rows, estimate.clock, kept);
  estimate.fit_samples = out.poses.rows;
  if (!estimate.converged) {
    out.notes.push_back(fmt::format("warning: the clocks' offset did not settle in {} steps",
                                    stream.max_iterations));
  }
  CalibrationResult held;  // the clock check reads the model and the residual scatter only
  held.calibrated = model;
  const ClockCheck check = check_clock(held, readings, out.poses, estimate.clock);
  std::string drift_note;
  if (const std::string step = clock_verdict(check, stream, tracker_in.origin, span, drift_note);
      !step.empty())
    out.notes.push_back("warning: " + step);
  if (!drift_note.empty()) out.notes.push_back("warning: " + drift_note);
  estimate.curve = residual_curve(model, readings, device, tracker, kept, estimate);
  if (screen.body) {
    out.notes.insert(out.notes.begin(), screen.markers.note);
    out.marker_body = screen.markers.body;
  }
  out.notes.push_back(clock_note(estimate, stream, device.origin, tracker_in.origin, true));
  glitch_notes(tracker_in, glitches, out.notes, estimate);
  return out;
}

StreamCalibration calibrate_streams(const DeviceModel& nominal, const Log& device,
                                    const Log& tracker_in, const CalibrationOptions& options,
                                    const StreamOptions& stream) {
  check_option("--clock-search", stream.search_range, option_range::kClockSearch);
  // A tree's stream: one marker a tip (x1, y1, z1, ...); its clock follows the first tip.
  if (nominal.tree() && tracker_in.marker_count != nominal.tips()) {
    throw InputError(tracker_in.origin, 0, "x1",
                     fmt::format("a tree of {} tips needs one marker a tip in the tracker's "
                                 "stream (x1, y1, z1 .. x{}, y{}, z{}); it has {}",
                                 nominal.tips(), nominal.tips(), nominal.tips(), nominal.tips(),
                                 tracker_in.marker_count));
  }
  const ScreenedTracker screen = screen_tracker(nominal, tracker_in, options.marker_body);
  const std::vector<int>& glitches = screen.glitches;
  const Log& tracker = screen.log;
  const Log first = nominal.tree() ? first_tip_stream(tracker) : Log();
  const Log& tracked = nominal.tree() ? first : tracker;
  check_streams(device, tracked);
  check_readings(device, nominal);
  // Readings out of the limits are the device log's whatever the clocks: named
  // here, before the clocks are searched (the final fit's notes repeat a warning).
  std::vector<std::string> said_again;
  detail::check_joint_limits(device, nominal, options.force, said_again);
  const auto progress = [&](const std::string& stage, double share) {
    if (stream.progress) stream.progress(stage, share);
  };
  StreamCalibration out;
  progress("clock search", 0);
  out.clock = coarse_estimate(nominal, device, tracked, tracker_in.rows, stream);
  ClockEstimate& estimate = out.clock;
  progress("clock search", 1);

  const ReadingInterpolator readings(device);
  const CalibrationOptions inner = inner_options(options);
  std::vector<int> kept;
  CalibrationResult last;  // the last inner fit
  const double span = tracked.t[tracked.rows - 1] - tracked.t[0];
  // The samples are chosen once, at the coarse offset: a set that changed with
  // the clock would move the estimate by a share of its sd at every step.
  const std::vector<int> rows =
      fit_rows(nominal, readings, device, tracked, estimate.clock, stream, estimate);
  for (int it = 0; it < stream.max_iterations; ++it) {
    progress("clock and kinematics", static_cast<double>(it) / stream.max_iterations);
    throw_if_cancelled();
    out.poses = samples_at(nominal, readings, device, tracker, tracked, rows, estimate.clock, kept);
    last = calibrate(nominal, out.poses, inner);
    const CalibrationResult& fit = last;
    if (fit.status != CalibrationStatus::kConverged) {
      out.result = fit;
      out.result.status_reason =
          "the fit at the clock's estimate did not converge: " + fit.status_reason;
      out.result.clock = estimate;
      return out;
    }
    const ClockStep step = clock_step(fit, readings, out.poses, estimate.clock, stream.drift);
    if (std::isnan(step.covariance(0, 0))) {
      out.result = fit;
      out.result.status = CalibrationStatus::kRankDeficient;
      out.result.status_reason =
          "the motion does not determine the clocks' offset (the velocity's columns vanish "
          "once the geometry is fitted)";
      out.result.clock = estimate;
      return out;
    }
    if (take_clock_step(step, span, stream.drift, it, estimate)) break;
  }
  progress("clock and kinematics", 1);
  // A clock the model cannot hold: a step refuses the session, a drift not
  // fitted is named.
  const ClockCheck check = check_clock(last, readings, out.poses, estimate.clock);
  std::string drift_note;
  if (const std::string step = clock_verdict(check, stream, tracker.origin, span, drift_note);
      !step.empty()) {
    out.result = last;
    out.result.status = CalibrationStatus::kNotConverged;
    out.result.status_reason = step;
    out.result.clock = estimate;
    return out;
  }
  out.poses = samples_at(nominal, readings, device, tracker, tracked, rows, estimate.clock, kept);
  estimate.fit_samples = out.poses.rows;
  progress("final fit", 0);
  out.result = final_fit(nominal, out.poses, options, estimate, stream, tracker.origin, drift_note);
  progress("final fit", 1);
  if (!drift_note.empty()) out.result.notes.push_back("warning: " + drift_note);
  std::vector<int> flagged;
  for (const OutlierPose& o : out.result.kinematics.robust.outliers)
    flagged.insert(flagged.end(), o.lines.begin(), o.lines.end());
  if (const std::string note = fast_motion_note(tracked, flagged); !note.empty())
    out.result.notes.push_back("warning: " + note);
  if (out.result.status == CalibrationStatus::kConverged && !estimate.converged) {
    out.result.status = CalibrationStatus::kNotConverged;
    out.result.status_reason = fmt::format(
        "the clock's offset did not settle in {} iterations (its last step was above {:g} s)",
        stream.max_iterations, kClockTolerance);
  }
  estimate.curve = residual_curve(out.result.calibrated, readings, device, tracked, kept, estimate);
  out.result.notes.push_back(clock_note(estimate, stream, device.origin, tracker.origin));
  glitch_notes(tracker_in, glitches, out.result.notes, estimate);
  if (screen.body) {
    out.result.notes.insert(out.result.notes.begin(), screen.markers.note);
    out.result.marker_body = screen.markers.body;
  }
  out.result.clock = estimate;
  return out;
}

}  // namespace hapticcal
