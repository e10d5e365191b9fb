// Checks of a log before it is fitted: joint readings within the limits, encoder
// readings that are readings, and a nominal error plausible for this device.
#include <ceres/ceres.h>
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <map>
#include <numeric>
#include <random>
#include <unordered_map>

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/identification/registration.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "identification/calibration_run.hpp"
#include "identification/problem/measurement_cost.hpp"
#include "identification/problem/solver_options.hpp"
#include "identification/problem/stack.hpp"

namespace hapticcal {
namespace {

using detail::measurement_cost;
using detail::measurement_rms;
using detail::position_rss;
using detail::residuals_at;
using detail::RowMatrix;
using detail::RowsOf;
using detail::stack;

}  // namespace

namespace {

// What a log's readings outside a joint's limits likely are, from how the log
// was written: a recording's joint states are radians (ROS's unit), so
// readings hapticcal import mapped by a driver's convention and still out are
// another driver's signs and offsets, not degrees. Empty for other logs.
std::string imported_readings_hint(const Log& log) {
  if (log.comment.rfind("hapticcal import of ", 0) != 0) return "";
  const std::size_t at = log.comment.find("; --convention ");
  if (at == std::string::npos) {
    return "; the log is a recording's joint states (radians): if the driver publishes its own "
           "signs and offsets, import it with the driver's --convention";
  }
  const std::string name = log.comment.substr(at + 15, log.comment.find(';', at + 15) - at - 15);
  return name == "none"
             ? "; the log is a recording's joint states as published (--convention none): if "
               "the driver publishes its own signs and offsets, import it with the driver's "
               "--convention"
             : fmt::format(
                   "; the readings were mapped at import by --convention {}: another "
                   "driver's signs and offsets give such readings (is {} the driver's? "
                   "import again with the driver's --convention)",
                   name, name);
}

// The play a reading of `link` may go beyond a stop by: its backlash, at
// least kReadingPlay.
double reading_play(const Link& link) {
  return std::max(std::abs(link.backlash),
                  link.prismatic() ? kReadingPlayLength : kReadingPlayAngle);
}

// A coupled joint's value (C q)_i beyond its range (Link::range_lower, upper)
// by more than its play, as check_joint_limits judges a reading.
void check_joint_ranges(const Log& log, const DeviceModel& model, bool force,
                        std::vector<std::string>& notes) {
  for (int i = 0; i < model.dof(); ++i) {
    const Link& link = model.links[i];
    if (!link.has_range()) continue;
    const double play = reading_play(link);
    int out = 0, first = -1;
    double first_value = 0;
    for (int r = 0; r < log.rows; ++r) {
      const double value = model.coupling.row(i).dot(log.q.row(r));
      if (value >= link.range_lower - play && value <= link.range_upper + play) continue;
      if (out++ == 0) {
        first = r;
        first_value = value;
      }
    }
    if (out == 0) continue;
    const char* unit = link.prismatic() ? "m" : "rad";
    const int line = first < static_cast<int>(log.line.size()) ? log.line[first] : first + 2;
    const std::string message = fmt::format(
        "{} of {} rows put {} (its coupling of the readings) outside its range [{:.4g}, {:.4g}] {} "
        "by more than its play ({:.3g} {}), the first at line {} ({:.4g})",
        out, log.rows, link.name, link.range_lower, link.range_upper, unit, play, unit, line,
        first_value);
    if (2 * out > log.rows && !force) {
      throw InputError(log.origin, 0, fmt::format("q{}", i + 1),
                       message + " (--force calibrates anyway)");
    }
    notes.push_back(fmt::format("warning: {}: {}", link.name, message));
  }
}

}  // namespace

namespace detail {

// Readings beyond the model's joint limits by more than the joint's play (its
// backlash, at least kReadingPlay): an InputError when most of a joint's
// readings are out (a unit missing from the header, another device, or an
// imported recording's driver convention), unless forced; a warning otherwise,
// naming the first such row. A reading within the play of a limit is the
// device at its stop, not an error.
void check_joint_limits(const Log& log, const DeviceModel& model, bool force,
                        std::vector<std::string>& notes) {
  for (int j = 0; j < model.dof(); ++j) {
    const Link& link = model.links[j];
    if (!model.reading_used(j)) {
      notes.push_back(
          fmt::format("{} is passive: its angle follows the coupling, and its reading "
                      "(q{}) is not used",
                      link.name, j + 1));
      continue;
    }
    const double play = reading_play(link);
    int out = 0, first = -1;
    double largest = 0;
    for (int r = 0; r < log.rows; ++r) {
      const double q = log.q(r, j);
      if (q < link.lower - play || q > link.upper + play) {
        if (out++ == 0) first = r;
      }
      largest = std::max(largest, std::abs(q));
    }
    if (out == 0) continue;
    const double bound = std::max(std::abs(link.lower), std::abs(link.upper));
    // Most out, in a log hapticcal import wrote: its convention's hint, not a unit's.
    std::string hint = 2 * out > log.rows ? imported_readings_hint(log) : std::string();
    if (hint.empty() && link.prismatic() && largest * 1e-3 <= bound + play) {
      hint = fmt::format("; in millimetres they would fit: name the column q{}[mm]", j + 1);
    } else if (hint.empty() && !link.prismatic() && largest > 2 * M_PI &&
               largest * M_PI / 180 <= bound + play) {
      hint = fmt::format("; in degrees they would fit: name the column q{}[deg]", j + 1);
    }
    const char* unit = link.prismatic() ? "m" : "rad";
    const int line = first < static_cast<int>(log.line.size()) ? log.line[first] : first + 2;
    const std::string message = fmt::format(
        "{} of {} readings are outside {}'s limits [{:.4g}, {:.4g}] {} by more than its play "
        "({:.3g} {}), the first at line {} ({:.4g}; largest |q| {:.4g}){}",
        out, log.rows, link.name, link.lower, link.upper, unit, play, unit, line, log.q(first, j),
        largest, hint);
    if (2 * out > log.rows && !force) {
      throw InputError(log.origin, 0, fmt::format("q{}", j + 1),
                       message + " (--force calibrates anyway)");
    }
    notes.push_back(fmt::format("warning: q{}: {}", j + 1, message));
  }
  check_joint_ranges(log, model, force, notes);
}

// An external encoder's reading beyond any joint's travel (1e308 read for a
// number) would only overflow the step-1 fit: bad input naming its line.
void check_encoder_readings(const Log& log) {
  constexpr double kLargest = 1e4;  // rad or m
  for (int j = 0; j < static_cast<int>(log.has_ext.size()); ++j) {
    if (!log.has_ext[j]) continue;
    for (int r = 0; r < log.rows; ++r) {
      const double v = log.ext(r, j);
      if (std::isfinite(v) && std::abs(v) <= kLargest) continue;
      throw InputError(
          log.origin, r < static_cast<int>(log.line.size()) ? log.line[r] : 0,
          fmt::format("ext{}", j + 1),
          fmt::format("{} is not an encoder reading (|value| above {:g} rad or m)", v, kLargest));
    }
  }
}

}  // namespace detail

namespace {

// The measurement error left once only the slots `free` are fitted (LM): a
// base known only roughly, or a marker's unknown offset from the tip, is no
// sign of a wrong log.
double rms_with_fitted(const ChainStructure& s, Eigen::VectorXd p, const std::vector<int>& free,
                       const std::vector<Eigen::VectorXd>& joints, const RowsOf& kind,
                       const RowMatrix& measured, const Eigen::VectorXd& weights, double rows,
                       bool compressed, Eigen::VectorXd* fitted = nullptr) {
  std::vector<int> constant;
  for (int k = 0; k < s.num_slots(); ++k) {
    if (std::find(free.begin(), free.end(), k) == free.end()) constant.push_back(k);
  }
  ceres::Problem problem;
  problem.AddResidualBlock(measurement_cost(s, joints, kind, measured, weights, compressed),
                           nullptr, p.data());
  problem.SetManifold(p.data(), new ceres::SubsetManifold(s.num_slots(), constant));
  ceres::Solver::Summary summary;
  detail::solve(detail::levenberg_marquardt(50), &problem, &summary);
  if (fitted) *fitted = p;
  return measurement_rms(position_rss(residuals_at(s, p, joints, kind, measured, weights), kind),
                         rows);
}

// What an implausible log's numbers fit once a first-day mistake is undone:
// its lengths in millimetres or micrometres read as metres (a header without
// units). The hint (empty: none fits within `limit`, the frame registered
// afresh and the slots `free` fitted).
std::string likely_mistake(const ChainStructure& s, const Eigen::VectorXd& p,
                           const std::vector<int>& free, const std::vector<Eigen::VectorXd>& joints,
                           const RowsOf& kind, const RowMatrix& measured,
                           const Eigen::VectorXd& weights, double rows, bool compressed,
                           double limit) {
  const int lengths = std::min(traits(kind.type).length_rows, static_cast<int>(measured.cols()));
  // The frame registered afresh in closed form on these numbers (a pose base,
  // measured points), then the slots `free` fitted.
  const auto fits = [&](const RowMatrix& m) {
    Eigen::VectorXd start = p;
    if (s.base_slots() == kPoseSlots && lengths == 3) {
      const ChainConstants<double> c = chain_constants(s, p.data());
      Eigen::Matrix3Xd a(3, static_cast<Eigen::Index>(joints.size())), b(3, a.cols());
      for (Eigen::Index i = 0; i < a.cols(); ++i) {
        a.col(i) =
            detail::pose_tool(s, c, p.data(), joints[static_cast<size_t>(i)].data(), kind.tip).p;
        b.col(i) = m.row(i).head<3>().transpose();
      }
      try {
        const Registration reg = register_points(a, b);
        const Eigen::Vector3d rpy = matrix_rpy(reg.R * c.base.R);
        start.head<3>() = reg.R * c.base.p + reg.t;
        start.segment<3>(3) = rpy;
      } catch (const InputError&) {  // collinear points: LM from the frame as it is
      }
    }
    return rms_with_fitted(s, start, free, joints, kind, m, weights, rows, compressed) <= limit;
  };
  if (!kind.labels && lengths > 0) {
    for (const auto& [factor, unit] : {std::pair{1e-3, "mm"}, std::pair{1e-6, "um"}}) {
      RowMatrix scaled = measured;
      scaled.leftCols(lengths) *= factor;
      if (fits(scaled)) {
        return fmt::format(
            " The measurements fit it in {}: give the unit in the log's header (x[{}], y[{}], "
            "z[{}] or distance[{}]; a bare column is metres).",
            unit, unit, unit, unit, unit);
      }
    }
  }
  return "";
}

}  // namespace

namespace detail {

double nominal_rms_with(const CalibrationRun& run, const std::vector<int>& free,
                        Eigen::VectorXd* fitted) {
  DeviceModel registered = run.step2_nominal;
  registered.base = run.problem.model.base;
  const ChainStructure s = registered.structure();
  return rms_with_fitted(s, registered.kinematic_parameters(), free, run.nominal_joints, run.kind(),
                         run.problem.measured, run.problem.weights, run.fit().rows,
                         run.problem.compressed, fitted);
}

// A nominal error beyond kImplausibleErrorFraction of the reach, even with what
// a measurement set-up normally leaves unknown fitted - the base pose first,
// then the base pose and the tool point (a marker's or reflector's offset; for
// poses the tool's orientation too) - says the log is not from this device: an
// InputError unless forced. The message names the fits it tried.
void check_reach(const ChainStructure& s, const DeviceModel& nominal,
                 const std::vector<Eigen::VectorXd>& joints, const RowsOf& kind,
                 const RowMatrix& measured, const Eigen::VectorXd& weights, double rows,
                 bool compressed, double rms_before, bool force, std::vector<std::string>& notes) {
  const Eigen::VectorXd p = nominal.kinematic_parameters();
  const ChainConstants<double> constants = chain_constants(s, p.data());
  double reach = 0;
  for (const Eigen::VectorXd& q : joints) {
    reach = std::max(
        reach, (pose_tool(s, constants, p.data(), q.data(), kind.tip).p - constants.base.p).norm());
  }
  const double limit = kImplausibleErrorFraction * reach;
  if (!(rms_before > limit)) return;
  std::vector<int> free;
  for (int k = 0; k < s.base_slots(); ++k) free.push_back(k);
  if (s.instrument) free.push_back(s.instrument_slot());
  const double rms_base =
      rms_with_fitted(s, p, free, joints, kind, measured, weights, rows, compressed);
  std::string tried = fmt::format("{:.1f} mm with its base pose{} fitted", rms_base * 1e3,
                                  s.instrument ? " and the instrument's zero" : "");
  double rms_fitted = rms_base;
  if (!(rms_base <= limit)) {
    const int tool_slots = traits(kind.type).rotation ? kPoseSlots : 3;
    for (int t = 0; t < s.tips; ++t) {  // every tip's tool
      for (int k = 0; k < tool_slots; ++k) free.push_back(s.tool_slot() + kPoseSlots * t + k);
    }
    rms_fitted = rms_with_fitted(s, p, free, joints, kind, measured, weights, rows, compressed);
    tried += fmt::format(", {:.1f} mm with its base pose and tool {} fitted", rms_fitted * 1e3,
                         traits(kind.type).rotation ? "pose" : "point");
  }
  if (rms_fitted <= limit) {
    notes.push_back(fmt::format(
        "the nominal model's RMS error is {:.1f} mm, {} (below {:.0f} % of the reach: plausible "
        "for this device)",
        rms_before * 1e3, tried, kImplausibleErrorFraction * 100));
    return;
  }
  const std::string message =
      fmt::format(
          "the nominal model's RMS error, {:.1f} mm ({}), is more than {:.0f} % of the device's "
          "reach ({:.1f} mm): is this log from this device ({})?",
          rms_before * 1e3, tried, kImplausibleErrorFraction * 100, reach * 1e3, nominal.name) +
      likely_mistake(s, p, free, joints, kind, measured, weights, rows, compressed, limit);
  if (!force) throw InputError(message + " (--force calibrates anyway)");
  notes.push_back("warning: " + message);
}

}  // namespace detail

}  // namespace hapticcal
