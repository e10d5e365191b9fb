// Calibration from two streams on two clocks (issue 26): the device's readings
// (a log with a time column t, typically 1 kHz) and a tracker's positions or
// poses (another log with t, 100-500 Hz), each stamped by its own clock. The
// clocks differ by an unknown offset and, on request, a drift (StreamClock).
//
// The offset is found by a coarse search (the cross-correlation of the tool
// point's speed in the two streams: a speed does not depend on the tracker's
// frame) and then estimated with the kinematic parameters: the readings are
// interpolated at each tracker sample's device time (cubic Hermite), the
// kinematics are fitted, and the clock is moved by the Gauss-Newton step of
// the fit's residuals over the clock parameters, their columns (the tool
// point's velocity) projected off the kinematic ones (variable projection);
// the standard deviations come from the same projected columns.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "hapticcal/core/log.hpp"
#include "hapticcal/identification/clock.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/model/model.hpp"

namespace hapticcal {

struct StreamOptions {
  double search_range = 10;  // s: the coarse search looks for offsets within +-search_range
  bool drift = false;        // estimate the drift too (else it is 0)
  // The kinematic fit uses at most this many tracker samples, spread evenly
  // over the session (the clock's and the kinematics' information is ample
  // long before; a one-hour session has 432 k samples at 120 Hz).
  int max_fit_samples = 10000;
  // Samples whose tool-point speed exceeds this quantile of the session's are
  // left out of the fit: a timing error moves them most.
  double speed_quantile = 0.95;
  int max_iterations = 10;
  // Called with a stage's name and its share done (0..1), for a progress bar.
  std::function<void(const std::string&, double)> progress;
};

// Readings of a time-stamped log at any time within it: cubic Hermite
// interpolation of every q and ext column with the slopes of the neighbouring
// samples; no value across a gap of more than kGapFactor median sample intervals.
class ReadingInterpolator {
 public:
  static constexpr double kGapFactor = 5;
  explicit ReadingInterpolator(const Log& device);
  // The readings (dof values) and external encoders at time t; false outside
  // the log or in a gap.
  bool at(double t, double* q, double* ext = nullptr) const;
  // The readings half a median interval before and after t (what a velocity at
  // t is differenced over); false where either is missing.
  bool around(double t, double* before, double* after) const {
    const double h = 0.5 * median_dt_;
    return at(t - h, before) && at(t + h, after);
  }
  double begin() const { return t_.front(); }
  double end() const { return t_.back(); }
  double median_interval() const { return median_dt_; }

 private:
  const Log& log_;
  std::vector<double> t_;
  double median_dt_ = 0, max_gap_ = 0;
};

// Checks a pair of streams: the device log has t and q columns, the tracker
// log t and positions; each one's times are finite and strictly increasing.
// Throws InputError naming the file, the line and the column.
void check_streams(const Log& device, const Log& tracker);

// A tracker stream's glitches (a marker swapped or reflected for one or two
// samples): the rows (0-based) of samples further from the componentwise
// median of the five about them than 10 times the stream's 99th percentile of
// that distance, for the tool point or any marker; none within two samples of
// a gap or an end. A stream with more than 1 % glitches keeps them.
std::vector<int> tracker_glitches(const Log& tracker);

// Of the samples a stream's fit flagged as outliers (their tracker lines), how
// many fall where the tool moves fastest (above the upper quartile of the
// tracker's speeds, each from the samples either side): when 3 or more and two
// thirds of them do (a quarter would by chance), a note that says so, since
// residuals that grow with the speed are the clocks' (an offset or a lag left
// between the streams) rather than bad measurements; else empty.
std::string fast_motion_note(const Log& tracker, const std::vector<int>& lines);

// The log without the given rows (ascending, 0-based): every per-row field.
Log without_rows(const Log& log, const std::vector<int>& rows);

// The coarse search: the offset in [-range, range] at which the speed of the
// nominal model's tool point (device stream) and the tracker's point agree
// best (largest Pearson correlation, 10 ms steps, refined by a parabola).
// Throws InputError when the clocks do not overlap at any offset in range.
std::pair<double, double> coarse_clock_offset(const DeviceModel& nominal, const Log& device,
                                              const Log& tracker, double range);

// The static log the kinematic fit reads at a clock: one row a tracker sample
// (rows `samples` of the tracker log) with the readings interpolated at its
// device time; samples the readings do not cover are left out (`kept`: the
// tracker rows used).
Log readings_at_tracker(const ReadingInterpolator& readings, const Log& device, const Log& tracker,
                        const std::vector<int>& samples, const StreamClock& clock,
                        std::vector<int>& kept);

struct StreamCalibration {
  CalibrationResult result;
  ClockEstimate clock;
  Log poses;  // the static log of the final fit
};

// A second session against a model held (evaluate --tracker): the clocks
// found as calibrate_streams finds them (glitches screened, a marker body's
// poses, the coarse search, the same samples) but by Gauss-Newton steps of the
// clock alone, the model fixed; `poses` the static log at that clock (the
// samples the evaluation scores), `notes` a step or a drift the clock check
// finds (warnings) and the clocks' summary line.
struct StreamAlignment {
  ClockEstimate clock;
  Log poses;
  Eigen::Matrix3Xd marker_body;  // a marker body's (given or estimated)
  std::vector<std::string> notes;
};
StreamAlignment align_streams(const DeviceModel& model, const Log& device, const Log& tracker,
                              const StreamOptions& stream,
                              const Eigen::Matrix3Xd& marker_body = {});

// The whole procedure: check, coarse search, then kinematic fits and clock
// steps until the clock moves by less than a microsecond, then the final
// calibration (`options`, e.g. the tolerance prior) at the estimated clock.
StreamCalibration calibrate_streams(const DeviceModel& nominal, const Log& device,
                                    const Log& tracker, const CalibrationOptions& options,
                                    const StreamOptions& stream);

}  // namespace hapticcal
