// Fixture points and planes (the measurement family's labels): each label's
// samples, the known distances and positions between them, and the rows a
// label's eliminated point or plane leaves (variable projection).
#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>
#include <string>
#include <vector>

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/measurement.hpp"

namespace hapticcal {

namespace {

// Bad input about a fixture fact: named where it was given (a fixture file's
// line and key), or for a command-line option, the log's.
[[noreturn]] void refuse(const Log& log, const FixtureSource& where, const std::string& message) {
  if (where.file.empty()) throw InputError(log.origin, 0, where.key, message);
  throw InputError(where.file, where.line, where.key, message);
}

std::string describe(const FixtureSource& where) {
  return where.file.empty() ? "by " + where.key : fmt::format("at {}:{}", where.file, where.line);
}

}  // namespace

FixtureLabels fixture_labels(MeasurementType type, const Log& log, const std::vector<int>& rows,
                             const std::vector<PointDistance>& distances,
                             const std::vector<KnownPoint>& known_points) {
  FixtureLabels out;
  out.points = traits(type).label_points;
  std::vector<int> samples;
  for (int r : rows) {
    const std::string& name = log.label.at(static_cast<size_t>(r));
    const auto it = std::find(out.names.begin(), out.names.end(), name);
    const int index = static_cast<int>(it - out.names.begin());
    if (it == out.names.end()) {
      out.names.push_back(name);
      samples.push_back(0);
    }
    out.of_pose.push_back(index);
    ++samples[index];
  }
  const bool plane = type == MeasurementType::kPlane;
  for (int k = 0; k < out.count(); ++k) {
    // Any 3 points lie on a plane: a plane needs a fourth to say anything.
    const int needed = plane ? 4 : 2;
    if (samples[k] >= needed) continue;
    throw InputError(log.origin, 0, plane ? "plane" : "point",
                     fmt::format("{} '{}' has {} sample{} (distinct poses): a {} needs at least {}",
                                 plane ? "plane" : "point", out.names[k], samples[k],
                                 samples[k] == 1 ? "" : "s", plane ? "plane" : "point", needed));
  }
  out.known_point.assign(out.names.size(), std::nullopt);
  auto index = [&](const FixtureSource& where, const std::string& name, const char* what) {
    const auto it = std::find(out.names.begin(), out.names.end(), name);
    if (it == out.names.end()) {
      refuse(log, where,
             fmt::format("no {} '{}' in the log{}", what, printable(name, 80),
                         plane ? " (it holds planes)" : ""));
    }
    return static_cast<int>(it - out.names.begin());
  };
  for (const KnownPoint& k : known_points) {
    if (plane) {
      refuse(log, k.source, "known positions are of fixture points; this log holds planes");
    }
    const int l = index(k.source, k.label, "point");
    if (out.known_point[l]) refuse(log, k.source, fmt::format("'{}' given twice", k.label));
    if (!k.p_meas.allFinite()) refuse(log, k.source, "a known position must be finite");
    out.known_point[l] = k.p_meas;
  }
  std::vector<const FixtureSource*> given;  // where each accepted distance was given
  for (const PointDistance& d : distances) {
    if (plane) {
      refuse(log, d.source, "known distances are between fixture points; this log holds planes");
    }
    const int a = index(d.source, d.a, "point"), b = index(d.source, d.b, "point");
    if (a == b) {
      refuse(log, d.source, fmt::format("'{}' twice: a distance is between two points", d.a));
    }
    if (!(d.metres > 0 && std::isfinite(d.metres))) {
      refuse(log, d.source,
             fmt::format("{}:{}: a distance must be a positive number of metres", d.a, d.b));
    }
    if (out.known_point[a] && out.known_point[b]) {
      refuse(log, d.source,
             fmt::format("'{}' and '{}' both have known positions ({:.6g} m apart): a distance "
                         "between them is redundant",
                         d.a, d.b, (*out.known_point[a] - *out.known_point[b]).norm()));
    }
    for (size_t k = 0; k < out.distances.size(); ++k) {
      const FixtureLabels::Known& e = out.distances[k];
      if (!((e.a == a && e.b == b) || (e.a == b && e.b == a))) continue;
      refuse(log, d.source,
             e.metres == d.metres
                 ? fmt::format("{}:{} given twice (also {})", d.a, d.b, describe(*given[k]))
                 : fmt::format("{}:{} = {} m contradicts {} m given {}", d.a, d.b, d.metres,
                               e.metres, describe(*given[k])));
    }
    out.distances.push_back({a, b, d.metres});
    given.push_back(&d.source);
  }
  return out;
}

int FixtureLabels::known_points() const {
  return static_cast<int>(std::count_if(known_point.begin(), known_point.end(),
                                        [](const auto& k) { return k.has_value(); }));
}

int fixture_rows(MeasurementType type, const FixtureLabels& labels, int poses) {
  return poses * traits(type).dimension + static_cast<int>(labels.distances.size());
}

void fixture_residuals(MeasurementType type, const FixtureLabels& labels, const Eigen::VectorXd& w,
                       const Eigen::VectorXd& raw, const Eigen::MatrixXd* raw_J, double* residual,
                       Eigen::MatrixXd* J) {
  const int m = static_cast<int>(labels.of_pose.size());
  const int L = labels.count();
  const Eigen::Index n = raw_J ? raw_J->cols() : 0;
  auto weight = [&](int i) { return w.size() > 0 ? w[i] : 1.0; };
  // The labels' weighted mean points (and their Jacobians).
  std::vector<Eigen::Vector3d> mean(L, Eigen::Vector3d::Zero());
  std::vector<Eigen::MatrixXd> mean_J(L, Eigen::MatrixXd::Zero(3, n));
  std::vector<double> total(L, 0.0);
  std::vector<int> samples(L, 0);
  for (int i = 0; i < m; ++i) {
    const int l = labels.of_pose[i];
    const double wi = weight(i) * weight(i);
    mean[l] += wi * raw.segment<3>(3 * i);
    if (raw_J) mean_J[l] += wi * raw_J->middleRows(3 * i, 3);
    total[l] += wi;
    ++samples[l];
  }
  // A label whose position is known is not eliminated: its rows are w_i (p_i - k_L).
  auto is_known = [&](int l) {
    return l < static_cast<int>(labels.known_point.size()) && labels.known_point[l].has_value();
  };
  for (int l = 0; l < L; ++l) {
    if (is_known(l)) {
      mean[l] = *labels.known_point[l];
      if (raw_J) mean_J[l].setZero();
      continue;
    }
    mean[l] /= total[l];
    if (raw_J) mean_J[l] /= total[l];
  }
  const int d = traits(type).dimension;
  if (J) J->setZero(fixture_rows(type, labels, m), n);
  if (type == MeasurementType::kPoint) {
    for (int i = 0; i < m; ++i) {
      const int l = labels.of_pose[i];
      const Eigen::Vector3d e = weight(i) * (raw.segment<3>(3 * i) - mean[l]);
      for (int k = 0; k < 3; ++k) residual[3 * i + k] = e[k];
      if (J) J->middleRows(3 * i, 3) = weight(i) * (raw_J->middleRows(3 * i, 3) - mean_J[l]);
    }
  } else {
    // Each label's best plane: the normal is the direction its points spread least.
    std::vector<Eigen::Vector3d> normal(L);
    std::vector<Eigen::Matrix3d> scatter(L, Eigen::Matrix3d::Zero());
    for (int i = 0; i < m; ++i) {
      const int l = labels.of_pose[i];
      const Eigen::Vector3d e = raw.segment<3>(3 * i) - mean[l];
      scatter[l] += weight(i) * weight(i) * e * e.transpose();
    }
    // The normal turns with the points: dn = -P dS n (eigenvector perturbation),
    // P = sum over the other axes v_j v_j^T / (lambda_j - lambda_0), dS n =
    // sum w_i^2 (de_i (e_i . n) + e_i (n . de_i)), de_i = dp_i - dm.
    std::vector<Eigen::Matrix3d> turn(L, Eigen::Matrix3d::Zero());
    for (int l = 0; l < L; ++l) {
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(scatter[l]);
      normal[l] = eig.eigenvectors().col(0);
      for (int j = 1; j < 3; ++j) {
        const double gap = eig.eigenvalues()[j] - eig.eigenvalues()[0];
        if (gap > 0)
          turn[l] += eig.eigenvectors().col(j) * eig.eigenvectors().col(j).transpose() / gap;
      }
    }
    std::vector<Eigen::MatrixXd> dn(L);
    if (J) {
      for (int l = 0; l < L; ++l) dn[l] = Eigen::MatrixXd::Zero(3, n);
      for (int i = 0; i < m; ++i) {
        const int l = labels.of_pose[i];
        const Eigen::Vector3d e = raw.segment<3>(3 * i) - mean[l];
        const Eigen::MatrixXd de = raw_J->middleRows(3 * i, 3) - mean_J[l];
        dn[l] -= weight(i) * weight(i) * (de * e.dot(normal[l]) + e * (normal[l].transpose() * de));
      }
      for (int l = 0; l < L; ++l) dn[l] = turn[l] * dn[l];
    }
    for (int i = 0; i < m; ++i) {
      const int l = labels.of_pose[i];
      const Eigen::Vector3d e = raw.segment<3>(3 * i) - mean[l];
      residual[i] = weight(i) * normal[l].dot(e);
      if (J) {
        J->row(i) = weight(i) * (normal[l].transpose() * (raw_J->middleRows(3 * i, 3) - mean_J[l]) +
                                 e.transpose() * dn[l]);
      }
    }
  }
  for (size_t k = 0; k < labels.distances.size(); ++k) {
    const FixtureLabels::Known& known = labels.distances[k];
    const Eigen::Vector3d v = mean[known.a] - mean[known.b];
    // The exact distance moves the two points apart along their line: the least
    // squares cost grows by delta^2 / (1 / W_A + 1 / W_B) (W: a label's summed
    // weights; a known position does not move: 1 / W = 0), so this row is the
    // constrained fit's, not a soft guess.
    const auto give = [&](int l) { return is_known(l) ? 0.0 : 1 / total[l]; };
    const double scale = 1 / std::sqrt(give(known.a) + give(known.b));
    const int row = m * d + static_cast<int>(k);
    residual[row] = scale * (v.norm() - known.metres);
    if (J) {
      J->row(row) = scale * v.normalized().transpose() * (mean_J[known.a] - mean_J[known.b]);
    }
  }
}

}  // namespace hapticcal
