// The measurement family: what an instrument measures of
// the tool frame T_meas_tool, as residual rows predicted - measured with an
// analytic Jacobian w.r.t. the kinematic parameters.
//   distance (cable encoder, paper eq. 5): |p|, 1 row (|p| + d0 while step 2
//     estimates the encoder's zero d0, "instrument.zero")
//   position (laser tracker):              p, 3 rows
//   pose (mocap, tracker with a 6-D probe): p and the rotation R, 6 rows: the
//     position error and s * log(R R_measured^T), the rotation error as a
//     rotation vector in the measurement frame times a length s (metres per
//     radian), so that both parts are lengths.
//   point (a fixture socket, a label a sample): the tool point is at a fixed,
//     unknown point: p - m, 3 rows, m the label's mean point (or its known
//     position k, from a fixture file: p - k)
//   plane (a plate touched, a label a sample): the tool point is on a fixed,
//     unknown plane: n . (p - m), 1 row, n the normal of the label's best plane
//   Fixture points and planes have no measured values: the unknown point or
//   plane of a label is eliminated (variable projection: for given parameters
//   its best estimate is the mean, or the best plane, of the label's predicted
//   points), and known distances between points add a row each.
// Everything that depends on the kind of measurement (the fit, evaluate, the
// reports, the Cramer-Rao bound) asks this family instead of switching itself.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "hapticcal/core/log.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model/frame.hpp"

namespace hapticcal {

// A kind of measurement. The built-in kinds; a kind registered with
// register_measurement_kind gets the next number.
enum class MeasurementType : int { kDistance, kPosition, kPose, kPoint, kPlane };

// Measured values, one row a sample (traits(type).width values), contiguous.
using MeasuredValues = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// What a kind is, for everything that is not its arithmetic.
struct MeasurementTraits {
  const char* name;    // "distance", "position", "pose", "point", "plane"
  const char* plural;  // "distances", ...
  int dimension;       // residual rows a sample (a fixture's after projection: 3, 1)
  int width;           // values a sample: 1, 3, 7 (x, y, z, qw, qx, qy, qz); a fixture's 3 (zeros)
  // The residual rows that are a length error (the first ones; the rest are a
  // pose's rotation rows, times the rotation scale, reported apart).
  int length_rows;
  bool fixture = false;       // labels, no measured values (fixture points, plane contacts)
  bool rotation = false;      // rotation rows: a rotation scale, an orientation noise, a tool pose
  bool label_points = false;  // fixture labels are points: known distances fix the robot's size
  // The log's built-in columns its values come from and go to.
  bool distance_column = false, position_columns = false, orientation_columns = false;
  // Reports: the per-sample error figure's title and axis (mm), and what a
  // plan calls the tool point's measurement.
  const char* error_title = "";
  const char* error_axis = "";
  const char* tip = "position";
  // A registered kind's columns in a log file, one a value (`width` of them),
  // lengths (m, or with a unit [mm], [um]); read into and written from
  // Log::columns under the kind's name. The built-in kinds have their own
  // columns (distance, x, y, z, qw..qz) and leave this empty.
  std::vector<std::string> columns = {};
};

// The noise of the instruments a simulation or a plan assumes: each one's sd
// [m, rad]; a kind takes its own (MeasurementKind::sigma, simulate).
struct InstrumentNoise {
  double distance = 0;     // a cable encoder's [m]
  double position = 0;     // a tracker's, per coordinate [m]
  double orientation = 0;  // a pose's rotation, per axis [rad]
};

// A figure evaluate reports of a kind: each sample's error, its RMS and
// largest, and its plot. A length in metres (printed in mm) or an angle in
// radians (printed in mrad).
struct ErrorFigure {
  const char* name;   // "distance", "position", "orientation", a registered kind's name
  const char* title;  // the per-sample plot's title
  const char* axis;   // and its axis
  bool angle = false;
  const char* unit() const { return angle ? "mrad" : "mm"; }
};

// One kind of measurement: its facts (traits), how a log holds it, what an
// instrument without error reads of the tool frame, and its residual rows with
// their analytic Jacobian. A new kind is one subclass and one
// register_measurement_kind call; nothing else switches on the kind.
class MeasurementKind {
 public:
  explicit MeasurementKind(const MeasurementTraits& traits) : traits_(traits) {}
  virtual ~MeasurementKind() = default;
  const MeasurementTraits& traits() const { return traits_; }

  // Whether a log holds this kind (the default: its columns).
  virtual bool in_log(const Log& log) const;
  // A log row's `width` values (the default: from its columns).
  virtual void from_log(const Log& log, int row, double* values) const;
  // The values (one row a sample) into the log's columns, which it marks present.
  virtual void to_log(const MeasuredValues& values, Log& log) const;
  // What an instrument without error reads of the tool frame T_meas_tool
  // (`width` values; a fixture's: zeros).
  virtual void predict(const Frame<double>& tool, double* values) const = 0;
  // Whether a sample's values hold the tool point in the instrument's own frame
  // (a tracker's x, y, z: its frame can be registered to the model's tool
  // points; the default: no), and that point of a sample's values (the
  // default: its first three).
  virtual bool measures_point() const { return false; }
  virtual Eigen::Vector3d measured_point(const double* values) const {
    return {values[0], values[1], values[2]};
  }
  // Whether the instrument reads an unknown additive zero on top of its values
  // (a cable encoder's d0, step 2's candidate "instrument.zero"; the default:
  // no), and a reading `values` with that zero (the default: unchanged).
  virtual bool reads_zero() const { return false; }
  virtual void add_zero(double /*zero*/, double* /*values*/) const {}
  // The sd of this kind's length values among an instrument noise's (the
  // default: a tracker's, noise.position).
  virtual double sigma(const InstrumentNoise& noise) const { return noise.position; }
  // What an instrument of this kind reads of the tool frame with `noise`:
  // predict's values, then the noise drawn by `gauss` (standard normal draws,
  // one after another). The default: sigma(noise) times a draw on each value.
  // A fixture's throws (its samples are placed, not read: simulate_fixture_log).
  virtual void simulate(const Frame<double>& tool, const InstrumentNoise& noise,
                        const std::function<double()>& gauss, double* values) const;
  // What evaluate reports of a log of this kind, one error a sample each (the
  // default: one figure named as the kind, its traits' title and axis; a
  // fixture kind's: none, evaluate scores its labels).
  virtual std::vector<ErrorFigure> error_figures() const;
  // One sample's errors, one a figure, from the tool frame and the sample's
  // measured values (the default: predicted - measured over the length values,
  // signed if there is one, else the norm).
  virtual void errors(const Frame<double>& tool, const double* measured, double* out) const;
  // The residual rows (predicted - measured) of one sample and their analytic
  // Jacobian (dimension x num_slots) w.r.t. the parameters; a fixture sample's
  // raw rows, the tool point (3 rows; fixture_residuals makes the fit's rows).
  virtual void rows(const ChainStructure& s, const ChainConstants<double>& constants,
                    const double* params, const double* joint, const double* measured,
                    double rotation_scale, double* residual,
                    Eigen::Ref<Eigen::MatrixXd> J) const = 0;
  // The rows' Jacobian w.r.t. the joint values (dimension x dof) from the tool
  // frame's geometric Jacobian in the measurement frame.
  virtual void joint_rows(const Frame<double>& tool, const Jacobian6<double>& J_tool_q,
                          double rotation_scale, Eigen::Ref<Eigen::MatrixXd> rows) const = 0;

 private:
  MeasurementTraits traits_;
};

// The kind of a type.
const MeasurementKind& kind_of(MeasurementType type);
inline const MeasurementTraits& traits(MeasurementType type) { return kind_of(type).traits(); }
// Adds a kind (before any calibration runs: the registry is not locked) and
// returns its type. Throws std::invalid_argument for a name already taken.
MeasurementType register_measurement_kind(std::unique_ptr<MeasurementKind> kind);
// Every kind, built-in ones first, in the order they were registered.
std::vector<MeasurementType> measurement_types();
// The kind named `name` (traits(type).name), or none.
std::optional<MeasurementType> measurement_type_named(const std::string& name);
// The registered kind whose log column is `name` and the value it holds, or none.
std::optional<std::pair<MeasurementType, int>> measurement_column(const std::string& name);

// Fixture points and planes: labels, no measured values.
inline bool is_fixture(MeasurementType t) { return traits(t).fixture; }
// A measurement with rotation rows (poses): orientation errors to report.
inline bool measures_orientation(MeasurementType t) { return traits(t).rotation; }
// A measurement with a distance column (a cable encoder's).
inline bool measures_distance(MeasurementType t) { return traits(t).distance_column; }
// The tool frame's slots a kind's rows see: its pose's (kPoseSlots) with
// rotation rows, its point's 3 else; "pose" or "point" in words.
int observed_tool_slots(MeasurementType t);
const char* observed_tool(MeasurementType t);
// Whether residual row `row` (of a sample's `dimension`) is a rotation row.
inline bool rotation_row(MeasurementType t, int row) {
  return row % traits(t).dimension >= traits(t).length_rows;
}

// Whether a log holds the values (or the labels) of kind `type`.
inline bool holds(const Log& log, MeasurementType type) { return kind_of(type).in_log(log); }
// Whether a log holds a fixture's labels (its rows' points or planes; an ISO
// 9283 test log's pose names are not a fixture's).
bool holds_fixture(const Log& log);
// The kinds a log holds (MeasurementKind::in_log), built-in ones first.
std::vector<MeasurementType> kinds_in(const Log& log);
// What a log measures: the last registered kind it holds (so fixture points
// or planes if it has labels, a pose if it has orientations, else positions,
// else distances; a log with positions and distances is fitted on its
// positions); distances if none.
MeasurementType measurement_type(const Log& log);
// The `width` measured values of a log row.
void measured_values(MeasurementType type, const Log& log, int row, double* out);
// What an instrument of this type without error reads of the tool frame.
inline void predicted_values(MeasurementType type, const Frame<double>& tool, double* out) {
  kind_of(type).predict(tool, out);
}

// Where a fact about the fixture was given, for its error messages: a fixture
// file's line and key, or a command-line option (file empty, line 0).
struct FixtureSource {
  std::string file;
  int line = 0;
  std::string key = "--point-distance";
};

// A known distance between two fixture points (labels), e.g. a fixture's
// sockets (`--point-distance A:B=METRES` or a fixture file's `distances`).
struct PointDistance {
  std::string a, b;
  double metres = 0;
  FixtureSource source = {};
};

// A fixture point's known position in the measurement frame (a fixture file's
// `points`): that label is not eliminated, its rows are p_i - p_meas.
struct KnownPoint {
  std::string label;
  Eigen::Vector3d p_meas = Eigen::Vector3d::Zero();
  FixtureSource source = {};
};

// The labels of a fixture problem's poses and the known distances between them.
struct FixtureLabels {
  bool points = true;              // points (sockets) the tool point is at, else planes it touches
  std::vector<std::string> names;  // in order of first appearance
  std::vector<int> of_pose;        // label index of each pose
  struct Known {
    int a = 0, b = 0;
    double metres = 0;
  };
  std::vector<Known> distances;
  // Per label, its known position (a fixture file's `points`) or none: eliminated.
  std::vector<std::optional<Eigen::Vector3d>> known_point;
  int count() const { return static_cast<int>(names.size()); }
  int known_points() const;  // labels with a known position
  // The unknowns the projection takes out of the rows: 3 an eliminated label.
  int unknowns() const { return 3 * (count() - known_points()); }
};
// The labels of `rows` of a fixture log; throws InputError (naming where the
// fact was given) for a distance or known point naming a label the log lacks, a
// distance given twice (or two different ones for one pair), a distance between
// two known points (redundant), a point label with fewer than 2 samples or a
// plane label with fewer than 4 (any 3 points lie on a plane).
FixtureLabels fixture_labels(MeasurementType type, const Log& log, const std::vector<int>& rows,
                             const std::vector<PointDistance>& distances,
                             const std::vector<KnownPoint>& known_points = {});

// The fit's residual rows of a fixture problem from each pose's tool point
// (raw: 3 rows a pose, p_i) and, if raw_J, its Jacobian (3 rows a pose):
//   point: w_i (p_i - m_L), 3 rows; plane: w_i n_L . (p_i - m_L), 1 row;
//   then per known distance (|m_A - m_B| - D) / sqrt(1 / W_A + 1 / W_B),
// W_L the summed weights w_i^2 of a label: for labels in one known distance at
// most, exactly the least squares with the distance as a constraint (the two
// points moved apart along their line); m_L the label's mean point (weights
// w_i^2), or its known position (then 1 / W_L = 0: it does not move), n_L the
// normal of its best plane
// (the smallest principal axis of its points). The Jacobian is exact: m_L's and
// n_L's dependence on the points included (the normal by eigenvector
// perturbation). w: each pose's weight (sqrt of its repeats; empty: 1).
int fixture_rows(MeasurementType type, const FixtureLabels& labels, int poses);
void fixture_residuals(MeasurementType type, const FixtureLabels& labels, const Eigen::VectorXd& w,
                       const Eigen::VectorXd& raw, const Eigen::MatrixXd* raw_J, double* residual,
                       Eigen::MatrixXd* J);

// The rotation vector of a rotation matrix (templated: double or ceres::Jet).
template <typename T>
Vec3<T> rotation_log(const Mat3<T>& R) {
  using std::atan2;
  using std::sqrt;
  const Vec3<T> v(R(2, 1) - R(1, 2), R(0, 2) - R(2, 0), R(1, 0) - R(0, 1));  // 2 sin(a) axis
  const T s2 = v.squaredNorm();
  const T c = (R.trace() - T(1)) / T(2);
  if (s2 < T(1e-12) && c < T(0)) {
    // a near pi: sin(a) carries no axis; (R + I) / 2 = cos^2(a/2) I + sin^2(a/2) u u^T
    // does, from its largest diagonal entry, with the sign of v.
    int k = 0;
    for (int i = 1; i < 3; ++i) {
      if (R(i, i) > R(k, k)) k = i;
    }
    Vec3<T> u = (R.col(k) + Vec3<T>::Unit(k)) / T(2);
    u /= u.norm();
    if (u.dot(v) < T(0)) u = -u;
    return u * atan2(sqrt(s2) / T(2), c);
  }
  if (s2 < T(1e-24)) return v / T(2);  // a -> 0: a / sin(a) -> 1
  const T s = sqrt(s2) / T(2);
  const T a = atan2(s, c);
  return v * (a / (T(2) * s));
}

// J_l^-1(phi): how log(exp(w) exp(phi)) changes with a small turn w.
Eigen::Matrix3d inverse_left_jacobian(const Eigen::Vector3d& phi);

// Residual rows (predicted - measured) of one sample from the predicted tool
// frame, templated on the scalar.
template <typename T>
void measurement_residual(MeasurementType type, const Frame<T>& tool, const double* measured,
                          double rotation_scale, T* residual) {
  if (type == MeasurementType::kDistance) {
    residual[0] = tool.p.norm() - T(measured[0]);
    return;
  }
  for (int k = 0; k < 3; ++k) residual[k] = tool.p[k] - T(measured[k]);
  if (type == MeasurementType::kPose) {
    const Eigen::Quaterniond q(measured[3], measured[4], measured[5], measured[6]);
    const Mat3<T> Rm = q.toRotationMatrix().cast<T>();
    const Vec3<T> phi = rotation_log(Mat3<T>(tool.R * Rm.transpose()));
    for (int k = 0; k < 3; ++k) residual[3 + k] = T(rotation_scale) * phi[k];
  }
}

// The residual rows of one sample and their analytic Jacobian (dimension x
// num_slots) w.r.t. the parameters (MeasurementKind::rows).
inline void measurement_rows(MeasurementType type, const ChainStructure& s,
                             const ChainConstants<double>& constants, const double* params,
                             const double* joint, const double* measured, double rotation_scale,
                             double* residual, Eigen::Ref<Eigen::MatrixXd> J) {
  kind_of(type).rows(s, constants, params, joint, measured, rotation_scale, residual, J);
}

}  // namespace hapticcal
