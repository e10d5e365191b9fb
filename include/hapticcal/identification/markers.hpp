// Several markers on one rigid body (issue 26, item 4): a log's x1, y1, z1,
// x2, ... columns turned into the body's poses, so that positions alone
// identify the tool's orientation. The body's marker positions are given (in
// the tool frame: the body frame is the tool frame) or estimated from the log
// (their mean shape; the body frame its centroid, x toward marker 1, z normal to
// markers 1 and 2; and the
// tool pose then takes the body's place on the device).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "hapticcal/core/log.hpp"

namespace hapticcal {

struct MarkerPoses {
  Log poses;              // the log with x, y, z and qw..qz of the body instead of the markers
  Eigen::Matrix3Xd body;  // the markers in the body frame (given, or estimated) [m]
  bool estimated = false;
  double fit_rms = 0;  // median over rows of the markers' RMS distance from the body's fit [m]
  std::string note;    // one sentence for the notes
};

// The body's pose in each row: the rigid transform that best maps the body's
// markers onto the row's (register_points). `body` (3 x K, K = the log's
// markers) or empty: estimated (generalised Procrustes over the rows). Throws
// InputError naming the log for fewer than 3 markers, a body of another count,
// or markers on a line (no orientation).
MarkerPoses markers_to_poses(const Log& log, const Eigen::Matrix3Xd& body = {});

// "X1,Y1,Z1,X2,..." (metres, 3 K numbers) as a 3 x K body; throws InputError
// naming `option`.
Eigen::Matrix3Xd parse_marker_body(const std::string& text, const std::string& option);

}  // namespace hapticcal
