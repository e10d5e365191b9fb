// Markers of one rigid body as its poses (identification/markers.hpp).
#include "hapticcal/identification/markers.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/measurement.hpp"
#include "hapticcal/identification/registration.hpp"

namespace hapticcal {
namespace {

constexpr int kProcrustesRounds = 5;

Eigen::Matrix3Xd row_markers(const Log& log, int r) {
  Eigen::Matrix3Xd m(3, log.marker_count);
  for (int k = 0; k < log.marker_count; ++k)
    m.col(k) = log.markers.row(r).segment<3>(3 * k).transpose();
  return m;
}

// The mean shape of the rows' markers (each row registered onto the running
// mean), in a frame of its own: the centroid at the origin, x toward marker 1,
// z normal to the plane of the centroid and markers 1 and 2.
Eigen::Matrix3Xd estimated_body(const Log& log) {
  Eigen::Matrix3Xd mean = row_markers(log, 0);
  mean.colwise() -= mean.rowwise().mean();
  for (int round = 0; round < kProcrustesRounds; ++round) {
    Eigen::Matrix3Xd sum = Eigen::Matrix3Xd::Zero(3, log.marker_count);
    for (int r = 0; r < log.rows; ++r) {
      const Registration reg = register_points(row_markers(log, r), mean);
      sum += (reg.R * row_markers(log, r)).colwise() + reg.t;
    }
    mean = sum / log.rows;
    mean.colwise() -= mean.rowwise().mean();
  }
  // Axes anchored on the markers, not the principal axes (a symmetric body's
  // are arbitrary): x toward marker 1, z normal to the plane of markers 1 and 2.
  Eigen::Matrix3d U;
  const Eigen::Vector3d x = mean.col(0).normalized();
  const Eigen::Vector3d z = mean.col(0).cross(mean.col(1)).normalized();
  if (!(mean.col(0).norm() > 0) || !z.allFinite() ||
      !(mean.col(0).cross(mean.col(1)).norm() > 1e-6 * mean.col(0).norm() * mean.col(1).norm())) {
    throw InputError(
        "markers 1 and 2 lie on a line through the body's centroid: give the body "
        "(--markers)");
  }
  U.col(0) = x;
  U.col(2) = z;
  U.col(1) = z.cross(x);
  return U.transpose() * mean;
}

// The median registration RMS of `body` onto the rows' markers (every
// `stride`-th row).
double median_fit(const Log& log, const Eigen::Matrix3Xd& body, int stride) {
  std::vector<double> rms;
  for (int r = 0; r < log.rows; r += stride) {
    try {
      rms.push_back(register_points(body, row_markers(log, r)).rms);
    } catch (const InputError&) {  // a degenerate row: no vote
    }
  }
  if (rms.empty()) return std::numeric_limits<double>::infinity();
  std::nth_element(rms.begin(), rms.begin() + static_cast<std::ptrdiff_t>(rms.size() / 2),
                   rms.end());
  return rms[rms.size() / 2];
}

// A given body whose markers the log lists in another order (--markers in
// the order of the log's x1, x2, ... columns): InputError naming the order that
// fits, where one fits four times better than the given one (at most six
// markers; a symmetric body's equal fits do not count).
void check_marker_order(const Log& log, const Eigen::Matrix3Xd& body, double given) {
  const int m = static_cast<int>(body.cols());
  if (m > 6 || !(given > 0)) return;
  const int stride = std::max(1, log.rows / 200);
  std::vector<int> order(static_cast<size_t>(m));
  std::iota(order.begin(), order.end(), 0);
  while (std::next_permutation(order.begin(), order.end())) {
    Eigen::Matrix3Xd moved(3, m);  // the body's marker order[k] as the log's marker k
    for (int k = 0; k < m; ++k) moved.col(k) = body.col(order[static_cast<size_t>(k)]);
    const double fit = median_fit(log, moved, stride);
    if (!(fit < 0.25 * given)) continue;
    std::vector<int> listed;
    for (int k : order) listed.push_back(k + 1);
    throw InputError(log.origin, 0, "--markers",
                     fmt::format("the body fits the log's markers at {:.3f} mm (median) with "
                                 "--markers' markers in the order {} ({:.3f} mm as given): list "
                                 "--markers in the order of the log's x1, x2, ... columns",
                                 1e3 * fit, fmt::join(listed, ", "), 1e3 * given));
  }
}

}  // namespace

MarkerPoses markers_to_poses(const Log& log, const Eigen::Matrix3Xd& body) {
  if (log.marker_count < 3) {
    throw InputError(log.origin, 0, "x1",
                     fmt::format("{} marker(s): a rigid body's pose needs at least 3 (a single "
                                 "point is x, y, z)",
                                 log.marker_count));
  }
  if (body.cols() != 0 && body.cols() != log.marker_count) {
    throw InputError(
        log.origin, 0, "--markers",
        fmt::format("the body has {} markers; the log has {}", body.cols(), log.marker_count));
  }
  if (!log.tip.empty() && body.cols() == 0) {  // a tree's samples: each tip's body
    throw InputError(log.origin, 0, "--markers",
                     "markers on a tree's tips: give their layout (--markers, one for every tip); "
                     "it is not estimated from the tips' markers pooled");
  }
  MarkerPoses out;
  out.estimated = body.cols() == 0;
  try {
    out.body = out.estimated ? estimated_body(log) : body;
  } catch (const InputError& e) {
    throw InputError(log.origin, log.line.front(), "x1", e.what());
  }
  Log& p = out.poses;
  p = log;
  p.markers.resize(0, 0);
  p.marker_count = 0;
  MeasuredValues poses(log.rows, traits(MeasurementType::kPose).width);  // x, y, z, qw .. qz
  std::vector<double> rms(static_cast<size_t>(log.rows));
  for (int r = 0; r < log.rows; ++r) {
    Registration reg;
    try {
      reg = register_points(out.body, row_markers(log, r));
    } catch (const InputError& e) {
      throw InputError(log.origin, log.line[static_cast<size_t>(r)], "x1", e.what());
    }
    const Eigen::Quaterniond q(reg.R);
    poses.row(r) << reg.t.transpose(), q.w(), q.x(), q.y(), q.z();
    rms[static_cast<size_t>(r)] = reg.rms;
  }
  kind_of(MeasurementType::kPose).to_log(poses, p);
  std::nth_element(rms.begin(), rms.begin() + static_cast<std::ptrdiff_t>(rms.size() / 2),
                   rms.end());
  out.fit_rms = rms[rms.size() / 2];
  if (!out.estimated) check_marker_order(log, out.body, out.fit_rms);
  out.note = fmt::format(
      "markers: {} on one rigid body, {}; each row's pose the best fit of the body onto its "
      "markers (median RMS {:.4f} mm){}",
      log.marker_count,
      out.estimated ? "their positions on the body estimated from the log (the body frame: "
                      "their centroid, x toward marker 1, z normal to markers 1 and 2)"
                    : "their positions on the body given (the body frame is the tool frame)",
      1e3 * out.fit_rms,
      out.estimated ? ": the tool pose is the body frame's; give the same body (--markers, as "
                      "results.json's markers) to evaluate new logs"
                    : "");
  return out;
}

Eigen::Matrix3Xd parse_marker_body(const std::string& text, const std::string& option) {
  std::vector<double> v;
  size_t start = 0;
  while (start <= text.size()) {
    const size_t comma = text.find(',', start);
    const std::string field =
        text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    char* end = nullptr;
    const double x = std::strtod(field.c_str(), &end);
    if (field.empty() || end != field.c_str() + field.size() || !std::isfinite(x) ||
        std::abs(x) > 10) {
      throw InputError(
          fmt::format("{}: '{}' is not a marker coordinate in metres (|x| <= 10)", option, field));
    }
    v.push_back(x);
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  if (v.size() % 3 != 0 || v.size() < 9) {
    throw InputError(fmt::format("{}: {} numbers; give X, Y, Z of each of at least 3 markers",
                                 option, v.size()));
  }
  Eigen::Matrix3Xd body(3, static_cast<Eigen::Index>(v.size() / 3));
  for (size_t i = 0; i < v.size(); ++i)
    body(static_cast<Eigen::Index>(i % 3), static_cast<Eigen::Index>(i / 3)) = v[i];
  return body;
}

}  // namespace hapticcal
