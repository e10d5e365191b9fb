#include "hapticcal/identification/measurement.hpp"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <memory>
#include <numeric>
#include <stdexcept>

#include "hapticcal/core/error.hpp"

namespace hapticcal {

namespace {

// The built-in kinds' log columns (MeasurementTraits), a registered kind's by
// its name: values in, values out.
bool columns_in_log(const MeasurementTraits& t, const Log& log) {
  if (!t.columns.empty()) return log.columns.count(t.name) > 0;
  if (t.orientation_columns) return log.has_orientation;
  if (t.position_columns) return log.has_position;
  return t.distance_column && log.has_distance;
}

// A kind whose residual rows are the tool point's, p - measured: a position,
// and a fixture sample's raw rows.
class ToolPointKind : public MeasurementKind {
 public:
  using MeasurementKind::MeasurementKind;
  void rows(const ChainStructure& s, const ChainConstants<double>& constants, const double* params,
            const double* joint, const double* measured, double, double* residual,
            Eigen::Ref<Eigen::MatrixXd> J) const override {
    Eigen::Matrix<double, 3, Eigen::Dynamic> J_p;
    const Eigen::Vector3d p = position_parameter_jacobian(s, constants, params, joint, J_p);
    for (int k = 0; k < 3; ++k) residual[k] = p[k] - measured[k];
    J = J_p;
  }
  void joint_rows(const Frame<double>&, const Jacobian6<double>& J_tool_q, double,
                  Eigen::Ref<Eigen::MatrixXd> rows) const override {
    rows = J_tool_q.topRows<3>();
  }
};

// A cable encoder (paper eq. 5): |p|, plus its zero d0 while step 2 estimates
// it ("instrument.zero").
class Distance : public MeasurementKind {
 public:
  Distance()
      : MeasurementKind({.name = "distance",
                         .plural = "distances",
                         .dimension = 1,
                         .width = 1,
                         .length_rows = 1,
                         .zero = true,
                         .distance_column = true,
                         .error_title = "Distance error per sample, before and after calibration",
                         .error_axis = "|delta_model - delta_measured| [mm]",
                         .tip = "distance"}) {}
  void predict(const Frame<double>& tool, double* values) const override {
    values[0] = tool.p.norm();
  }
  double sigma(const InstrumentNoise& noise) const override { return noise.distance; }
  void rows(const ChainStructure& s, const ChainConstants<double>& constants, const double* params,
            const double* joint, const double* measured, double, double* residual,
            Eigen::Ref<Eigen::MatrixXd> J) const override {
    Eigen::Matrix<double, 3, Eigen::Dynamic> J_p;
    const Eigen::Vector3d p = position_parameter_jacobian(s, constants, params, joint, J_p);
    const double delta = p.norm();
    residual[0] = delta - measured[0];
    J = (p / delta).transpose() * J_p;
    if (s.instrument) {  // the instrument reads |p| + d0
      residual[0] += params[s.instrument_slot()];
      J(0, s.instrument_slot()) = 1;
    }
  }
  void joint_rows(const Frame<double>& tool, const Jacobian6<double>& J_tool_q, double,
                  Eigen::Ref<Eigen::MatrixXd> rows) const override {
    rows = tool.p.normalized().transpose() * J_tool_q.topRows<3>();
  }
};

// A laser tracker: p, 3 rows.
class Position : public ToolPointKind {
 public:
  Position()
      : ToolPointKind({.name = "position",
                       .plural = "positions",
                       .dimension = 3,
                       .width = 3,
                       .length_rows = 3,
                       .own_frame = true,
                       .position_columns = true,
                       .error_title = "Position error per sample, before and after calibration",
                       .error_axis = "|p_model - p_measured| [mm]"}) {}
  void predict(const Frame<double>& tool, double* values) const override {
    for (int k = 0; k < 3; ++k) values[k] = tool.p[k];
  }
};

// Mocap, a tracker with a 6-D probe: p and s * log(R R_measured^T), 6 rows.
class Pose : public MeasurementKind {
 public:
  Pose()
      : MeasurementKind({.name = "pose",
                         .plural = "poses",
                         .dimension = 6,
                         .width = 7,
                         .length_rows = 3,
                         .rotation = true,
                         .own_frame = true,
                         .position_columns = true,
                         .orientation_columns = true,
                         .error_title = "Position error per sample, before and after calibration",
                         .error_axis = "|p_model - p_measured| [mm]"}) {}
  void from_log(const Log& log, int row, double* values) const override {
    for (int k = 0; k < 3; ++k) values[k] = log.position(row, k);
    for (int k = 0; k < 4; ++k) values[3 + k] = log.orientation(row, k);
  }
  void predict(const Frame<double>& tool, double* values) const override {
    for (int k = 0; k < 3; ++k) values[k] = tool.p[k];
    const Eigen::Quaterniond q(tool.R);
    values[3] = q.w();
    values[4] = q.x();
    values[5] = q.y();
    values[6] = q.z();
  }
  // The position with noise, then the orientation turned by a rotation vector
  // of noise.orientation per axis.
  void simulate(const Frame<double>& tool, const InstrumentNoise& noise,
                const std::function<double()>& gauss, double* values) const override {
    Eigen::Vector3d e, w;
    for (int k = 0; k < 3; ++k) e[k] = noise.position * gauss();
    for (int k = 0; k < 3; ++k) w[k] = noise.orientation * gauss();
    const double angle = w.norm();
    const Eigen::Matrix3d turn = angle > 0 ? Eigen::AngleAxisd(angle, w / angle).toRotationMatrix()
                                           : Eigen::Matrix3d::Identity();
    predict({turn * tool.R, tool.p + e}, values);
  }
  void rows(const ChainStructure& s, const ChainConstants<double>& constants, const double* params,
            const double* joint, const double* measured, double rotation_scale, double* residual,
            Eigen::Ref<Eigen::MatrixXd> J) const override {
    Eigen::Matrix<double, 6, Eigen::Dynamic> J6;
    const Frame<double> tool = pose_parameter_jacobian<6>(s, constants, params, joint, J6);
    measurement_residual(MeasurementType::kPose, tool, measured, rotation_scale, residual);
    const Eigen::Vector3d phi = Eigen::Map<Eigen::Vector3d>(residual + 3) / rotation_scale;
    J.topRows(3) = J6.topRows(3);
    // R -> exp(w) R turns log(R Rm^T) by J_l^-1(phi) w.
    J.bottomRows(3) = rotation_scale * inverse_left_jacobian(phi) * J6.bottomRows(3);
  }
  void joint_rows(const Frame<double>&, const Jacobian6<double>& J_tool_q, double rotation_scale,
                  Eigen::Ref<Eigen::MatrixXd> rows) const override {
    rows.topRows(3) = J_tool_q.topRows<3>();
    rows.bottomRows(3) = rotation_scale * J_tool_q.bottomRows<3>();
  }
};

// A fixture: the tool point at a fixed, unknown point (socket) or on a fixed,
// unknown plane per label; no measured values. Its raw rows are the tool point
// (fixture_residuals makes the fit's rows).
class FixtureKind : public ToolPointKind {
 public:
  using ToolPointKind::ToolPointKind;
  void from_log(const Log&, int, double* values) const override {
    for (int k = 0; k < 3; ++k) values[k] = 0;  // the raw rows are the tool point itself
  }
  void to_log(const MeasuredValues&, Log&) const override { placed_not_read(); }
  void predict(const Frame<double>&, double* values) const override {
    for (int k = 0; k < 3; ++k) values[k] = 0;  // nothing measured
  }
  void simulate(const Frame<double>&, const InstrumentNoise&, const std::function<double()>&,
                double*) const override {
    placed_not_read();
  }

 private:
  [[noreturn]] void placed_not_read() const {
    throw InputError(
        fmt::format("{} have no measured columns: simulate them with "
                    "simulate_fixture_log or simulate_plane_log",
                    traits().plural));
  }
};

class Point : public FixtureKind {
 public:
  Point()
      : FixtureKind(
            {.name = "point",
             .plural = "fixture points",
             .dimension = 3,
             .width = 3,
             .length_rows = 3,
             .fixture = true,
             .label_points = true,
             .error_title = "Distance of each sample's tool point from its fixture point's centre",
             .error_axis = "|p_model - centre| [mm]"}) {}
  bool in_log(const Log& log) const override { return log.has_point; }
};

class Plane : public FixtureKind {
 public:
  Plane()
      : FixtureKind({.name = "plane",
                     .plural = "plane contacts",
                     .dimension = 1,
                     .width = 3,
                     .length_rows = 1,
                     .fixture = true,
                     .error_title = "Distance of each sample's tool point from its plane",
                     .error_axis = "|n . (p_model - centre)| [mm]"}) {}
  // (A log has point or plane labels, never both: a point log is fitted on its points.)
  bool in_log(const Log& log) const override { return log.has_plane && !log.has_point; }
};

std::vector<std::unique_ptr<MeasurementKind>>& registry() {
  static std::vector<std::unique_ptr<MeasurementKind>> kinds = [] {
    std::vector<std::unique_ptr<MeasurementKind>> k;
    k.push_back(std::make_unique<Distance>());  // in MeasurementType's order
    k.push_back(std::make_unique<Position>());
    k.push_back(std::make_unique<Pose>());
    k.push_back(std::make_unique<Point>());
    k.push_back(std::make_unique<Plane>());
    return k;
  }();
  return kinds;
}

}  // namespace

bool MeasurementKind::in_log(const Log& log) const { return columns_in_log(traits_, log); }

void MeasurementKind::from_log(const Log& log, int row, double* values) const {
  if (!traits_.columns.empty()) {
    const Eigen::MatrixXd& v = log.columns.at(traits_.name);
    for (int k = 0; k < traits_.width; ++k) values[k] = v(row, k);
  } else if (traits_.position_columns) {
    for (int k = 0; k < 3; ++k) values[k] = log.position(row, k);
  } else if (traits_.distance_column) {
    values[0] = log.distance[row];
  }
}

void MeasurementKind::to_log(const MeasuredValues& values, Log& log) const {
  if (!traits_.columns.empty()) log.columns[traits_.name] = values;
  if (traits_.distance_column) {
    log.has_distance = true;
    log.distance = values.col(0);
  }
  if (traits_.position_columns) {
    log.has_position = true;
    log.position = values.leftCols(3);
  }
  if (traits_.orientation_columns) {
    log.has_orientation = true;
    log.orientation = values.rightCols(4);
  }
}

void MeasurementKind::simulate(const Frame<double>& tool, const InstrumentNoise& noise,
                               const std::function<double()>& gauss, double* values) const {
  predict(tool, values);
  const double sd = sigma(noise);
  for (int k = 0; k < traits_.width; ++k) values[k] += sd * gauss();
}

const MeasurementKind& kind_of(MeasurementType type) {
  const auto& kinds = registry();
  const auto i = static_cast<std::size_t>(type);
  if (i >= kinds.size()) throw std::invalid_argument("not a registered measurement kind");
  return *kinds[i];
}

MeasurementType register_measurement_kind(std::unique_ptr<MeasurementKind> kind) {
  if (!kind) throw std::invalid_argument("register_measurement_kind: no kind");
  const MeasurementTraits& t = kind->traits();
  if (measurement_type_named(t.name)) {
    throw std::invalid_argument(
        fmt::format("a measurement kind named '{}' is registered already", t.name));
  }
  if (!t.columns.empty() && static_cast<int>(t.columns.size()) != t.width) {
    throw std::invalid_argument(fmt::format("measurement kind '{}': {} columns for {} values",
                                            t.name, t.columns.size(), t.width));
  }
  // The log's own column names of letters alone (data_io/log_columns.cpp's
  // grammar; q, ext and dir take a joint's number): a kind may not take one.
  static const char* const kLogColumns[] = {"distance", "x",     "y",  "z",   "t",  "qw",
                                            "qx",       "qy",    "qz", "rx",  "ry", "rz",
                                            "point",    "plane", "q",  "ext", "dir"};
  for (const std::string& c : t.columns) {
    const bool name = !c.empty() && std::all_of(c.begin(), c.end(), [](char x) {
      return (x >= 'a' && x <= 'z') || (x >= 'A' && x <= 'Z') || x == '_';
    });
    const bool built_in =
        std::find(std::begin(kLogColumns), std::end(kLogColumns), c) != std::end(kLogColumns);
    if (!name || c == "_" || built_in || measurement_column(c)) {
      throw std::invalid_argument(fmt::format(
          "measurement kind '{}': column '{}' is not a name of letters and '_' or is taken", t.name,
          c));
    }
  }
  registry().push_back(std::move(kind));
  return static_cast<MeasurementType>(registry().size() - 1);
}

std::vector<MeasurementType> measurement_types() {
  std::vector<MeasurementType> all;
  for (std::size_t i = 0; i < registry().size(); ++i)
    all.push_back(static_cast<MeasurementType>(i));
  return all;
}

std::optional<std::pair<MeasurementType, int>> measurement_column(const std::string& name) {
  for (MeasurementType t : measurement_types()) {
    const std::vector<std::string>& columns = traits(t).columns;
    const auto it = std::find(columns.begin(), columns.end(), name);
    if (it != columns.end()) return std::pair(t, static_cast<int>(it - columns.begin()));
  }
  return std::nullopt;
}

std::optional<MeasurementType> measurement_type_named(const std::string& name) {
  for (MeasurementType t : measurement_types()) {
    if (name == traits(t).name) return t;
  }
  return std::nullopt;
}

MeasurementType measurement_type(const Log& log) {
  const std::vector<MeasurementType> all = measurement_types();
  for (auto it = all.rbegin(); it != all.rend(); ++it) {
    if (kind_of(*it).in_log(log)) return *it;
  }
  return MeasurementType::kDistance;
}

void measured_values(MeasurementType type, const Log& log, int row, double* out) {
  kind_of(type).from_log(log, row, out);
}
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

Eigen::Matrix3d inverse_left_jacobian(const Eigen::Vector3d& phi) {
  const double a = phi.norm();
  Eigen::Matrix3d W;
  W << 0, -phi[2], phi[1], phi[2], 0, -phi[0], -phi[1], phi[0], 0;
  // J_l^-1 = I - W / 2 + (1 / a^2 - (1 + cos a) / (2 a sin a)) W^2 (Barfoot,
  // State Estimation for Robotics, eq. 7.64); the series 1/12 + a^2/720 near 0.
  const double c =
      a < 1e-4 ? 1.0 / 12 + a * a / 720 : 1 / (a * a) - (1 + std::cos(a)) / (2 * a * std::sin(a));
  return Eigen::Matrix3d::Identity() - W / 2 + c * W * W;
}

}  // namespace hapticcal
