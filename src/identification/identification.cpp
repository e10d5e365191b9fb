// Step 2 of the paper's procedure and the whole calibration.
#include "hapticcal/identification/identification.hpp"

#include <ceres/ceres.h>
#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <map>
#include <numeric>
#include <random>
#include <unordered_map>

#include "hapticcal/identification/registration.hpp"
#include "hapticcal/io/error.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "identification/measurement_cost.hpp"
#include "identification/solver_options.hpp"
#include "identification/stack.hpp"

namespace hapticcal {
namespace detail {

Stack stack(const ChainStructure& s, const Eigen::VectorXd& params,
            const std::vector<Eigen::VectorXd>& joints, const RowsOf& kind,
            const RowMatrix& measured, const Eigen::VectorXd& weights, bool compressed) {
  const int m = static_cast<int>(joints.size());
  if (compressed) {
    detail::CompressedRows z =
        detail::compress_rows(s, params.data(), joints, kind, measured, weights);
    return {Eigen::VectorXd(), std::move(z.R), z.rss(), kind.rows(m)};
  }
  Stack out{Eigen::VectorXd(kind.rows(m)), Eigen::MatrixXd()};
  all_rows(s, params.data(), joints, kind, measured, weights, out.r.data(), &out.J);
  out.rss = out.r.squaredNorm();
  out.residuals = out.r.size();
  return out;
}

Eigen::VectorXd residuals_at(const ChainStructure& s, const Eigen::VectorXd& params,
                             const std::vector<Eigen::VectorXd>& joints, const RowsOf& kind,
                             const RowMatrix& measured, const Eigen::VectorXd& weights) {
  Eigen::VectorXd r(kind.rows(static_cast<int>(joints.size())));
  all_rows(s, params.data(), joints, kind, measured, weights, r.data(), nullptr);
  return r;
}

double position_rss(const Eigen::VectorXd& r, const RowsOf& kind) {
  if (kind.labels) {  // the poses' rows, without the known distances'
    const Eigen::Index pose_rows =
        static_cast<Eigen::Index>(kind.labels->of_pose.size()) * kind.dimension();
    return r.head(pose_rows).squaredNorm();
  }
  if (kind.type != MeasurementType::kPose) return r.squaredNorm();
  double sum = 0;
  for (Eigen::Index i = 0; i < r.size(); ++i) {
    if (i % 6 < 3) sum += r[i] * r[i];
  }
  return sum;
}

}  // namespace detail

namespace {

constexpr std::uint64_t kStructuralSeed = 20130601;  // synthetic poses of the structural analysis
constexpr int kStructuralPoses = 400;
constexpr int kDefaultFolds = 5;
constexpr int kIterations = 100;  // Levenberg-Marquardt's limit
constexpr int kFixtureIterations =
    500;  // for fixture points and planes  // model selection when cross-validation is off

using detail::CompressedMeasurementCost;
using detail::measurement_rows;
using detail::MeasurementCost;
using detail::position_rss;
using detail::residuals_at;
using detail::RowMatrix;
using detail::rows_of;
using detail::RowsOf;
using detail::Stack;
using detail::stack;

// The cost LM minimises over these poses: every row, or its compressed form.
ceres::CostFunction* measurement_cost(const ChainStructure& s,
                                      const std::vector<Eigen::VectorXd>& joints,
                                      const RowsOf& kind, const RowMatrix& measured,
                                      const Eigen::VectorXd& weights, bool compressed) {
  if (compressed) return new CompressedMeasurementCost(s, joints, kind, measured, weights);
  return new MeasurementCost(s, joints, kind, measured, weights);
}

// The used rows of the log as measured values (the family's width a row).
RowMatrix measured_values(const Log& log, const std::vector<int>& rows, const RowsOf& kind) {
  RowMatrix out(rows.size(), traits(kind.type).width);
  for (size_t i = 0; i < rows.size(); ++i) {
    hapticcal::measured_values(kind.type, log, rows[i], out.row(i).data());
  }
  return out;
}

// What the model at `params` predicts for these joint values: measurements
// without error (for the structural analysis, whose rows need a measured value).
RowMatrix predicted_values(const ChainStructure& s, const Eigen::VectorXd& params,
                           const std::vector<Eigen::VectorXd>& joints, const RowsOf& kind) {
  RowMatrix out(joints.size(), traits(kind.type).width);
  if (is_fixture(kind.type)) return RowMatrix::Zero(out.rows(), out.cols());  // nothing measured
  const ChainConstants<double> constants = chain_constants(s, params.data());
  for (size_t i = 0; i < joints.size(); ++i) {
    const Frame<double> tool = forward_kinematics(s, constants, joints[i].data());
    double* row = out.row(i).data();
    if (kind.type == MeasurementType::kDistance) {
      row[0] = tool.p.norm() + (s.instrument ? params[s.instrument_slot()] : 0.0);
      continue;
    }
    for (int k = 0; k < 3; ++k) row[k] = tool.p[k];
    if (kind.type == MeasurementType::kPose) {
      const Eigen::Quaterniond q(tool.R);
      row[3] = q.w();
      row[4] = q.x();
      row[5] = q.y();
      row[6] = q.z();
    }
  }
  return out;
}

// One candidate's fate in the greedy rank test.
struct Verdict {
  enum Kind { kIdentified, kNoEffect, kDependent } kind = kIdentified;
  std::vector<int> on;  // slots it depends on
};

// Greedy rank test in priority order on scale-free (unit) columns: a column
// with no effect, or whose part outside the span of the columns accepted before
// it is below `tolerance` of its norm, is held.
std::map<int, Verdict> rank_test(const Eigen::MatrixXd& J, const std::vector<int>& order,
                                 double tolerance) {
  std::map<int, Verdict> out;
  double largest = 0;
  for (int slot : order) largest = std::max(largest, J.col(slot).norm());
  std::vector<Eigen::VectorXd> basis;
  std::vector<int> accepted;
  for (int slot : order) {
    const double norm = J.col(slot).norm();
    if (!(norm > 1e-10 * largest) || largest == 0) {
      out[slot] = {Verdict::kNoEffect, {}};
      continue;
    }
    Eigen::VectorXd v = J.col(slot) / norm;
    for (int pass = 0; pass < 2; ++pass) {  // Gram-Schmidt twice: orthogonal to rounding
      for (const Eigen::VectorXd& b : basis) v -= b.dot(v) * b;
    }
    const double rest = v.norm();
    if (rest < tolerance) {
      // Which accepted parameters reproduce its effect.
      Eigen::MatrixXd A(J.rows(), accepted.size());
      for (size_t k = 0; k < accepted.size(); ++k) A.col(k) = J.col(accepted[k]).normalized();
      const Eigen::VectorXd x = A.colPivHouseholderQr().solve(J.col(slot) / norm);
      std::vector<std::pair<double, int>> weights;
      for (size_t k = 0; k < accepted.size(); ++k) weights.push_back({std::abs(x[k]), accepted[k]});
      std::sort(weights.rbegin(), weights.rend());
      Verdict verdict{Verdict::kDependent, {}};
      for (size_t k = 0; k < weights.size() && k < 3; ++k) {
        if (weights[k].first > 0.1 * weights[0].first) verdict.on.push_back(weights[k].second);
      }
      out[slot] = verdict;
      continue;
    }
    basis.push_back(v / rest);
    accepted.push_back(slot);
    out[slot] = {Verdict::kIdentified, {}};
  }
  return out;
}

// Greedy holds the last dependent column in order, which may carry a dependency
// only faintly (its unit column is the others' combination with coefficients
// far above 1: those others are then nearly dependent among themselves, badly
// conditioned). Exchanges such a held slot of `exchangeable` with the accepted
// one of the largest coefficient, while one exceeds 2 (a basis exchange on the
// largest pivot, as in maxvol); returns the slots now held in exchange.
std::vector<int> exchange_faint_carriers(const Eigen::MatrixXd& J, const std::vector<int>& order,
                                         const std::function<bool(int)>& exchangeable,
                                         std::map<int, Verdict>& verdict) {
  std::vector<int> out;
  for (int round = 0; round < 8; ++round) {
    bool changed = false;
    for (int held : order) {
      if (verdict.at(held).kind != Verdict::kDependent || !exchangeable(held)) continue;
      std::vector<int> accepted;
      for (int slot : order) {
        if (verdict.at(slot).kind == Verdict::kIdentified) accepted.push_back(slot);
      }
      Eigen::MatrixXd A(J.rows(), static_cast<Eigen::Index>(accepted.size()));
      for (size_t k = 0; k < accepted.size(); ++k) A.col(k) = J.col(accepted[k]).normalized();
      const Eigen::VectorXd x = A.colPivHouseholderQr().solve(J.col(held).normalized());
      if (x.size() == 0) continue;
      // The accepted slots of the largest coefficients (at most 3), largest first.
      std::vector<Eigen::Index> by_size(static_cast<size_t>(x.size()));
      std::iota(by_size.begin(), by_size.end(), 0);
      std::stable_sort(by_size.begin(), by_size.end(), [&](Eigen::Index a, Eigen::Index b) {
        return std::abs(x[a]) > std::abs(x[b]);
      });
      const Eigen::Index k = by_size[0];
      const auto relation = [&](int also, Eigen::Index skip) {
        Verdict v{Verdict::kDependent, {}};
        if (also >= 0) v.on.push_back(also);
        for (Eigen::Index c : by_size) {
          if (c != skip && std::abs(x[c]) > 0.1 * std::abs(x[k]) && v.on.size() < 3)
            v.on.push_back(accepted[static_cast<size_t>(c)]);
        }
        return v;
      };
      if (std::abs(x[k]) <= 2 || !exchangeable(accepted[static_cast<size_t>(k)])) {
        verdict[held] = relation(-1, -1);  // the relation with the accepted set of now
        continue;
      }
      const int swapped = accepted[static_cast<size_t>(k)];
      const Verdict v = relation(held, k);
      verdict[held] = {Verdict::kIdentified, {}};
      verdict[swapped] = v;
      out.erase(std::remove(out.begin(), out.end(), held), out.end());
      out.push_back(swapped);
      changed = true;
    }
    if (!changed) break;
  }
  return out;
}

std::string names_of(const std::vector<int>& slots, const std::map<int, std::string>& name) {
  std::string out;
  for (int s : slots) out += (out.empty() ? "" : ", ") + name.at(s);
  return out;
}

// RMS of the per-measurement error, as `evaluate` reports it: the distance error,
// or the Euclidean norm of the position error.
// `rows` the log rows behind the residuals (their weights' sum of squares).
double measurement_rms(double rss, double rows) { return std::sqrt(rss / std::max(rows, 1.0)); }

}  // namespace

std::vector<int> sample_rows(int rows, int samples, std::uint64_t seed) {
  std::vector<int> all(rows);
  for (int i = 0; i < rows; ++i) all[i] = i;
  if (samples <= 0 || samples >= rows) return all;
  // Partial Fisher-Yates with a bounded draw by rejection: the same rows for a
  // seed on every platform (std::uniform_int_distribution is not specified).
  std::mt19937_64 rng(seed);
  for (int i = 0; i < samples; ++i) {
    const std::uint64_t span = static_cast<std::uint64_t>(rows - i);
    const std::uint64_t limit = UINT64_MAX - UINT64_MAX % span;
    std::uint64_t draw;
    do {
      draw = rng();
    } while (draw >= limit);
    std::swap(all[i], all[i + static_cast<int>(draw % span)]);
  }
  all.resize(samples);
  std::sort(all.begin(), all.end());
  return all;
}

const char* to_string(CalibrationStatus status) {
  switch (status) {
    case CalibrationStatus::kConverged:
      return "converged";
    case CalibrationStatus::kNotConverged:
      return "not converged";
    case CalibrationStatus::kNumericalFailure:
      return "numerical failure";
    case CalibrationStatus::kSuspect:
      return "suspect";
    case CalibrationStatus::kRankDeficient:
      return "rank-deficient";
  }
  return "unknown";
}

std::vector<std::vector<int>> repeated_poses(const Log& log) {
  std::vector<std::vector<int>> groups;
  std::unordered_map<std::string, int> index;
  index.reserve(static_cast<size_t>(log.rows));
  std::string key(sizeof(double) * static_cast<size_t>(log.dof()), '\0');
  for (int r = 0; r < log.rows; ++r) {
    for (int j = 0; j < log.dof(); ++j) {
      const double v = log.q(r, j) + 0.0;  // -0.0 and 0.0 are one reading
      std::memcpy(key.data() + sizeof(double) * j, &v, sizeof(double));
    }
    // A fixture log's rows are one pose only at one label.
    const std::string labelled =
        log.label.empty() ? key : key + '\0' + log.label[static_cast<size_t>(r)];
    const auto [it, added] = index.try_emplace(labelled, static_cast<int>(groups.size()));
    if (added) groups.emplace_back();
    groups[it->second].push_back(r);
  }
  return groups;
}

Log average_repeats(const Log& log, const std::vector<std::vector<int>>& groups) {
  Log out;
  out.origin = log.origin;
  out.rows = static_cast<int>(groups.size());
  out.has_ext = log.has_ext;
  out.has_distance = log.has_distance;
  out.has_position = log.has_position;
  out.has_time = log.has_time;
  out.has_orientation = log.has_orientation;
  out.has_point = log.has_point;
  out.has_plane = log.has_plane;
  out.q.resize(out.rows, log.dof());
  out.ext = Eigen::MatrixXd::Zero(out.rows, log.ext.cols());
  if (log.has_distance) out.distance = Eigen::VectorXd::Zero(out.rows);
  if (log.has_position) out.position = Eigen::MatrixXd::Zero(out.rows, 3);
  if (log.has_time) out.t.resize(out.rows);
  if (log.has_orientation) out.orientation = Eigen::MatrixXd::Zero(out.rows, 4);
  for (int g = 0; g < out.rows; ++g) {
    const std::vector<int>& rows = groups[g];
    const int first = rows.front();
    out.q.row(g) = log.q.row(first);
    if (!log.label.empty()) out.label.push_back(log.label[static_cast<size_t>(first)]);
    out.line.push_back(first < static_cast<int>(log.line.size()) ? log.line[first] : 0);
    if (log.has_time) out.t[g] = log.t[first];
    const double w = 1.0 / static_cast<double>(rows.size());
    for (int r : rows) {
      if (log.ext.cols() > 0) out.ext.row(g) += w * log.ext.row(r);
      if (log.has_distance) out.distance[g] += w * log.distance[r];
      if (log.has_position) out.position.row(g) += w * log.position.row(r);
      if (log.has_orientation) {  // q and -q are one rotation: align with the first
        const double sign = log.orientation.row(r).dot(log.orientation.row(first)) < 0 ? -1 : 1;
        out.orientation.row(g) += sign * w * log.orientation.row(r);
      }
    }
    // The normalised mean of nearby unit quaternions: the chordal L2 mean rotation.
    if (log.has_orientation) out.orientation.row(g).normalize();
  }
  return out;
}

namespace {

// The other joint whose axis link `link`'s twist alpha turns into (or from):
// DH: A_i twists joint i's axis into joint i+1's; MDH: joint i-1's into joint i's.
// None for the last DH link and the first MDH link (the tool or base pose).
std::optional<int> twist_partner(const DeviceModel& model, int link) {
  const Geometry g = model.links[link].geometry;
  if (g == Geometry::kOrigin) return std::nullopt;
  const int partner = g == Geometry::kDh ? link + 1 : link - 1;
  if (partner < 0 || partner >= model.dof()) return std::nullopt;
  return partner;
}

bool is_beta(const DeviceModel& model, const ParameterInfo& p) {
  return p.joint >= 0 && p.joint < model.dof() &&
         model.links[p.joint].geometry != Geometry::kOrigin && p.element == kLinkBeta;
}

// Why a beta is not a candidate.
std::string beta_left_out_reason(const DeviceModel& model, int link) {
  const std::string& name = model.links[link].name;
  const auto partner = twist_partner(model, link);
  if (!partner) {
    return fmt::format("not a candidate: no joint {} {} (free it by name)",
                       model.links[link].geometry == Geometry::kDh ? "after" : "before", name);
  }
  const auto [first, second] = std::minmax(link, *partner);
  return fmt::format(
      "not a candidate: the axes of {} and {} are not within {} deg of parallel (free it by "
      "name)",
      model.links[first].name, model.links[second].name, kParallelAxesDeg);
}

}  // namespace

std::optional<int> parallel_axis_partner(const DeviceModel& model, int link) {
  const auto partner = twist_partner(model, link);
  if (!partner) return std::nullopt;
  if (std::abs(std::sin(model.links[link].alpha)) > std::sin(kParallelAxesDeg * M_PI / 180)) {
    return std::nullopt;
  }
  return partner;
}

std::vector<int> candidate_slots(const DeviceModel& model, const std::vector<std::string>& fix,
                                 const std::vector<std::string>& free) {
  const std::vector<ParameterInfo> info = model.parameter_info();
  std::map<std::string, int> slot_of;
  std::vector<std::string> known;
  for (const ParameterInfo& p : info) {
    slot_of[p.name] = p.slot;
    known.push_back(p.name);
  }
  auto lookup = [&](const std::string& name, const char* option) {
    const auto it = slot_of.find(name);
    if (it == slot_of.end()) {
      throw InputError(fmt::format("{}: '{}' is not a kinematic parameter of model '{}'{}", option,
                                   printable(name), model.name, did_you_mean(name, known)));
    }
    return it->second;
  };
  std::vector<bool> fixed(model.structure().num_slots(), false), freed(fixed.size(), false);
  for (const std::string& name : fix) fixed[lookup(name, "--fix")] = true;
  for (const std::string& name : free) freed[lookup(name, "--free")] = true;
  std::vector<int> order;
  auto take = [&](const ParameterInfo& p) {
    if (fixed[p.slot]) return;
    if (is_beta(model, p) && !freed[p.slot]) {
      if (!parallel_axis_partner(model, p.joint) && model.links[p.joint].beta == 0) return;
    }
    order.push_back(p.slot);
  };
  const int dof = model.dof();
  for (const ParameterInfo& p : info) {
    if (p.joint >= 0 && p.joint < dof) take(p);
  }
  for (const ParameterInfo& p : info) {
    if (p.joint == dof) take(p);
  }
  for (const ParameterInfo& p : info) {
    if (p.joint < 0) take(p);
  }
  for (const ParameterInfo& p : info) {
    if (p.joint > dof) take(p);  // the instrument's: held in favour of the device's
  }
  return order;
}

namespace {

// Readings outside the model's joint limits: an InputError when most of a
// joint's readings are out (a unit missing from the header, or another
// device), unless forced; a warning otherwise.
void check_joint_limits(const Log& log, const DeviceModel& model, bool force,
                        std::vector<std::string>& notes) {
  constexpr double kSlack = 1e-9;  // rad or m: rounding in the log
  for (int j = 0; j < model.dof(); ++j) {
    const Link& link = model.links[j];
    int out = 0;
    double largest = 0;
    for (int r = 0; r < log.rows; ++r) {
      const double q = log.q(r, j);
      if (q < link.lower - kSlack || q > link.upper + kSlack) ++out;
      largest = std::max(largest, std::abs(q));
    }
    if (out == 0) continue;
    const double bound = std::max(std::abs(link.lower), std::abs(link.upper));
    std::string hint;
    if (link.prismatic() && largest * 1e-3 <= bound + kSlack) {
      hint = fmt::format("; in millimetres they would fit: name the column q{}[mm]", j + 1);
    } else if (!link.prismatic() && largest > 2 * M_PI && largest * M_PI / 180 <= bound + kSlack) {
      hint = fmt::format("; in degrees they would fit: name the column q{}[deg]", j + 1);
    }
    const std::string message = fmt::format(
        "{} of {} readings are outside {}'s limits [{:.4g}, {:.4g}] {} (largest |q| {:.4g}){}", out,
        log.rows, link.name, link.lower, link.upper, link.prismatic() ? "m" : "rad", largest, hint);
    if (2 * out > log.rows && !force) {
      throw InputError(log.origin, 0, fmt::format("q{}", j + 1),
                       message + " (--force calibrates anyway)");
    }
    notes.push_back(fmt::format("warning: q{}: {}", j + 1, message));
  }
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

// The measurement error left once only the slots `free` are fitted (LM): a
// base known only roughly, or a marker's unknown offset from the tip, is no
// sign of a wrong log.
double rms_with_fitted(const ChainStructure& s, Eigen::VectorXd p, const std::vector<int>& free,
                       const std::vector<Eigen::VectorXd>& joints, const RowsOf& kind,
                       const RowMatrix& measured, const Eigen::VectorXd& weights, double rows,
                       bool compressed) {
  std::vector<int> constant;
  for (int k = 0; k < s.num_slots(); ++k) {
    if (std::find(free.begin(), free.end(), k) == free.end()) constant.push_back(k);
  }
  ceres::Problem problem;
  problem.AddResidualBlock(measurement_cost(s, joints, kind, measured, weights, compressed),
                           nullptr, p.data());
  problem.SetManifold(p.data(), new ceres::SubsetManifold(s.num_slots(), constant));
  ceres::Solver::Summary summary;
  ceres::Solve(detail::levenberg_marquardt(50), &problem, &summary);
  return measurement_rms(position_rss(residuals_at(s, p, joints, kind, measured, weights), kind),
                         rows);
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
    reach =
        std::max(reach, (forward_kinematics(s, constants, q.data()).p - constants.base.p).norm());
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
    const int tool_slots = kind.type == MeasurementType::kPose ? kPoseSlots : 3;
    for (int k = 0; k < tool_slots; ++k) free.push_back(s.tool_slot() + k);
    rms_fitted = rms_with_fitted(s, p, free, joints, kind, measured, weights, rows, compressed);
    tried += fmt::format(", {:.1f} mm with its base pose and tool {} fitted", rms_fitted * 1e3,
                         kind.type == MeasurementType::kPose ? "pose" : "point");
  }
  if (rms_fitted <= limit) {
    notes.push_back(fmt::format(
        "the nominal model's RMS error is {:.1f} mm, {} (below {:.0f} % of the reach: plausible "
        "for this device)",
        rms_before * 1e3, tried, kImplausibleErrorFraction * 100));
    return;
  }
  const std::string message = fmt::format(
      "the nominal model's RMS error, {:.1f} mm ({}), is more than {:.0f} % of the device's reach "
      "({:.1f} mm): is this log from this device ({})?",
      rms_before * 1e3, tried, kImplausibleErrorFraction * 100, reach * 1e3, nominal.name);
  if (!force) throw InputError(message + " (--force calibrates anyway)");
  notes.push_back("warning: " + message);
}

// An unknown measurement frame (a tracker's, a mocap system's): where the base
// is a free pose and the model's tool points lie far from the measured ones, the
// base is first registered in closed form (register_points: Horn / Kabsch on
// the predicted and measured tool points, weighted by the repeat counts), so
// that Levenberg-Marquardt starts near the solution. Applied when it halves the
// RMS point error and moves the base beyond the large-change bounds; returns
// the note saying so, or nothing.
std::optional<std::string> register_frame(DeviceModel& model,
                                          const std::vector<Eigen::VectorXd>& joints,
                                          const RowsOf& kind, const RowMatrix& measured,
                                          const Eigen::VectorXd& weights,
                                          const std::vector<int>& candidates) {
  if (kind.type == MeasurementType::kDistance || is_fixture(kind.type) ||
      model.base_kind != BaseKind::kPose) {
    return {};  // no measured points to register to
  }
  for (int k = 0; k < kPoseSlots; ++k) {  // every base slot free
    if (std::find(candidates.begin(), candidates.end(), k) == candidates.end()) return {};
  }
  const ChainStructure s = model.structure();
  const Eigen::VectorXd p = model.kinematic_parameters();
  const ChainConstants<double> constants = chain_constants(s, p.data());
  const Eigen::Index m = static_cast<Eigen::Index>(joints.size());
  Eigen::Matrix3Xd a(3, m), b(3, m);
  for (Eigen::Index i = 0; i < m; ++i) {
    a.col(i) = forward_kinematics(s, constants, joints[i].data()).p;
    b.col(i) = measured.row(i).head<3>().transpose();
  }
  const Eigen::VectorXd w =
      weights.size() ? Eigen::VectorXd(weights.cwiseAbs2()) : Eigen::VectorXd();
  Registration reg;
  try {
    reg = register_points(a, b, w);
  } catch (const InputError&) {
    return {};  // collinear tool points: no closed form; LM alone
  }
  const Eigen::VectorXd e2 = (a - b).colwise().squaredNorm().transpose();
  const double before = std::sqrt(w.size() ? e2.dot(w) / w.sum() : e2.mean());
  const Frame<double> B = constants.base;
  const Frame<double> moved{reg.R * B.R, reg.R * B.p + reg.t};
  const double shift = (moved.p - B.p).norm();
  const double turn = Eigen::AngleAxisd(reg.R).angle();
  if (!(reg.rms < 0.5 * before) || (shift <= kLargeChangeLength && turn <= kLargeChangeAngle)) {
    return {};
  }
  const Eigen::Vector3d rpy = matrix_rpy(moved.R);
  model.base = {moved.p[0], moved.p[1], moved.p[2], rpy[0], rpy[1], rpy[2]};
  return fmt::format(
      "the measurement frame was far from the model's base (RMS point error {:.1f} mm): it was "
      "registered in closed form first (Horn/Kabsch point-set alignment: base moved by {:.1f} mm "
      "and {:.2f} deg, RMS {:.2f} mm), then refined by Levenberg-Marquardt",
      before * 1e3, shift * 1e3, turn * 180 / M_PI, reg.rms * 1e3);
}

}  // namespace

double identified_instrument_zero(const KinematicFit& fit) {
  for (const ParameterEstimate& e : fit.parameters) {
    if (e.name == "instrument.zero" && e.identifiable) return e.value;
  }
  return 0;
}

namespace {

// What the identified zero of a distance instrument means for the user.
std::string instrument_zero_note(const ParameterEstimate& zero) {
  return fmt::format(
      "the distances carry an instrument zero (instrument.zero) of {:+.3f} +- {:.3f} mm, fitted "
      "with the device: the encoder's offset, not the device's, so the calibrated model leaves "
      "it out; subtract it from this encoder's readings (--fix instrument.zero assumes none)",
      zero.value * 1e3, zero.sd * 1e3);
}

// How far the measurement frame (base) and the tool point moved: the set-up's
// unknowns, reported, not flagged.
std::string setup_change_note(const DeviceModel& nominal, const DeviceModel& calibrated) {
  const auto frame = [](const std::array<double, 6>& v) {
    return pose_frame(v[0], v[1], v[2], v[3], v[4], v[5]);
  };
  const Frame<double> b0 = frame(nominal.base), b1 = frame(calibrated.base);
  const Frame<double> t0 = frame(nominal.tool), t1 = frame(calibrated.tool);
  return fmt::format(
      "the measurement frame (base) moved {:.1f} mm and {:.2f} deg from the model's, the tool "
      "point {:.1f} mm: the set-up's unknowns (the tracker's frame, the marker's offset), not "
      "changes of the robot",
      (b1.p - b0.p).norm() * 1e3, Eigen::AngleAxisd(b0.R.transpose() * b1.R).angle() * 180 / M_PI,
      (t1.p - t0.p).norm() * 1e3);
}

// RMS scatter of repeated measurements about their pose's mean (`means`, the
// average_repeats of `log` over `poses`; Euclidean for positions), with
// rows - poses degrees of freedom; NaN without repeats.
double repeatability(const Log& log, const std::vector<std::vector<int>>& poses, const Log& means,
                     const RowsOf& kind) {
  if (is_fixture(kind.type)) return std::numeric_limits<double>::quiet_NaN();  // nothing measured
  double sum = 0;
  int dof = 0;
  for (size_t g = 0; g < poses.size(); ++g) {
    dof += static_cast<int>(poses[g].size()) - 1;
    for (int r : poses[g]) {
      sum += kind.type != MeasurementType::kDistance
                 ? (log.position.row(r) - means.position.row(g)).squaredNorm()
                 : std::pow(log.distance[r] - means.distance[g], 2);
    }
  }
  return dof > 0 ? std::sqrt(sum / dof) : std::numeric_limits<double>::quiet_NaN();
}

// The outcome: a numerical failure, then no convergence, then parameters the
// data do not excite; else converged.
void set_status(CalibrationResult& result, const std::vector<int>& identified) {
  const KinematicFit& fit = result.kinematics;
  bool finite = std::isfinite(fit.rms_after) && std::isfinite(fit.rms_before) &&
                result.calibrated.kinematic_parameters().allFinite();
  std::string unexcited, transmissions_failed;
  for (const ParameterEstimate& e : fit.parameters) {
    finite = finite && (!e.identifiable || std::isfinite(e.sd));
    if (e.reason.rfind("not excited", 0) == 0)
      unexcited += (unexcited.empty() ? "" : ", ") + e.name;
  }
  for (const TransmissionFit& t : result.transmissions) {
    finite = finite && t.value.allFinite() && std::isfinite(t.offset) && std::isfinite(t.rms_after);
    if (!t.converged) {
      transmissions_failed +=
          (transmissions_failed.empty() ? "" : ", ") + result.calibrated.links[t.joint].name;
    }
  }
  if (!finite || fit.numerical_failure) {
    result.status = CalibrationStatus::kNumericalFailure;
    result.status_reason = fit.numerical_failure
                               ? "the solver failed: " + fit.termination
                               : "the fit produced non-finite values (a measurement too large "
                                 "for the model, or a degenerate model)";
  } else if (!transmissions_failed.empty()) {
    result.status = CalibrationStatus::kNotConverged;
    result.status_reason =
        "the transmission fit (step 1) did not converge for " + transmissions_failed;
  } else if (!identified.empty() && !fit.converged) {
    result.status = CalibrationStatus::kNotConverged;
    result.status_reason = fmt::format("Levenberg-Marquardt did not converge in {} iterations ({})",
                                       fit.iterations, fit.termination);
  } else if (identified.empty() && fit.model_selection && fit.structurally_identified > 0) {
    result.status = CalibrationStatus::kConverged;
    result.status_reason =
        "model selection: these data support no change from the model (every identifiable "
        "parameter held at nominal)";
  } else if (identified.empty()) {
    result.status = CalibrationStatus::kRankDeficient;
    result.status_reason = "no parameter is identifiable from these measurements";
  } else if (fit.rank_deficient) {
    result.status = CalibrationStatus::kRankDeficient;
    result.status_reason = "these measurements do not excite " + unexcited +
                           " (measure poses that move them, or hold them with --fix to calibrate "
                           "the rest)";
  } else {
    result.status = CalibrationStatus::kConverged;
    result.status_reason = fmt::format("converged in {} iterations", fit.iterations);
  }
}

// The outliers' log lines (the rows of their poses), and a note of how many
// were flagged and whether they were down-weighted.
void name_outliers(RobustFit& robust, const Log& log, const std::vector<std::vector<int>>& poses,
                   std::vector<std::string>& notes) {
  for (OutlierPose& o : robust.outliers) {
    for (int row : poses[static_cast<size_t>(o.pose)]) o.lines.push_back(log.line[row]);
  }
  if (robust.outliers.empty()) return;
  notes.push_back(fmt::format(
      "{} pose{} flagged as outlier{} (residual beyond {:.2f} robust sds of {:.4g} mm, Bonferroni "
      "over the poses): {}",
      robust.outliers.size(), robust.outliers.size() == 1 ? "" : "s",
      robust.outliers.size() == 1 ? "" : "s", robust.threshold, robust.robust_sd * 1e3,
      robust.reweighted ? fmt::format("down-weighted by the {} loss (--loss none: plain least "
                                      "squares)",
                                      to_string(robust.loss))
                        : std::string("not down-weighted") +
                              (robust.note.empty() ? " (--loss none)" : " (" + robust.note + ")")));
}

// --strict: a suspect fit is unusable.
void refuse_suspect(CalibrationResult& result, bool strict) {
  const SuspectFit& suspect = result.kinematics.suspect;
  if (!strict || !suspect.suspect || result.status != CalibrationStatus::kConverged) return;
  result.status = CalibrationStatus::kSuspect;
  result.status_reason = "suspect fit (--strict): " + suspect.reasons.front();
}

}  // namespace

namespace {

// The length scale of the problem's current model and poses.
void set_scales(KinematicProblem& problem) {
  const ChainStructure s = problem.model.structure();
  const Eigen::VectorXd p = problem.model.kinematic_parameters();
  // Metres and radians made comparable: angle columns times a length scale, the
  // RMS distance of the tool point from the base origin; a pose's rotation rows
  // likewise (an orientation error phi counts as L phi at the tool).
  const ChainConstants<double> constants = chain_constants(s, p.data());
  double sum = 0;
  for (const Eigen::VectorXd& jq : problem.joints) {
    sum += (forward_kinematics(s, constants, jq.data()).p - constants.base.p).squaredNorm();
  }
  problem.length_scale =
      std::max(std::sqrt(sum / std::max<double>(problem.joints.size(), 1)), 1e-3);
  problem.rotation_scale = problem.length_scale;
}

}  // namespace

std::vector<TransmissionFit> fit_transmissions(DeviceModel& model, const Log& poses,
                                               const CalibrationOptions& options,
                                               std::vector<std::string>& notes) {
  std::vector<TransmissionFit> fits;
  bool any_ext = false;
  for (int j = 0; j < model.dof(); ++j) any_ext = any_ext || poses.has_ext[j];
  if (!options.transmissions) {
    notes.push_back(
        "--no-transmission: transmissions kept as in the device file (kinematic-only calibration)");
    return fits;
  }
  for (int j = 0; j < model.dof(); ++j) {
    if (!poses.has_ext[j]) continue;
    TransmissionFit tf;
    const bool declared = !model.links[j].transmission.is_none();
    Transmission fitted =
        fit_transmission(model, j, poses.q.col(j), poses.ext.col(j), options.polynomial_order, tf);
    if (!declared) {
      notes.push_back(fmt::format(
          "{} has no transmission in the model: a polynomial of order {} was fitted to ext{}",
          model.links[j].name, tf.value.size(), j + 1));
    }
    if (!tf.converged) {
      notes.push_back(fmt::format("{}: the transmission fit did not converge: {}",
                                  model.links[j].name, tf.message));
    }
    if (auto* c = std::get_if<Capstan>(&fitted.model())) c->offset = tf.offset;
    model.links[j].transmission = fitted;
    fits.push_back(tf);
  }
  if (!any_ext) notes.push_back("no ext<i> columns: step 1 (transmissions) skipped");
  return fits;
}

KinematicProblem kinematic_problem(const DeviceModel& model, const Log& poses,
                                   const std::vector<int>& repeats,
                                   const CalibrationOptions& options) {
  check_log_fits(poses, model);
  KinematicProblem problem;
  problem.model = model;
  problem.type = measurement_type(poses);
  const int m = poses.rows;
  const PreparedModel prepared(model);
  problem.joints.assign(m, Eigen::VectorXd(model.dof()));
  for (int i = 0; i < m; ++i) {
    const Eigen::VectorXd qi = poses.q.row(i).transpose();
    prepared.compensate(qi.data(), problem.joints[i].data());
  }
  std::vector<int> pose_index(m);
  std::iota(pose_index.begin(), pose_index.end(), 0);
  problem.measured = measured_values(poses, pose_index, RowsOf{problem.type});
  if (is_fixture(problem.type)) {
    problem.labels = fixture_labels(problem.type, poses, pose_index, options.point_distances,
                                    options.known_points);
  } else if (!options.point_distances.empty() || !options.known_points.empty()) {
    throw InputError(poses.origin, 0,
                     options.point_distances.empty() ? "--fixture" : "--point-distance",
                     "known distances are between fixture points: the log has no point column");
  }
  problem.rows = m;
  if (!repeats.empty()) {
    problem.rows = std::accumulate(repeats.begin(), repeats.end(), 0);
    // An average of k repeats has 1/k of one reading's variance: its rows weigh
    // sqrt(k) (none when no pose repeats, and then no arithmetic changes).
    if (problem.rows > m) {
      problem.weights.resize(m);
      for (int i = 0; i < m; ++i) problem.weights[i] = std::sqrt(static_cast<double>(repeats[i]));
    }
  }
  const int d = traits(problem.type).dimension;
  // Beyond options.max_jacobian_bytes the Jacobian is never formed (issue 10:
  // 10^6 rows): its R factor carries the same column geometry.
  // (A fixture problem's rows couple the poses of a label: never compressed.)
  problem.compressed = !is_fixture(problem.type) &&
                       static_cast<double>(m) * d * model.structure().num_slots() * sizeof(double) >
                           static_cast<double>(options.max_jacobian_bytes);
  set_scales(problem);
  return problem;
}

bool measurement_frame_unknown(const KinematicProblem& problem, const std::vector<int>& candidates,
                               bool registered) {
  if (problem.type != MeasurementType::kPosition && problem.type != MeasurementType::kPose) {
    return false;
  }
  if (problem.model.base_kind != BaseKind::kPose) return false;
  // A base the model gives (a device file's measured pose, the Meca500's
  // T_base) is the frame, known; none (a URDF's root) or one the log was far
  // from (registered) is not.
  const bool given = std::any_of(problem.model.base.begin(), problem.model.base.end(),
                                 [](double v) { return v != 0; });
  if (given && !registered) return false;
  for (int k = 0; k < kPoseSlots; ++k) {
    if (std::find(candidates.begin(), candidates.end(), k) == candidates.end()) return false;
  }
  return true;
}

bool register_measurement_frame(KinematicProblem& problem, const std::vector<int>& candidates,
                                std::vector<std::string>& notes) {
  auto note = register_frame(problem.model, problem.joints, rows_of(problem), problem.measured,
                             problem.weights, candidates);
  if (!note) return false;
  notes.push_back(*note);
  set_scales(problem);
  return true;
}

namespace {

std::vector<Eigen::VectorXd> consistent_joints(const ChainStructure& s, const Eigen::VectorXd& p,
                                               std::vector<Eigen::VectorXd> joints,
                                               MeasurementType type, const FixtureLabels& labels) {
  constexpr int kSteps = 30;
  const ChainConstants<double> constants = chain_constants(s, p.data());
  const int m = static_cast<int>(joints.size());
  std::vector<Eigen::Vector3d> point(m);
  for (int i = 0; i < m; ++i) point[i] = forward_kinematics(s, constants, joints[i].data()).p;
  // Each label's mean point and (planes) the normal of its best plane.
  std::vector<Eigen::Vector3d> mean(labels.count(), Eigen::Vector3d::Zero());
  std::vector<Eigen::Matrix3d> scatter(labels.count(), Eigen::Matrix3d::Zero());
  std::vector<int> count(labels.count(), 0);
  for (int i = 0; i < m; ++i) {
    mean[labels.of_pose[i]] += point[i];
    ++count[labels.of_pose[i]];
  }
  for (int l = 0; l < labels.count(); ++l) {
    mean[l] /= count[l];
    if (l < static_cast<int>(labels.known_point.size()) && labels.known_point[l])
      mean[l] = *labels.known_point[l];  // a known position: the poses go there
  }
  for (int i = 0; i < m; ++i) {
    const Eigen::Vector3d e = point[i] - mean[labels.of_pose[i]];
    scatter[labels.of_pose[i]] += e * e.transpose();
  }
  std::array<Frame<double>, kMaxDof + 1> frames;
  Jacobian6<double> J;
  for (int i = 0; i < m; ++i) {
    const int l = labels.of_pose[i];
    const Eigen::Vector3d normal =
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter[l]).eigenvectors().col(0);
    for (int step = 0; step < kSteps; ++step) {
      const Frame<double> tool = forward_kinematics(s, constants, joints[i].data(), frames.data());
      Eigen::Vector3d e = mean[l] - tool.p;
      if (type == MeasurementType::kPlane) e = normal * normal.dot(e);
      if (e.norm() < 1e-13) break;
      geometric_jacobian(s, frames.data(), tool, JacobianFrame::kMeasurement, J);
      const Eigen::MatrixXd Jp = J.topRows<3>();
      joints[i] += Jp.transpose() *
                   (Jp * Jp.transpose() + 1e-10 * Eigen::Matrix3d::Identity()).ldlt().solve(e);
    }
  }
  return joints;
}

}  // namespace

IdentifiabilityAnalysis analyze_identifiability(const KinematicProblem& problem,
                                                const std::vector<int>& candidates,
                                                double tolerance) {
  const DeviceModel& model = problem.model;
  const ChainStructure s = model.structure();
  const Eigen::VectorXd p0 = model.kinematic_parameters();
  const RowsOf kind = rows_of(problem);
  // On synthetic poses over the joint limits (structural) and on the data.
  std::mt19937_64 rng(kStructuralSeed);
  std::vector<Eigen::VectorXd> synthetic(kStructuralPoses);
  for (Eigen::VectorXd& qs : synthetic) {
    Eigen::VectorXd reading(model.dof());
    for (int j = 0; j < model.dof(); ++j) {
      reading[j] =
          std::uniform_real_distribution<double>(model.links[j].lower, model.links[j].upper)(rng);
    }
    qs = model.compensate(reading);
  }
  // A fixture's rows change with the residual itself (p_i - m_L turns with the
  // robot): at the data, directions that only turn or stretch the residuals look
  // identifiable, with an information that is the noise's. The rank test runs
  // where the nominal model meets the fixture exactly: each pose moved (damped
  // least squares in the joints) until its tool point is at its label's mean
  // point, or on its label's best plane.
  const std::vector<Eigen::VectorXd> joints =
      kind.labels ? consistent_joints(s, p0, problem.joints, problem.type, problem.labels)
                  : problem.joints;
  const Stack data =
      stack(s, p0, joints, kind, problem.measured, problem.weights, problem.compressed);
  // A fixture problem's synthetic poses are spread over as many labels as the data's.
  FixtureLabels synthetic_labels;
  RowsOf synthetic_kind = kind;
  if (kind.labels) {
    synthetic_labels = problem.labels;
    synthetic_labels.of_pose.resize(synthetic.size());
    for (size_t i = 0; i < synthetic.size(); ++i)
      synthetic_labels.of_pose[i] = static_cast<int>(i) % problem.labels.count();
    synthetic_kind.labels = &synthetic_labels;
  }
  const Stack structural = stack(s, p0, synthetic, synthetic_kind,
                                 predicted_values(s, p0, synthetic, kind), Eigen::VectorXd());
  IdentifiabilityAnalysis out;
  out.scale = Eigen::VectorXd::Ones(s.num_slots());
  std::map<int, std::string> name;
  std::vector<bool> length(static_cast<size_t>(s.num_slots()), false);
  for (const ParameterInfo& pi : model.parameter_info()) {
    name[pi.slot] = pi.name;
    length[static_cast<size_t>(pi.slot)] = pi.unit == ParameterUnit::kLength;
    if (pi.unit == ParameterUnit::kAngle) out.scale[pi.slot] = problem.length_scale;
  }
  // An angle phi enters as L phi (metres at the tool): its column is divided by L.
  auto scaled = [&](const Eigen::MatrixXd& J) {
    return Eigen::MatrixXd(J * out.scale.cwiseInverse().asDiagonal());
  };
  // A fixture's unknown points or planes absorb a rigid motion of the whole
  // robot (the cost does not change: the residuals turn with it). The base pose
  // is that motion: it goes first in the rank test, so that what duplicates it
  // is found dependent on it, and is held. Synthetic poses cannot reach a common
  // point: the data's poses decide alone.
  // A known position pins the fixture: the rank test then decides the base too.
  const bool rigid = kind.labels && problem.labels.known_points() == 0;
  std::vector<int> order = candidates;
  const auto is_base = [&](int slot) { return slot < s.base_slots(); };
  // An unknown measurement frame is likewise the base's: it goes first, and
  // the first joint's origin keeps only what a rigid frame cannot express.
  // Its marker is as unknown: the tool goes next, so that a last joint's twist
  // about its own axis does not carry the marker's offset.
  if (kind.labels || problem.frame_unknown) {
    const auto links = std::stable_partition(order.begin(), order.end(), is_base);
    if (problem.frame_unknown) {
      std::stable_partition(links, order.end(), [&](int slot) { return slot >= s.tool_slot(); });
    }
  }
  // Planes, and points without a known distance, cannot see the robot's size
  // (every length times 1 + e leaves the residuals as they are): the rank test
  // finds one length dependent on the others; its reason says so.
  const bool sizeless =
      kind.labels && (problem.type == MeasurementType::kPlane ||
                      (problem.labels.distances.empty() && problem.labels.known_points() < 2));
  // A slot the rank test holds only because of that: one it accepts once a row
  // that measures the scale (d size = lengths . d params) is added.
  std::map<int, bool> sized;
  if (sizeless) {
    Eigen::MatrixXd with_size = scaled(data.J);
    with_size.conservativeResize(with_size.rows() + 1, Eigen::NoChange);
    with_size.bottomRows(1).setZero();
    for (const ParameterInfo& pi : model.parameter_info()) {
      if (pi.unit == ParameterUnit::kLength) with_size(with_size.rows() - 1, pi.slot) = p0[pi.slot];
    }
    with_size.bottomRows(1) *= with_size.topRows(with_size.rows() - 1).norm() /
                               std::max(with_size.bottomRows(1).norm(), 1e-300);
    for (const auto& [slot, v] : rank_test(with_size, order, tolerance))
      sized[slot] = v.kind == Verdict::kIdentified;
  }
  auto data_verdict = rank_test(scaled(data.J), order, tolerance);
  // The scale is a dependency among lengths; greedy may hold one that carries
  // it faintly (the Panda's flange ball, 0.025 mm off the axis in x: its other lengths
  // were then left with a 23 mm Cramer-Rao sd). Exchanged for the length that
  // carries most of it.
  std::vector<int> size_held;
  // (Points only: plane contacts leave many dependencies among lengths, and
  // exchanging there made their fits crawl.)
  if (sizeless && problem.type == MeasurementType::kPoint) {
    const auto is_length = [&](int slot) {
      return !is_base(slot) && length[static_cast<size_t>(slot)];
    };
    size_held = exchange_faint_carriers(scaled(data.J), order, is_length, data_verdict);
    for (int slot : size_held) sized[slot] = true;
  }
  const auto structural_verdict =
      kind.labels ? data_verdict : rank_test(scaled(structural.J), order, tolerance);
  for (int slot : order) {
    const Verdict& sv = structural_verdict.at(slot);
    const Verdict& dv = data_verdict.at(slot);
    if (rigid && is_base(slot)) {
      out.reason[slot] = fmt::format(
          "no effect on the measurements: the unknown places of the fixture's {} absorb a "
          "rigid motion of the whole robot",
          traits(problem.type).plural);
    } else if (dv.kind == Verdict::kIdentified) {
      out.identified.push_back(slot);
    } else if (sv.kind == Verdict::kNoEffect) {
      out.reason[slot] = "no effect on the measurements";
      if (kind.labels) {
        out.reason[slot] += fmt::format(" (the unknown places of the fixture's {} absorb it)",
                                        traits(problem.type).plural);
      }
    } else if (sv.kind == Verdict::kDependent) {
      out.reason[slot] = "dependent: its effect is that of " + names_of(sv.on, name);
      if (rigid && std::all_of(sv.on.begin(), sv.on.end(), is_base)) {
        out.reason[slot] += " (a rigid motion of the whole robot, which the fixture absorbs)";
      } else if (sizeless && sized[slot]) {
        out.reason[slot] += fmt::format(
            " (with them, a uniform scale of the robot: {} cannot see its size; give a known "
            "distance between points, --point-distance)",
            problem.type == MeasurementType::kPlane ? "plane contacts"
                                                    : "fixture points without a known distance");
      }
    } else if (s.instrument && slot == s.instrument_slot()) {
      // The instrument's, not the device's: these poses leave it at 0 (held),
      // they do not leave the device unidentified - so not a "not excited"
      // reason, which set_status and the too-few-measurements check count.
      out.reason[slot] =
          "held at 0: these poses do not separate the instrument's zero from the "
          "device's parameters";
    } else {
      out.rank_deficient = true;
      out.reason[slot] = dv.kind == Verdict::kNoEffect
                             ? "not excited by these measurements (no effect on them)"
                             : "not excited by these measurements (here its effect is that of " +
                                   names_of(dv.on, name) + ")";
    }
  }
  return out;
}

const char* to_string(SolveTermination termination) {
  switch (termination) {
    case SolveTermination::kConverged:
      return "converged";
    case SolveTermination::kNoConvergence:
      return "no convergence";
    case SolveTermination::kFailure:
      return "failure";
    case SolveTermination::kNothingToSolve:
      return "nothing to solve";
  }
  return "?";
}

KinematicSolution solve_kinematics(const KinematicProblem& problem,
                                   const std::vector<int>& identified, int max_iterations) {
  const ChainStructure s = problem.model.structure();
  KinematicSolution out;
  out.parameters = problem.model.kinematic_parameters();
  if (identified.empty()) {
    out.termination = SolveTermination::kNothingToSolve;
    out.message = "no parameter is identifiable from these measurements";
    return out;
  }
  std::vector<int> constant;
  for (int k = 0; k < s.num_slots(); ++k) {
    if (std::find(identified.begin(), identified.end(), k) == identified.end())
      constant.push_back(k);
  }
  ceres::Problem lm;
  lm.AddResidualBlock(measurement_cost(s, problem.joints, rows_of(problem), problem.measured,
                                       problem.weights, problem.compressed),
                      nullptr, out.parameters.data());
  if (!constant.empty()) {
    lm.SetManifold(out.parameters.data(), new ceres::SubsetManifold(s.num_slots(), constant));
  }
  ceres::Solver::Summary summary;
  ceres::Solve(detail::levenberg_marquardt(max_iterations), &lm, &summary);
  out.termination = summary.termination_type == ceres::CONVERGENCE ? SolveTermination::kConverged
                    : summary.termination_type == ceres::FAILURE   ? SolveTermination::kFailure
                                                                 : SolveTermination::kNoConvergence;
  // Ceres lists iteration 0 (the start) too.
  out.iterations = std::max(static_cast<int>(summary.iterations.size()) - 1, 0);
  out.message = summary.message;
  return out;
}

CalibrationResult calibrate(const DeviceModel& nominal, const Log& log,
                            const CalibrationOptions& options) {
  check_log_fits(log, nominal);
  if (options.samples < 0) throw InputError("--samples must not be negative");
  // The CLI's range, for every caller (Python passed 1.0 and inf: a QR of no columns).
  if (!(options.dependency_tolerance >= 1e-12 && options.dependency_tolerance <= 0.5)) {
    throw InputError(fmt::format("--dependency-tolerance {}: not in [1e-12, 0.5]",
                                 options.dependency_tolerance));
  }
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
  CalibrationResult result;
  check_joint_limits(log, nominal, options.force, result.notes);
  check_encoder_readings(log);
  // Repeats of a pose are averaged: one pose, one row of the fit.
  const std::vector<std::vector<int>> all_poses = repeated_poses(log);
  std::vector<int> repeats;
  for (int g : sample_rows(static_cast<int>(all_poses.size()), options.samples, options.seed)) {
    result.poses.push_back(all_poses[g]);
    result.rows.push_back(all_poses[g].front());
    repeats.push_back(static_cast<int>(all_poses[g].size()));
  }
  const Log poses = average_repeats(log, result.poses);
  const int m = poses.rows;
  KinematicFit& fit = result.kinematics;
  fit.type = measurement_type(log);
  fit.poses = m;
  fit.rows = std::accumulate(repeats.begin(), repeats.end(), 0);
  fit.repeatability = repeatability(log, result.poses, poses, RowsOf{fit.type});
  if (log.has_position && log.has_distance) {
    result.notes.push_back("the log has positions and distances: positions are used");
  }

  // Step 1: transmissions from the external encoders.
  DeviceModel model = nominal;
  result.transmissions = fit_transmissions(model, poses, options, result.notes);
  // A distance instrument's own zero (a cable encoder's offset) is a candidate
  // of step 2, after every parameter of the device. `step2_nominal` is the
  // nominal with it (at zero): step 2's parameter vector.
  // --fix instrument.zero (or options.instrument_zero false): no slot at all.
  // (Other logs have no such parameter: fixing it is refused below as unknown.)
  const bool distances = fit.type == MeasurementType::kDistance && options.instrument_zero;
  std::vector<std::string> fix = options.fix;
  const auto fixed_zero = std::find(fix.begin(), fix.end(), "instrument.zero");
  const bool zero_fixed = distances && fixed_zero != fix.end();
  if (zero_fixed) fix.erase(fixed_zero);
  if (distances && !zero_fixed) model.instrument_zero = 0.0;
  DeviceModel step2_nominal = nominal;
  step2_nominal.instrument_zero = model.instrument_zero;

  // Step 2: kinematic parameters from the compensated readings.
  KinematicProblem problem = kinematic_problem(model, poses, repeats, options);
  const std::vector<int> candidates = candidate_slots(model, fix, options.free);
  const int d = traits(fit.type).dimension;
  // Too few measurements for the parameters the model can identify at all (the
  // structural rank, before these poses' own analysis below).
  // A fixture's points or planes take 3 unknowns each out of its rows (known points none).
  const int nuisance = problem.labels.unknowns();
  const int kind_rows = rows_of(problem).rows(m);
  const auto too_few = [&](std::size_t parameters, const char* what) {
    if (kind_rows - nuisance > static_cast<int>(parameters)) return;
    throw InputError(
        log.origin, 0, "",
        fmt::format("too few measurements: {} pose{} give{} {} residual{}{} for {} {} parameters",
                    m, m == 1 ? "" : "s", m == 1 ? "s" : "", kind_rows - nuisance,
                    kind_rows - nuisance == 1 ? "" : "s",
                    nuisance ? fmt::format(" (less 3 a fixture point or plane)") : std::string(),
                    parameters, what));
  };
  if (m < 2) too_few(candidates.size(), "candidate");
  fit.frame_registered = register_measurement_frame(problem, candidates, result.notes);
  problem.frame_unknown = measurement_frame_unknown(problem, candidates, fit.frame_registered);
  fit.length_scale = problem.length_scale;
  fit.rotation_scale = problem.rotation_scale;
  const ChainStructure s = model.structure();
  const RowsOf kind = rows_of(problem);
  const RowMatrix& measured = problem.measured;
  const Eigen::VectorXd& weights = problem.weights;
  const bool compressed = problem.compressed;
  {
    const PreparedModel prepared_nominal(nominal);
    std::vector<Eigen::VectorXd> nominal_joints(m, Eigen::VectorXd(model.dof()));
    for (int i = 0; i < m; ++i) {
      const Eigen::VectorXd qi = poses.q.row(i).transpose();
      prepared_nominal.compensate(qi.data(), nominal_joints[i].data());
    }
    const Eigen::VectorXd r0 = residuals_at(s, step2_nominal.kinematic_parameters(), nominal_joints,
                                            kind, measured, weights);
    for (Eigen::Index i = 0; i < r0.size(); ++i) {
      if (std::isfinite(r0[i] * r0[i])) continue;
      if (kind.labels || i >= static_cast<Eigen::Index>(m) * d) {  // no measured value to blame
        throw InputError(log.origin, 0, "",
                         "the nominal model's tool point is not finite on some row: a reading is "
                         "too large");
      }
      // The row of the pose with the largest measured value is the culprit.
      auto size = [&](int row) {
        return kind.type == MeasurementType::kDistance ? std::abs(log.distance[row])
                                                       : log.position.row(row).norm();
      };
      const std::vector<int>& rows = result.poses[i / d];
      const int culprit = *std::max_element(rows.begin(), rows.end(),
                                            [&](int a, int b) { return size(a) < size(b); });
      throw InputError(log.origin, log.line[culprit], "",
                       "the nominal model's error on this row is not finite: a value is too large");
    }
    fit.rms_before = measurement_rms(position_rss(r0, kind), fit.rows);
    DeviceModel registered = step2_nominal;  // the nominal in the registered frame, if it was
    registered.base = problem.model.base;
    check_reach(s, registered, nominal_joints, kind, measured, weights, fit.rows, compressed,
                fit.rms_before, options.force, result.notes);
  }

  // Identifiability, then Levenberg-Marquardt over the identified parameters.
  const IdentifiabilityAnalysis analysis =
      analyze_identifiability(problem, candidates, options.dependency_tolerance);
  std::vector<int> identified = analysis.identified;
  std::map<int, std::string> reason = analysis.reason;
  const Eigen::VectorXd& scale = analysis.scale;
  fit.rank_deficient = analysis.rank_deficient;
  too_few(identified.size() +
              std::count_if(reason.begin(), reason.end(),
                            [](const auto& r) { return r.second.rfind("not excited", 0) == 0; }),
          "identifiable");
  fit.structurally_identified = static_cast<int>(identified.size());
  // A fixture problem's cost is flat along motions its unknown points nearly
  // absorb: Levenberg-Marquardt needs more steps (the MUKCa Panda: up to 130).
  const int iterations = is_fixture(problem.type) ? kFixtureIterations : kIterations;
  KinematicSolution solution = solve_kinematics(problem, identified, iterations);
  // Outliers: named, and down-weighted by the robust loss (problem.weights).
  const Eigen::VectorXd plain_weights = problem.weights;
  fit.robust = reweight_outliers(problem, identified, solution, options.loss, options.outlier_alpha,
                                 iterations);
  name_outliers(fit.robust, log, result.poses, result.notes);
  // The residuals and Jacobian at the fit, for selection, cross-validation and statistics.
  Stack data = stack(s, solution.parameters, problem.joints, kind, measured, weights, compressed);
  std::map<int, std::string> name;
  for (const ParameterInfo& pi : model.parameter_info()) name[pi.slot] = pi.name;
  // Model selection: hold what the data do not support, and fit again.
  std::vector<int> held_by_selection;
  const int selection_folds = options.folds >= 2 ? options.folds : kDefaultFolds;
  if (options.keep_all) {
    fit.selection_note = "off (--keep-all)";
  } else if (solution.termination != SolveTermination::kConverged) {
    fit.selection_note = "skipped: the fit of every identifiable parameter did not converge";
  } else if (compressed) {
    fit.selection_note = "skipped: the log is too long for per-pose fits (compressed Jacobian)";
    result.notes.push_back("model selection " + fit.selection_note);
  } else {
    const ModelSelection selection =
        detail::select_model(problem, identified, solution.parameters, data,
                             options.selection_alpha, selection_folds, options.seed);
    fit.model_selection = true;
    fit.selection_folds = std::min(selection_folds, m);
    fit.selection_path = selection.path;
    if (selection.kept.size() < identified.size()) {
      std::vector<int> held;
      for (const auto& [slot, why] : selection.reason) held.push_back(slot);
      const Eigen::VectorXd start = problem.model.kinematic_parameters();
      KinematicSolution refit;
      if (selection.kept.empty()) {
        // The data support no change from the model: it stays as it is.
        refit.parameters = start;
        refit.termination = SolveTermination::kConverged;
        refit.message = "model selection: no parameter changed";
      } else {
        // From the full fit with the held parameters back at their start: a
        // few iterations.
        KinematicProblem warm = problem;
        Eigen::VectorXd from = solution.parameters;
        for (int slot : held) from[slot] = start[slot];
        warm.model.set_kinematic_parameters(from);
        refit = solve_kinematics(warm, selection.kept, iterations);
      }
      if (refit.termination == SolveTermination::kConverged) {
        identified = selection.kept;
        solution = refit;
        held_by_selection = held;
        for (const auto& [slot, why] : selection.reason) reason[slot] = why;
        data = stack(s, solution.parameters, problem.joints, kind, measured, weights);
        result.notes.push_back(fmt::format(
            "model selection held {} of the {} identifiable parameters at nominal (not supported "
            "by these data; --keep-all keeps them): {}",
            held.size(), fit.structurally_identified, names_of(held, name)));
      } else {
        fit.model_selection = false;
        fit.selection_note = "its re-fit did not converge (" + refit.message +
                             "): every identifiable parameter kept";
        result.notes.push_back("model selection: " + fit.selection_note);
      }
    }
  }
  fit.identified = static_cast<int>(identified.size());
  if (options.folds >= 2 && solution.termination == SolveTermination::kConverged) {
    const CrossValidation cv =
        detail::cross_validate(problem, identified, data, options.folds, options.seed);
    fit.cv_rms = cv.rms;
    fit.cv_folds = cv.folds;
    fit.cv_note = cv.note;
  } else if (options.folds >= 2) {
    fit.cv_note = "not computed: the fit did not converge";
  }
  fit.converged = solution.termination == SolveTermination::kConverged;
  fit.numerical_failure = solution.termination == SolveTermination::kFailure;
  fit.iterations = solution.iterations;
  fit.termination = solution.message;
  if (solution.termination == SolveTermination::kNothingToSolve) {
    result.notes.push_back(fit.termination);
  } else if (!fit.converged) {
    result.notes.push_back("step 2 did not converge: " + solution.message);
  }
  // Angles are periodic: a step that went round (a real fit turned a flange's
  // pitch by 11 rad) is the same model with the deviation in (-pi, pi].
  Eigen::VectorXd p = solution.parameters;
  {
    const Eigen::VectorXd start = problem.model.kinematic_parameters();
    for (const ParameterInfo& pi : problem.model.parameter_info()) {
      if (pi.unit != ParameterUnit::kAngle) continue;
      p[pi.slot] = start[pi.slot] + std::remainder(p[pi.slot] - start[pi.slot], 2 * M_PI);
    }
  }
  model = problem.model;
  model.set_kinematic_parameters(p);
  fit.rms_after = measurement_rms(
      position_rss(residuals_at(s, p, problem.joints, kind, measured, weights), kind), fit.rows);
  const std::vector<ParameterInfo> info = model.parameter_info();

  // Uncertainty, conditioning and observability of the identified parameters.
  const int k = static_cast<int>(identified.size());
  Eigen::MatrixXd Ji(data.J.rows(), k), Js(data.J.rows(), k);
  for (int c = 0; c < k; ++c) {
    Ji.col(c) = data.J.col(identified[c]);
    Js.col(c) = Ji.col(c) / scale[identified[c]];
  }
  // Each eliminated fixture point or plane is 3 unknowns the projection took out.
  const Eigen::Index dof_residual = data.residuals - k - problem.labels.unknowns();
  fit.sigma_given = options.sigma.has_value();
  fit.sigma =
      options.sigma
          ? *options.sigma
          : std::sqrt(data.rss / static_cast<double>(std::max<Eigen::Index>(dof_residual, 1)));
  // From the eigen-decomposition of the small normal matrices J^T J: the
  // covariance sigma^2 (J^T J)^-1, and the singular values of the scaled J.
  const Eigen::MatrixXd covariance = parameter_covariance(Ji, fit.sigma);
  const Conditioning scaled_conditioning = conditioning(Js, static_cast<double>(fit.rows) * d);
  fit.condition_number = scaled_conditioning.condition_number;
  fit.observability = scaled_conditioning.observability;
  fit.correlation.resize(k, k);
  for (int a = 0; a < k; ++a) {
    fit.identified_names.push_back(name[identified[a]]);
    for (int b = 0; b < k; ++b) {
      fit.correlation(a, b) = covariance(a, b) / std::sqrt(covariance(a, a) * covariance(b, b));
    }
  }
  for (const ParameterInfo& pi : info) {
    ParameterEstimate e;
    e.name = pi.name;
    e.slot = pi.slot;
    e.unit = pi.unit;
    e.nominal = step2_nominal.kinematic_parameters()[pi.slot];
    e.value = p[pi.slot];
    const auto it = std::find(identified.begin(), identified.end(), pi.slot);
    if (it != identified.end()) {
      const int c = static_cast<int>(it - identified.begin());
      e.identifiable = true;
      e.sd = std::sqrt(covariance(c, c));
      // An unknown frame, a marker's offset and an instrument's zero are the
      // set-up's, not the robot's.
      const bool setup = (problem.frame_unknown && (pi.joint < 0 || pi.joint == model.dof())) ||
                         pi.joint > model.dof();
      e.large_change =
          !setup && std::abs(e.value - e.nominal) >
                        (e.unit == ParameterUnit::kAngle ? kLargeChangeAngle : kLargeChangeLength);
      for (int o = 0; o < k; ++o) {
        if (o == c) continue;
        const double rho = covariance(c, o) / std::sqrt(covariance(c, c) * covariance(o, o));
        if (std::abs(rho) > std::abs(e.max_correlation)) {
          e.max_correlation = rho;
          e.max_correlation_with = name[identified[o]];
        }
      }
    } else if (reason.count(pi.slot)) {
      e.reason = reason.at(pi.slot);
      e.held_by_selection = std::find(held_by_selection.begin(), held_by_selection.end(),
                                      pi.slot) != held_by_selection.end();
    } else if (std::find(options.fix.begin(), options.fix.end(), pi.name) != options.fix.end()) {
      e.reason = "fixed by the user";
    } else {  // a beta that candidate_slots left out
      e.reason = beta_left_out_reason(nominal, pi.joint);
    }
    fit.parameters.push_back(e);
  }
  if (problem.frame_unknown) result.notes.push_back(setup_change_note(nominal, model));
  if (fit.rank_deficient) {
    result.notes.push_back(
        "rank-deficient: these measurements do not excite every parameter the model can "
        "identify; see the parameters marked 'not excited'");
  }
  if (model.instrument_zero) {
    const ParameterEstimate& zero = fit.parameters.back();
    if (zero.identifiable) result.notes.push_back(instrument_zero_note(zero));
    model.instrument_zero.reset();  // the instrument's, not the device's
  }
  result.calibrated = model;
  if (fit.converged) {
    DeviceModel nominal_in_frame = step2_nominal;
    nominal_in_frame.base = problem.model.base;
    fit.suspect = check_suspect(fit, problem, nominal_in_frame, poses, plain_weights);
  }
  set_status(result, identified);
  refuse_suspect(result, options.strict);
  return result;
}

}  // namespace hapticcal
