// A simulated hand-guided session (issue 26, item 3): the handle swept by
// hand through the workspace while a tracker records, two streams each stamped
// by its own clock (identification/stream.hpp reads them back).
#pragma once

#include <Eigen/Core>
#include <cstdint>

#include "hapticcal/core/log.hpp"
#include "hapticcal/identification/clock.hpp"
#include "hapticcal/model/model.hpp"

namespace hapticcal {

struct SessionOptions {
  double seconds = 600;          // of hand-guided motion
  double device_rate_hz = 1000;  // the device's readings
  double tracker_rate_hz = 120;  // the tracker's positions
  // The clocks: device time = tracker time + offset + drift * (tracker time -
  // the tracker's first stamp); the tracker's clock reads tracker_start at its
  // first sample.
  double clock_offset = 0.0373;  // s
  double clock_drift = 20e-6;
  double tracker_start = 0;  // s
  // Jitter: each stamp's error about its sample's instant [s, sd].
  double device_jitter = 2e-5, tracker_jitter = 1e-4;
  // Dropouts (the marker occluded): this share of the tracker's samples lost,
  // in gaps of dropout_seconds on average.
  double dropout_share = 0.02, dropout_seconds = 0.3;
  double sigma_position = 1e-4;  // m, per coordinate
  // A 6-D tracker (a chain's): the tool's orientation too (qw, qx, qy, qz), each
  // turned by a random rotation of sigma_orientation rad sd about each axis.
  bool orientation = false;
  double sigma_orientation = 1e-3;  // rad
  // A marker body on the tool (a chain's): 3 x K markers in the tool frame [m],
  // each recorded with sigma_position noise (x1, y1, z1, ...); empty: the tool point.
  Eigen::Matrix3Xd marker_body;
  // The motion: each reading a sum of sinusoids of 0.05 to max_frequency_hz
  // about the middle of its limits, within `coverage` of its half range.
  double max_frequency_hz = 0.5;
  double coverage = 0.95;
  // The device at rest at home (every reading 0, or the middle of the limits
  // where they exclude it) for this long, then picked up over 2 s [s].
  double rest_seconds = 0;
};

struct Session {
  Log device;   // t (device clock), q
  Log tracker;  // t (tracker clock), x, y, z [qw..qz] (a tree's or a marker body's: x1, y1, z1,
                // ...)
  StreamClock clock;  // the truth
  int dropped = 0;    // tracker samples lost to dropouts
};

// The device's readings (the motion, stamped on its clock) and the tracker's
// positions of the actual device's tool point (stamped on its own, with
// noise, jitter and dropouts); a tree's tips each as a marker (x1, y1, z1,
// ...). Reproducible for a seed.
Session simulate_session(const DeviceModel& actual, const SessionOptions& options,
                         std::uint64_t seed);

}  // namespace hapticcal
