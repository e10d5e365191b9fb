// Checks of the options and of a log before it is fitted: joint readings within
// the limits, encoder readings that are readings, enough rows for the
// parameters, and a nominal error plausible for this device.
#include <ceres/ceres.h>
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <map>
#include <numeric>
#include <random>
#include <unordered_map>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/option_ranges.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/identification/joint_error_family.hpp"
#include "hapticcal/identification/joint_errors.hpp"
#include "hapticcal/identification/registration.hpp"
#include "hapticcal/identification/tree.hpp"
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
    const int tool_slots = observed_tool_slots(kind.type);
    for (int t = 0; t < s.tips; ++t) {  // every tip's tool
      for (int k = 0; k < tool_slots; ++k) free.push_back(s.tool_slot() + kPoseSlots * t + k);
    }
    rms_fitted = rms_with_fitted(s, p, free, joints, kind, measured, weights, rows, compressed);
    tried += fmt::format(", {:.1f} mm with its base pose and tool {} fitted", rms_fitted * 1e3,
                         observed_tool(kind.type));
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

// The options a caller may get wrong, checked before anything is read (the
// CLI's ranges, for every caller: Python passed 1.0 and inf).
void check_options(const CalibrationOptions& options) {
  if (options.samples < 0) throw InputError("--samples must not be negative");
  check_option("--dependency-tolerance", options.dependency_tolerance,
               option_range::kDependencyTolerance);
  for (const std::string& name : options.fix) {
    if (std::find(options.free.begin(), options.free.end(), name) != options.free.end()) {
      throw InputError(fmt::format("'{}' is given to both --fix and --free", printable(name)));
    }
  }
  if (!(options.selection_alpha > 0 && options.selection_alpha < 1)) {
    throw InputError(
        fmt::format("model selection level {} is not in (0, 1)", options.selection_alpha));
  }
  if (options.folds < 0 || options.folds == 1) {
    throw InputError(fmt::format("--folds {}: K-fold cross-validation needs K = 0 (none) or K >= 2",
                                 options.folds));
  }
  if (options.sigma && !(*options.sigma > 0 && std::isfinite(*options.sigma))) {
    throw InputError("--sigma must be a positive number of metres");
  }
  if (options.encoder_resolution &&
      !(*options.encoder_resolution > 0 && *options.encoder_resolution <= 1)) {
    throw InputError("--encoder-resolution must be a positive number of radians, at most 1");
  }
  for (const std::string& family : options.joint_errors) {
    if (family != "none" && !find_joint_error_family(family)) {
      std::vector<std::string_view> names;
      for (const JointErrorFamily* f : joint_error_families()) names.push_back(f->name());
      throw InputError(fmt::format("--joint-errors: '{}' is not a joint-error family ({}, or none)",
                                   printable(family), fmt::join(names, ", ")));
    }
    if (family == "none" && options.joint_errors.size() > 1) {
      throw InputError("--joint-errors: none names no family and goes alone");
    }
  }
  if (options.keep_all + options.select + options.prior > 1) {
    throw InputError(
        "--keep-all, --select and --prior exclude each other (plain least squares, the "
        "significance cut or the tolerance prior)");
  }
  const Tolerances& t = options.tolerances;
  // A tolerance or scale is positive and within 1e-9..1e3 (m, rad): beyond, the
  // evidence's sums would leave double's range.
  const auto positive = [](double v) { return v >= 1e-9 && v <= 1e3; };
  if (!positive(t.length) || !positive(t.angle)) {
    throw InputError("--tolerance length=... and angle=... must be in [1e-9, 1000] (m, rad)");
  }
  for (const auto& [name, value] : t.by_name) {
    if (!positive(value)) {
      throw InputError(
          fmt::format("--tolerance {}={}: not in [1e-9, 1000] (SI)", printable(name), value));
    }
  }
  for (const auto& [name, value] : t.by_family) {
    if (!find_joint_error_family(name) || !positive(value)) {
      throw InputError(fmt::format(
          "tolerance of the joint-error family {}={}: no such family, or not in [1e-9, 1000] (SI)",
          printable(name), value));
    }
  }
  if (t.scale && !(*t.scale >= 1e-6 && *t.scale <= 1e6)) {
    throw InputError("--prior-scale must be in [1e-6, 1e6]");
  }
}

// Too few measurements for `parameters` (the structural rank before these
// poses' own analysis, or the identifiable ones after it). A fixture's points
// or planes take 3 unknowns each out of its rows (known points none).
void check_enough_rows(const CalibrationRun& run, std::size_t parameters, const char* what) {
  const int m = run.m;
  const int nuisance = run.problem.labels.unknowns();
  const int kind_rows = run.kind().rows(m);
  if (kind_rows - nuisance > static_cast<int>(parameters)) return;
  throw InputError(
      run.log.origin, 0, "",
      fmt::format("too few measurements: {} give{} {} residual{}{} for {} {} parameters",
                  samples_text(m, run.nominal.tips(), "pose"), m == run.nominal.tips() ? "s" : "",
                  kind_rows - nuisance, kind_rows - nuisance == 1 ? "" : "s",
                  nuisance ? fmt::format(" (less 3 a fixture point or plane)") : std::string(),
                  parameters, what));
}

// The nominal model's error on the poses: finite on every row (else the row
// with the largest measured value is named), and plausible for this device
// (check_reach). Sets fit.rms_before.
void check_nominal(CalibrationRun& run) {
  const int m = run.m;
  const int d = traits(run.fit().type).dimension;
  const ChainStructure s = run.model.structure();
  const RowsOf kind = run.kind();
  // step2_nominal: its compensate leaves a fitted compliance to the stages (kind).
  const StepTwoJoints step_two(run.step2_nominal);
  std::vector<Eigen::VectorXd> nominal_joints(m);
  for (int i = 0; i < m; ++i) nominal_joints[i] = step_two.row(run.poses, i);
  const Eigen::VectorXd r0 =
      residuals_at(s, run.step2_nominal.kinematic_parameters(), nominal_joints, kind,
                   run.problem.measured, run.problem.weights);
  run.nominal_joints = nominal_joints;
  for (Eigen::Index i = 0; i < r0.size(); ++i) {
    if (std::isfinite(r0[i] * r0[i])) continue;
    if (kind.labels || i >= static_cast<Eigen::Index>(m) * d) {  // no measured value to blame
      throw InputError(run.log.origin, 0, "",
                       "the nominal model's tool point is not finite on some row: a reading is "
                       "too large");
    }
    // The row of the pose with the largest measured value is the culprit.
    // (The size of its length values: a distance, a position.)
    const MeasurementTraits& t = traits(kind.type);
    std::vector<double> value(t.width);
    auto size = [&](int row) {
      measured_values(kind.type, run.log, row, value.data());
      return Eigen::Map<const Eigen::VectorXd>(value.data(), std::min(t.length_rows, t.width))
          .norm();
    };
    const std::vector<int>& rows = run.result.poses[i / d];
    const int culprit = *std::max_element(rows.begin(), rows.end(),
                                          [&](int a, int b) { return size(a) < size(b); });
    throw InputError(run.log.origin, run.log.line[culprit], "",
                     "the nominal model's error on this row is not finite: a value is too large");
  }
  run.fit().rms_before = measurement_rms(position_rss(r0, kind), run.fit().rows);
  run.fit().tip_rms_before = detail::tip_rms(run.problem, r0, kind, run.problem.weights);
  DeviceModel registered = run.step2_nominal;  // the nominal in the registered frame, if it was
  registered.base = run.problem.model.base;
  check_reach(s, registered, nominal_joints, kind, run.problem.measured, run.problem.weights,
              run.fit().rows, run.problem.compressed, run.fit().rms_before, run.options.force,
              run.result.notes);
}

}  // namespace detail

}  // namespace hapticcal
