// The clocks of two streams (identification/stream.hpp) and what calibrate
// reports of them (CalibrationResult::clock).
#pragma once

#include <limits>
#include <utility>
#include <vector>

namespace hapticcal {

// device time = tracker time + offset + drift * (tracker time - reference):
// the offset is the clocks' difference at the reference, the tracker stream's
// first sample.
struct StreamClock {
  double offset = 0;     // s
  double drift = 0;      // dimensionless (20 ppm = 2e-5)
  double reference = 0;  // s, tracker time
  double device_time(double tracker_time) const {
    return tracker_time + offset + drift * (tracker_time - reference);
  }
};

struct ClockEstimate {
  StreamClock clock;
  double offset_sd = std::numeric_limits<double>::quiet_NaN();  // s
  double drift_sd = std::numeric_limits<double>::quiet_NaN();
  bool drift_fitted = false;
  double coarse_offset = 0;       // s: the coarse search's
  double coarse_correlation = 0;  // the speeds' correlation there
  double search_range = 0;        // s
  int device_rows = 0, tracker_rows = 0;
  int overlapping = 0;            // tracker samples whose device time the readings cover
  int fit_samples = 0;            // used by the kinematic fit
  int dropped_gap = 0;            // in a gap of the device stream (no readings to interpolate)
  int dropped_speed = 0;          // above the speed quantile
  int iterations = 0;             // of the clock's Gauss-Newton steps
  std::vector<int> glitch_lines;  // tracker samples left out as glitches (tracker_glitches)
  bool converged = false;
  // RMS position residual [m] of the calibrated model against the offset
  // [s], about the estimate (the report's figure).
  std::vector<std::pair<double, double>> curve;
};

}  // namespace hapticcal
