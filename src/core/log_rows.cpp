#include "hapticcal/core/log_rows.hpp"

#include <Eigen/Core>
#include <string>
#include <vector>

namespace hapticcal {

Log select_rows(const Log& log, const std::vector<int>& rows) {
  const std::vector<Eigen::Index> keep(rows.begin(), rows.end());
  Log out = log;
  out.rows = static_cast<int>(keep.size());
  const auto take = [&](Eigen::MatrixXd& m) {
    if (m.rows() == log.rows) m = Eigen::MatrixXd(m(keep, Eigen::all));
  };
  take(out.q), take(out.ext), take(out.direction), take(out.position), take(out.orientation),
      take(out.markers);
  if (out.t.size() == log.rows) out.t = Eigen::VectorXd(log.t(keep));
  if (out.distance.size() == log.rows) out.distance = Eigen::VectorXd(log.distance(keep));
  const auto take_each = [&](auto& v) {
    if (v.size() != static_cast<size_t>(log.rows)) return;
    auto all = v;
    v.clear();
    for (const Eigen::Index r : keep) v.push_back(all[static_cast<size_t>(r)]);
  };
  take_each(out.line), take_each(out.tip), take_each(out.label);
  for (auto& [name, m] : out.columns) take(m);
  return out;
}

Log average_rows(const Log& log, const std::vector<std::vector<int>>& groups) {
  Log out;
  out.origin = log.origin;
  out.rows = static_cast<int>(groups.size());
  out.has_ext = log.has_ext;
  out.has_direction = log.has_direction;
  out.has_distance = log.has_distance;
  out.has_position = log.has_position;
  out.has_time = log.has_time;
  out.has_orientation = log.has_orientation;
  out.has_point = log.has_point;
  out.has_plane = log.has_plane;
  out.q.resize(out.rows, log.dof());
  out.direction = Eigen::MatrixXd::Zero(out.rows, log.any_direction() ? log.dof() : 0);
  out.ext = Eigen::MatrixXd::Zero(out.rows, log.ext.cols());
  if (log.has_distance) out.distance = Eigen::VectorXd::Zero(out.rows);
  if (log.has_position) out.position = Eigen::MatrixXd::Zero(out.rows, 3);
  if (log.has_time) out.t.resize(out.rows);
  if (log.has_orientation) out.orientation = Eigen::MatrixXd::Zero(out.rows, 4);
  for (const auto& [name, values] : log.columns)
    out.columns[name] = Eigen::MatrixXd::Zero(out.rows, values.cols());
  for (int g = 0; g < out.rows; ++g) {
    const std::vector<int>& rows = groups[g];
    const int first = rows.front();
    out.q.row(g) = log.q.row(first);
    if (log.any_direction()) out.direction.row(g) = log.direction.row(first);  // one per group
    if (!log.label.empty()) out.label.push_back(log.label[static_cast<size_t>(first)]);
    if (!log.tip.empty()) out.tip.push_back(log.tip[static_cast<size_t>(first)]);
    out.line.push_back(first < static_cast<int>(log.line.size()) ? log.line[first] : 0);
    if (log.has_time) out.t[g] = log.t[first];
    const double w = 1.0 / static_cast<double>(rows.size());
    for (int r : rows) {
      if (log.ext.cols() > 0) out.ext.row(g) += w * log.ext.row(r);
      if (log.has_distance) out.distance[g] += w * log.distance[r];
      if (log.has_position) out.position.row(g) += w * log.position.row(r);
      for (const auto& [name, values] : log.columns) out.columns[name].row(g) += w * values.row(r);
      if (log.has_orientation) {  // q and -q are one rotation: align with the first
        const double sign = log.orientation.row(r).dot(log.orientation.row(first)) < 0 ? -1 : 1;
        out.orientation.row(g) += sign * w * log.orientation.row(r);
      }
    }
    // The normalised mean of nearby unit quaternions: the chordal L2 mean rotation.
    if (log.has_orientation) out.orientation.row(g).normalize();
  }
  return out;
}

}  // namespace hapticcal
