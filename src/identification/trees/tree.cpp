// A tree's logs (identification/tree.hpp): one sample a tip of each row, and
// a chain's log of a tree log. The tree itself is model_io/tree_model.cpp's.
#include "hapticcal/identification/tree.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <stdexcept>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/identification/measurement.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/model_source.hpp"
#include "hapticcal/model_io/urdf.hpp"

namespace hapticcal {
namespace {

// A tree fixture log's row labels (point1 .. pointK, joined by ',' as the log
// reader keeps them), one a tip; InputError naming the row for another count.
std::vector<std::string> row_labels(const Log& log, int r, int tips) {
  std::vector<std::string> out;
  const std::string& joined = log.label[static_cast<size_t>(r)];
  size_t from = 0;
  for (size_t comma = joined.find(','); comma != std::string::npos;
       comma = joined.find(',', from)) {
    out.push_back(joined.substr(from, comma - from));
    from = comma + 1;
  }
  out.push_back(joined.substr(from));
  if (static_cast<int>(out.size()) != tips) {
    const char* label = traits(measurement_type(log)).name;  // "point" or "plane"
    throw InputError(log.origin, r < static_cast<int>(log.line.size()) ? log.line[r] : 0,
                     fmt::format("{}1", label),
                     fmt::format("the tree has {} tips: a fixture log names a label a tip "
                                 "({}1 .. {}{}); this row has {}",
                                 tips, label, label, tips, out.size()));
  }
  return out;
}

}  // namespace

Log tip_samples(const DeviceModel& tree, const Log& log, std::optional<int> only) {
  const int k = tree.tips();
  if (only && (*only < 0 || *only >= k))
    throw std::out_of_range("tip_samples: tip " + std::to_string(*only));
  const bool fixture = holds_fixture(log);
  // Markers a tip: 1, a point; 3 or more, a rigid body on each tip (the same
  // layout on every one), x1 .. x<M> the first tip's, x<M+1> .. the second's.
  const int per_tip = fixture ? 0 : log.marker_count / k;
  if (!fixture && (log.marker_count % k != 0 || per_tip == 0 || per_tip == 2)) {
    std::vector<std::string> names;
    for (int t = 0; t < k; ++t) names.push_back(tree.tip_name(t));
    throw InputError(
        log.origin, 0, "header",
        fmt::format("{} tips ({}) need the points x1, y1, z1 .. x{}, y{}, z{}; the log has {}", k,
                    fmt::join(names, ", "), k, k, k,
                    log.marker_count ? fmt::format("{} point{}", log.marker_count,
                                                   log.marker_count > 1 ? "s" : "")
                                     : std::string("none")) +
            fmt::format(" (a rigid body of M >= 3 markers on each tip: x1 .. x{}M)", k));
  }
  // Nothing measured but the markers, or but the labels.
  if (kinds_in(log).size() > (fixture ? 1u : 0u) || (fixture && log.marker_count > 0))
    throw InputError(log.origin, 0, "x1",
                     "a tree's log gives each tip's point, or each tip's fixture label, only (no "
                     "orientations, distances or other measurements yet)");
  Log out = log;
  const int per_row = only ? 1 : k;
  out.rows = log.rows * per_row;
  out.marker_count = per_tip > 1 ? per_tip : 0;
  out.markers.resize(per_tip > 1 ? out.rows : 0, 3 * out.marker_count);
  MeasuredValues points(per_tip == 1 ? out.rows : 0, 3);  // a marker a tip: its positions
  out.q.resize(out.rows, log.dof());
  out.ext.resize(out.rows, log.ext.cols());
  out.direction.resize(out.rows, log.direction.cols());
  if (log.has_time) out.t.resize(out.rows);
  out.line.clear();
  out.tip.clear();
  out.label.clear();
  for (int r = 0; r < log.rows; ++r) {
    const std::vector<std::string> labels =
        fixture ? row_labels(log, r, k) : std::vector<std::string>();
    for (int t = only.value_or(0); t < (only ? *only + 1 : k); ++t) {
      const int row = only ? r : r * k + t;
      out.q.row(row) = log.q.row(r);
      if (log.ext.cols() > 0) out.ext.row(row) = log.ext.row(r);
      if (log.direction.cols() > 0) out.direction.row(row) = log.direction.row(r);
      if (log.has_time) out.t[row] = log.t[r];
      if (fixture) {
        out.label.push_back(labels[static_cast<size_t>(t)]);
      } else if (per_tip == 1) {
        points.row(row) = log.markers.row(r).segment<3>(3 * t);
      } else {
        out.markers.row(row) = log.markers.row(r).segment(3 * per_tip * t, 3 * per_tip);
      }
      out.line.push_back(r < static_cast<int>(log.line.size()) ? log.line[r] : 0);
      out.tip.push_back(t);
    }
  }
  if (per_tip == 1) kind_of(MeasurementType::kPosition).to_log(points, out);
  return out;
}

Log chain_log(const DeviceTree& tree, const Log& log, int chain) {
  const std::vector<int>& joints = tree.joint_of[static_cast<size_t>(chain)];
  Log out;
  out.origin = log.origin;
  out.rows = log.rows;
  out.line = log.line;
  const Eigen::Index n = static_cast<Eigen::Index>(joints.size());
  out.q.resize(log.rows, n);
  out.ext.setZero(log.rows, n);
  out.direction.setZero(log.rows, n);
  out.has_ext.assign(joints.size(), false);
  out.has_direction.assign(joints.size(), false);
  for (size_t k = 0; k < joints.size(); ++k) {
    out.q.col(static_cast<Eigen::Index>(k)) = log.q.col(joints[k]);
    out.q_unit.push_back(log.q_unit[static_cast<size_t>(joints[k])]);
    out.q_column.push_back(log.q_column[static_cast<size_t>(joints[k])]);
    out.ext_unit.push_back(ReadingUnit::kNone);
    out.ext_column.push_back("");
  }
  kind_of(MeasurementType::kPosition).to_log(log.markers.middleCols(3 * chain, 3), out);
  return out;
}

std::string samples_text(int samples, int tips, const char* noun) {
  const int rows = tips > 1 ? samples / tips : samples;
  const std::string counted = fmt::format("{} {}{}", rows, noun, rows == 1 ? "" : "s");
  return tips > 1 ? fmt::format("{} of {} tips, {} points", counted, tips, samples) : counted;
}

}  // namespace hapticcal
