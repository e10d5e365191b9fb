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
                         .distance_column = true,
                         .error_title = "Distance error per sample, before and after calibration",
                         .error_axis = "|delta_model - delta_measured| [mm]",
                         .tip = "distance"}) {}
  void predict(const Frame<double>& tool, double* values) const override {
    values[0] = tool.p.norm();
  }
  bool reads_zero() const override { return true; }
  void add_zero(double zero, double* values) const override { values[0] += zero; }
  double sigma(const InstrumentNoise& noise) const override { return noise.distance; }
  std::vector<ErrorFigure> error_figures() const override {
    return {{"distance", "Distance error per sample", "|delta_model - delta_measured| [mm]"}};
  }
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

const ErrorFigure kPositionFigure{"position", "Position error per sample",
                                  "|p_model - p_measured| [mm]"};

// A laser tracker: p, 3 rows.
class Position : public ToolPointKind {
 public:
  Position()
      : ToolPointKind({.name = "position",
                       .plural = "positions",
                       .dimension = 3,
                       .width = 3,
                       .length_rows = 3,
                       .position_columns = true,
                       .error_title = "Position error per sample, before and after calibration",
                       .error_axis = "|p_model - p_measured| [mm]"}) {}
  bool measures_point() const override { return true; }
  void predict(const Frame<double>& tool, double* values) const override {
    for (int k = 0; k < 3; ++k) values[k] = tool.p[k];
  }
  std::vector<ErrorFigure> error_figures() const override { return {kPositionFigure}; }
  void errors(const Frame<double>& tool, const double* measured, double* out) const override {
    out[0] = (tool.p - Eigen::Map<const Eigen::Vector3d>(measured)).norm();
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
                         .position_columns = true,
                         .orientation_columns = true,
                         .error_title = "Position error per sample, before and after calibration",
                         .error_axis = "|p_model - p_measured| [mm]"}) {}
  bool measures_point() const override { return true; }
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
  // The position's and the orientation's: the angle of R_model R_measured^T.
  std::vector<ErrorFigure> error_figures() const override {
    return {kPositionFigure,
            {"orientation", "Orientation error per sample", "orientation error [mrad]", true}};
  }
  void errors(const Frame<double>& tool, const double* measured, double* out) const override {
    out[0] = (tool.p - Eigen::Map<const Eigen::Vector3d>(measured)).norm();
    const Eigen::Quaterniond q(measured[3], measured[4], measured[5], measured[6]);
    out[1] = rotation_log(Eigen::Matrix3d(tool.R * q.toRotationMatrix().transpose())).norm();
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

std::vector<ErrorFigure> MeasurementKind::error_figures() const {
  if (traits_.fixture) return {};
  return {{traits_.name, traits_.error_title, traits_.error_axis}};
}

void MeasurementKind::errors(const Frame<double>& tool, const double* measured, double* out) const {
  std::vector<double> predicted(static_cast<size_t>(traits_.width));
  predict(tool, predicted.data());
  if (traits_.length_rows == 1) {
    out[0] = predicted[0] - measured[0];
    return;
  }
  double sum = 0;
  for (int k = 0; k < traits_.length_rows; ++k) sum += std::pow(predicted[k] - measured[k], 2);
  out[0] = std::sqrt(sum);
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

std::vector<MeasurementType> kinds_in(const Log& log) {
  std::vector<MeasurementType> held;
  for (MeasurementType t : measurement_types())
    if (kind_of(t).in_log(log)) held.push_back(t);
  return held;
}

int observed_tool_slots(MeasurementType t) { return traits(t).rotation ? kPoseSlots : 3; }
const char* observed_tool(MeasurementType t) { return traits(t).rotation ? "pose" : "point"; }

bool holds_fixture(const Log& log) {
  for (MeasurementType t : kinds_in(log))
    if (traits(t).fixture) return true;
  return false;
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
