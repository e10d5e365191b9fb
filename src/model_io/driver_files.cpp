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
// (least squares on 101 points): {b, a}; none: {0, 0}.
std::pair<double, double> transmission_line(const Link& l) {
  if (l.transmission.is_none()) return {0, 0};
  Eigen::MatrixXd A(101, 2);
  Eigen::VectorXd y(101);
  for (int k = 0; k <= 100; ++k) {
    const double r = l.lower + (l.upper - l.lower) * k / 100.0;
    A(k, 0) = r;
    A(k, 1) = 1;
    y[k] = l.transmission.error(r);
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

std::optional<DriverFile> driver_file(const DeviceModel& calibrated, const DeviceModel& nominal) {
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
