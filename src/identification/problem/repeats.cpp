// A log's repeats: rows at one pose grouped (repeated_poses), averaged into
// one row a pose (average_repeats), and the measurement's repeatability from
// the genuine repeats among them (detail::repeatability).
#include <Eigen/Core>
#include <cstring>
#include <limits>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "hapticcal/core/log_rows.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/identification/measurement.hpp"

namespace hapticcal {

namespace detail {

// RMS scatter of a pose's genuine repeats about their mean (Euclidean for
// positions), with repeats - poses degrees of freedom; NaN without any. A
// repeat is a row whose measured values differ from the pose's earlier rows'
// (bit-identical rows are one sample sent again); in a log with time, a run of
// consecutive rows at one pose is one visit (a device at rest streaming: its
// mean is the visit's sample), so only a pose left and reached again repeats
// (rows of no pose, a screened outlier's, do not end a visit).
double repeatability(const Log& log, const std::vector<std::vector<int>>& poses,
                     MeasurementType type) {
  if (holds_fixture(log)) return std::numeric_limits<double>::quiet_NaN();  // nothing measured
  // Each row's next row of some pose (log.rows: none).
  std::vector<int> next_used(static_cast<std::size_t>(log.rows) + 1, log.rows);
  {
    std::vector<bool> used(static_cast<std::size_t>(log.rows), false);
    for (const std::vector<int>& rows : poses)
      for (const int r : rows) used[static_cast<std::size_t>(r)] = true;
    for (int r = log.rows - 1; r >= 0; --r) {
      next_used[static_cast<std::size_t>(r)] =
          r + 1 < log.rows && used[static_cast<std::size_t>(r) + 1]
              ? r + 1
              : next_used[static_cast<std::size_t>(r) + 1];
    }
  }
  // The spread of the values that are lengths (a pose's position, not its rotation).
  const MeasurementTraits& t = traits(type);
  const int lengths = std::min(t.length_rows, t.width);
  std::vector<double> value(static_cast<std::size_t>(t.width));
  double sum = 0;
  int dof = 0;
  // A sample's numbers as a key (-0.0 and 0.0 one number): a pose's samples
  // found by hashing, linear in its rows however many there are.
  const auto key = [lengths](const Eigen::VectorXd& v) {
    std::string k(sizeof(double) * static_cast<std::size_t>(lengths), '\0');
    for (int i = 0; i < lengths; ++i) {
      const double x = v[i] + 0.0;
      std::memcpy(k.data() + sizeof(double) * static_cast<std::size_t>(i), &x, sizeof(double));
    }
    return k;
  };
  for (const std::vector<int>& rows : poses) {
    std::vector<Eigen::VectorXd> samples;    // the pose's distinct samples (or visits' means)
    std::unordered_set<std::string> closed;  // the samples before the last, by their numbers
    int visit_rows = 0, previous = -2;
    for (const int r : rows) {
      measured_values(type, log, r, value.data());
      const Eigen::VectorXd v = Eigen::Map<const Eigen::VectorXd>(value.data(), lengths);
      if (log.has_time && previous >= 0 && r == next_used[static_cast<std::size_t>(previous)] &&
          !samples.empty()) {  // the same visit
        samples.back() += (v - samples.back()) / ++visit_rows;
      } else if (!(!samples.empty() && samples.back() == v) && !closed.count(key(v))) {
        if (!samples.empty()) closed.insert(key(samples.back()));
        samples.push_back(v), visit_rows = 1;
      }
      previous = r;
    }
    if (samples.size() < 2) continue;
    Eigen::VectorXd mean = Eigen::VectorXd::Zero(lengths);
    for (const Eigen::VectorXd& v : samples) mean += v / static_cast<double>(samples.size());
    for (const Eigen::VectorXd& v : samples) sum += (v - mean).squaredNorm();
    dof += static_cast<int>(samples.size()) - 1;
  }
  return dof > 0 ? std::sqrt(sum / dof) : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace detail

std::vector<std::vector<int>> repeated_poses(const Log& log, bool by_direction) {
  std::vector<std::vector<int>> groups;
  std::unordered_map<std::string, int> index;
  index.reserve(static_cast<size_t>(log.rows));
  // The readings, and the approach directions: a pose reached from the other
  // side is another pose (its backlash differs).
  const int directions = by_direction && log.any_direction() ? log.dof() : 0;
  std::string key(sizeof(double) * static_cast<size_t>(log.dof() + directions), '\0');
  for (int r = 0; r < log.rows; ++r) {
    for (int j = 0; j < log.dof() + directions; ++j) {
      // -0.0 and 0.0 are one reading
      const double v = (j < log.dof() ? log.q(r, j) : log.direction(r, j - log.dof())) + 0.0;
      std::memcpy(key.data() + sizeof(double) * j, &v, sizeof(double));
    }
    // A fixture log's rows are one pose only at one label.
    std::string labelled = log.label.empty() ? key : key + '\0' + log.label[static_cast<size_t>(r)];
    // A tree's rows are one pose only at one tip.
    if (!log.tip.empty()) labelled += '\0' + std::to_string(log.tip[static_cast<size_t>(r)]);
    const auto [it, added] = index.try_emplace(labelled, static_cast<int>(groups.size()));
    if (added) groups.emplace_back();
    groups[it->second].push_back(r);
  }
  return groups;
}

Log average_repeats(const Log& log, const std::vector<std::vector<int>>& groups) {
  return average_rows(log, groups);
}

}  // namespace hapticcal
