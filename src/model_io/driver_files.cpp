// A calibrated built-in device's calibration in its driver's own file
// (model_io/driver_files.hpp).
#include "hapticcal/model_io/driver_files.hpp"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <Eigen/QR>
#include <cmath>
#include <random>

#include "hapticcal/core/error.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model/joint_effect.hpp"

namespace hapticcal {
namespace {

// The turn about `axis` (unit, in the child frame) of R_nominal^T R_calibrated:
// the twist of its swing-twist decomposition, which a joint's zero takes up.
double twist_about(const Mat3<double>& nominal, const Mat3<double>& calibrated,
                   const Eigen::Vector3d& axis) {
  const Eigen::Quaterniond d(Mat3<double>(nominal.transpose() * calibrated));
  return 2 * std::atan2(d.vec().dot(axis), d.w());
}

// Joint i's zero in `calibrated` beyond `nominal`'s [rad or m].
double zero_change(const Link& c, const Link& n) {
  if (traits(c.geometry).dh_parameters) return c.prismatic() ? c.d - n.d : c.theta - n.theta;
  const double offset = c.offset - n.offset;
  if (c.prismatic()) return offset;
  return offset + twist_about(rpy_matrix(n.origin[3], n.origin[4], n.origin[5]),
                              rpy_matrix(c.origin[3], c.origin[4], c.origin[5]), c.axis);
}

// A transmission's best line dtheta(r) ~ a + b r over the reading's limits
// (least squares on 101 points), with the joint's effects: {b, a}; none: {0, 0}.
std::pair<double, double> transmission_line(const Link& l) {
  if (l.transmission.is_none() && l.effects.empty()) return {0, 0};
  Eigen::MatrixXd A(101, 2);
  Eigen::VectorXd y(101);
  for (int k = 0; k <= 100; ++k) {
    const double r = l.lower + (l.upper - l.lower) * k / 100.0;
    A(k, 0) = r;
    A(k, 1) = 1;
    y[k] = l.transmission.error(r) + effects_error(l, r);
  }
  const Eigen::Vector2d line = A.colPivHouseholderQr().solve(y);
  return {line[0], line[1]};
}

constexpr int kMapDraws = 300;
constexpr int kMapSteps = 10;  // Gauss-Newton steps from the parameters' map
constexpr double kMapStep = 1e-7;
constexpr double kMapRotationScale = 0.1;  // m/rad: a turn of the tool counts as this length

// Readings drawn within the limits (seeded), one a column.
Eigen::MatrixXd reading_draws(const DeviceModel& m) {
  std::mt19937_64 rng(57);
  Eigen::MatrixXd out(m.dof(), kMapDraws);
  for (int k = 0; k < kMapDraws; ++k) {
    for (int i = 0; i < m.dof(); ++i) {
      const Link& l = m.links[static_cast<size_t>(i)];
      out(i, k) = std::uniform_real_distribution<double>(l.lower, l.upper)(rng);
    }
  }
  return out;
}

// The nominal model's pose at the mapped readings less the calibrated one's at
// the readings, each draw's position and scaled turn; x: scales, then offsets.
Eigen::VectorXd map_errors(const PreparedModel& calibrated, const PreparedModel& nominal,
                           const Eigen::MatrixXd& draws, const Eigen::VectorXd& x) {
  const Eigen::Index n = draws.rows();
  Eigen::VectorXd e(6 * draws.cols());
  for (Eigen::Index k = 0; k < draws.cols(); ++k) {
    const Eigen::VectorXd r = draws.col(k);
    const Eigen::VectorXd mapped = x.head(n).cwiseProduct(r) + x.tail(n);
    const Frame<double> want = calibrated.forward(r.data()), got = nominal.forward(mapped.data());
    const Eigen::AngleAxisd turn(Mat3<double>(got.R * want.R.transpose()));
    e.segment<3>(6 * k) = got.p - want.p;
    e.segment<3>(6 * k + 3) = kMapRotationScale * turn.angle() * turn.axis();
  }
  return e;
}

std::string numbers(const std::vector<double>& v) {
  std::string out;
  for (size_t i = 0; i < v.size(); ++i) out += fmt::format("{}{:.17g}", i ? ", " : "", v[i]);
  return out;
}

}  // namespace

ReadingMap reading_map(const DeviceModel& calibrated, const DeviceModel& nominal) {
  const int n = nominal.dof();
  if (calibrated.dof() != n)
    throw InputError(fmt::format("driver file: {} joints, not {}", calibrated.dof(), n));
  // Joint values: theta = C (r + dtheta(r)) + zero. A change of zero dz and a
  // transmission's line a + b r are the readings' map C (b r + a) + dz = C (s r + o) - C r.
  Eigen::VectorXd zero(n), line_offset(n), slope(n);
  for (int i = 0; i < n; ++i) {
    const Link& c = calibrated.links[static_cast<size_t>(i)];
    const Link& m = nominal.links[static_cast<size_t>(i)];
    zero[i] = zero_change(c, m);
    const auto [b, a] = transmission_line(c);
    const auto [bn, an] = transmission_line(m);
    slope[i] = b - bn;
    line_offset[i] = a - an;
  }
  const Eigen::MatrixXd C =
      calibrated.coupled() ? calibrated.coupling : Eigen::MatrixXd::Identity(n, n);
  // The readings' offsets o with C o = dz (least squares where C is singular:
  // a passive joint's zero is no reading's).
  const Eigen::VectorXd o = C.completeOrthogonalDecomposition().solve(zero) + line_offset;
  // That start refined on the tool's poses: the map of least squares over
  // readings drawn within the limits, whatever parameters the calibration
  // moved to hold a zero (an origin's turn and shift, another joint's zero).
  Eigen::VectorXd x(2 * n);
  x << Eigen::VectorXd::Ones(n) + slope, o;
  const Eigen::MatrixXd draws = reading_draws(nominal);
  const PreparedModel a(calibrated), b(nominal);
  for (int step = 0; step < kMapSteps; ++step) {
    const Eigen::VectorXd e = map_errors(a, b, draws, x);
    Eigen::MatrixXd J(e.size(), 2 * n);
    for (int k = 0; k < 2 * n; ++k) {
      Eigen::VectorXd moved = x;
      moved[k] += kMapStep;
      J.col(k) = (map_errors(a, b, draws, moved) - e) / kMapStep;
    }
    const Eigen::VectorXd dx = J.colPivHouseholderQr().solve(-e);
    x += dx;
    if (dx.cwiseAbs().maxCoeff() < 1e-13) break;
  }
  ReadingMap map;
  for (int i = 0; i < n; ++i) {
    map.scale.push_back(x[i]);
    map.offset.push_back(x[n + i]);
  }
  // What it leaves out: the tool points apart over the draws.
  const Eigen::VectorXd e = map_errors(a, b, draws, x);
  double sum = 0;
  for (Eigen::Index k = 0; k < draws.cols(); ++k) sum += e.segment<3>(6 * k).squaredNorm();
  map.left_out = std::sqrt(sum / static_cast<double>(draws.cols()));
  return map;
}

namespace {

// The dVRK MTM's joint limits [rad] as its kinematic file states them
// (jhu-dvrk/sawIntuitiveResearchKit share/kinematic/mtmr.json, commit 2a3ae486):
// the device file's limits are a box in the actuators' readings, not these.
constexpr double kMtmLimits[7][2] = {
    {-1.13446, 0.698132}, {-0.261799, 0.872665}, {-0.872665, 0.610865}, {-1.22173, 4.01426},
    {-1.5708, 3.14159},   {-0.785398, 0.785398}, {-8.37758, 7.85398}};

std::string matrix_text(const Eigen::MatrixXd& m, const std::string& indent) {
  std::string out = "[";
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    out += fmt::format("{}\n{}  [", r ? "," : "", indent);
    for (Eigen::Index c = 0; c < m.cols(); ++c)
      out += fmt::format("{}{:.17g}", c ? ", " : "", m(r, c));
    out += "]";
  }
  return out + "\n" + indent + "]";
}

// The MTM's kinematic file (sawIntuitiveResearchKit: "base-offset", the
// standard DH links as cisst's robDH reads them, theta + offset + q, upper-case
// A and D, and the coupling), or none if the model is not standard DH with
// revolute joints.
std::optional<DriverFile> mtm_file(const DeviceModel& m) {
  if (m.base_kind != BaseKind::kPose) return std::nullopt;
  for (const Link& l : m.links) {
    if (l.geometry != Geometry::kDh || l.prismatic() || !l.transmission.is_none())
      return std::nullopt;
  }
  const Frame<double> base = pose_frame(m.base);
  Eigen::Matrix4d base_offset = Eigen::Matrix4d::Identity();
  base_offset.topLeftCorner<3, 3>() = base.R;
  base_offset.topRightCorner<3, 1>() = base.p;
  std::string links;
  for (int i = 0; i < m.dof(); ++i) {
    const Link& l = m.links[static_cast<size_t>(i)];
    links += fmt::format(
        "{}\n      {{\"name\": \"{}\", \"alpha\": {:.17g}, \"A\": {:.17g}, \"theta\": 0.0, "
        "\"D\": {:.17g}, \"type\": \"revolute\", \"mode\": \"active\", \"offset\": {:.17g}, "
        "\"qmin\": {}, \"qmax\": {}}}",
        i ? "," : "", l.name, l.alpha, l.a, l.d, l.theta, kMtmLimits[i][0], kMtmLimits[i][1]);
  }
  const Eigen::MatrixXd C = m.coupled() ? m.coupling : Eigen::MatrixXd::Identity(m.dof(), m.dof());
  double beta = 0;
  for (const Link& l : m.links) beta = std::max(beta, std::abs(l.beta));
  const Frame<double> tool_frame = pose_frame(m.tool);
  const double tool = tool_frame.p.norm();
  const double tool_turn = Eigen::AngleAxisd(Mat3<double>(tool_frame.R)).angle();
  DriverFile f;
  f.name = "dvrk-mtm.json";
  f.text = fmt::format(
      "{{\n  \"base-offset\": {},\n  \"DH\": {{\n    \"convention\": \"standard\",\n"
      "    \"links\": [{}\n    ]\n  }},\n  \"coupling\": {{\n    \"ActuatorToJointPosition\": "
      "{}\n  }}\n}}\n",
      matrix_text(base_offset, "  "), links, matrix_text(C, "    "));
  f.note = fmt::format(
      "dvrk-mtm.json holds the calibrated DH links (alpha, A, D, offset), base-offset and "
      "coupling as sawIntuitiveResearchKit's kinematic file (qmin and qmax mtmr.json's; merge "
      "ftmax and the dynamics of your own file){}",
      beta > 1e-12 || tool > 1e-12 || tool_turn > 1e-12
          ? fmt::format(": not the links' beta (up to {:.3f} mrad) or the tool ({:.3f} mm, "
                        "{:.3f} mrad), which device.yaml holds",
                        beta * 1e3, tool * 1e3, tool_turn * 1e3)
          : "");
  return f;
}

}  // namespace

std::optional<DriverFile> driver_file(const DeviceModel& calibrated, const DeviceModel& nominal) {
  if (nominal.name == "dvrk-mtm" && nominal.dof() == 7 && calibrated.dof() == 7)
    return mtm_file(calibrated);
  if (nominal.name != "geomagic-touch" || nominal.dof() != 6) return std::nullopt;
  const ReadingMap map = reading_map(calibrated, nominal);
  DriverFile f;
  f.name = "sawSensablePhantom.json";
  f.text = fmt::format(
      "{{\n"
      "  \"devices\": [\n"
      "    {{\n"
      "      \"name\": \"Default PHANToM\",\n"
      "      \"rename\": \"arm\",\n"
      "      \"joint-scales\": [{}],\n"
      "      \"joint-offsets\": [{}]\n"
      "    }}\n"
      "  ]\n"
      "}}\n",
      numbers(map.scale), numbers(map.offset));
  f.note = fmt::format(
      "sawSensablePhantom.json holds the calibrated joint zeros and scales the driver applies to "
      "its joint states (relative to its defaults, scales 1 and offsets 0; merge a configuration "
      "of your own): not the lengths, axes and tool, {:.4f} mm RMS over the workspace, which "
      "device.yaml holds (the driver's Cartesian pose is OpenHaptics' own)",
      map.left_out * 1e3);
  return f;
}

}  // namespace hapticcal
