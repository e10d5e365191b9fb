#include "hapticcal/study/iso9283.hpp"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/measurement.hpp"
#include "hapticcal/identification/registration.hpp"
#include "hapticcal/kinematics/kinematics.hpp"

namespace hapticcal {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// An angle into (-pi, pi].
double wrapped(double angle) {
  const double turned = std::remainder(angle, 2 * std::numbers::pi);
  return turned == -std::numbers::pi ? std::numbers::pi : turned;
}

// The sample standard deviation (n - 1) of values about their mean.
double sample_sd(const std::vector<double>& values, double mean) {
  if (values.size() < 2) return kNaN;
  double sum = 0;
  for (double v : values) sum += (v - mean) * (v - mean);
  return std::sqrt(sum / static_cast<double>(values.size() - 1));
}

double mean_of(const std::vector<double>& values) {
  double sum = 0;
  for (double v : values) sum += v;
  return values.empty() ? kNaN : sum / static_cast<double>(values.size());
}

// P1 < P2 < ... < P10 by number; other labels after them, as strings.
bool pose_order(const std::string& a, const std::string& b) {
  const auto number = [](const std::string& s) {
    const bool numbered =
        s.size() > 1 && s.size() < 9 && s[0] == 'P' &&
        std::all_of(s.begin() + 1, s.end(), [](char c) { return c >= '0' && c <= '9'; });
    return numbered ? std::stoi(s.substr(1)) : -1;
  };
  const int x = number(a), y = number(b);
  if ((x >= 0) != (y >= 0)) return x >= 0;
  return x >= 0 && x != y ? x < y : a < b;
}

const IsoPoseRuns* find_pose(const std::vector<IsoPoseRuns>& poses, const std::string& label) {
  for (const IsoPoseRuns& p : poses)
    if (p.label == label) return &p;
  return nullptr;
}

}  // namespace

IsoPoseCriteria iso_pose_criteria(const IsoPoseRuns& runs) {
  IsoPoseCriteria c;
  c.label = runs.label;
  c.cycles = static_cast<int>(runs.attained.size());
  c.commanded = runs.commanded.p;
  c.orientation = runs.orientation;
  c.mean.setZero();
  for (const Frame<double>& f : runs.attained) c.mean += f.p;
  if (c.cycles == 0) {
    c.mean.setConstant(kNaN);
    c.ap_xyz.setConstant(kNaN);
    c.ap = c.rp = kNaN;
    c.ap_abc.setConstant(kNaN);
    c.rp_abc.setConstant(kNaN);
    return c;
  }
  c.mean /= c.cycles;
  c.ap_xyz = c.mean - c.commanded;
  c.ap = c.ap_xyz.norm();
  std::vector<double> l;
  for (const Frame<double>& f : runs.attained) l.push_back((f.p - c.mean).norm());
  const double l_mean = mean_of(l);
  c.rp = l_mean + 3 * sample_sd(l, l_mean);
  if (!runs.orientation) return c;
  const Eigen::Vector3d commanded = matrix_rpy(runs.commanded.R);
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double> turn;  // a_j - a_c, into (-pi, pi]
    for (const Frame<double>& f : runs.attained)
      turn.push_back(wrapped(matrix_rpy(f.R)[axis] - commanded[axis]));
    const double mean = mean_of(turn);
    c.ap_abc[axis] = mean;
    c.rp_abc[axis] = 3 * sample_sd(turn, mean);
  }
  return c;
}

IsoDistanceCriteria iso_distance_criteria(const IsoPoseRuns& from, const IsoPoseRuns& to) {
  IsoDistanceCriteria d;
  d.from = from.label;
  d.to = to.label;
  d.commanded = (from.commanded.p - to.commanded.p).norm();
  std::vector<double> distances;
  for (size_t i = 0; i < from.cycles.size(); ++i) {
    for (size_t j = 0; j < to.cycles.size(); ++j) {
      if (from.cycles[i] == to.cycles[j])
        distances.push_back((from.attained[i].p - to.attained[j].p).norm());
    }
  }
  d.cycles = static_cast<int>(distances.size());
  d.mean = mean_of(distances);
  d.ad = d.mean - d.commanded;
  d.rd = 3 * sample_sd(distances, d.mean);
  return d;
}

IsoCriteria iso_criteria(const std::vector<IsoPoseRuns>& poses) {
  IsoCriteria out;
  for (const IsoPoseRuns& p : poses) out.poses.push_back(iso_pose_criteria(p));
  const IsoPoseRuns* p2 = find_pose(poses, "P2");
  const IsoPoseRuns* p4 = find_pose(poses, "P4");
  if (p2 && p4) out.distances.push_back(iso_distance_criteria(*p2, *p4));  // the standard's pair
  const IsoPoseRuns* first = find_pose(poses, "P1");
  if (!first && !poses.empty()) first = &poses.front();
  for (const IsoPoseRuns& p : poses) {
    if (&p != first) out.distances.push_back(iso_distance_criteria(*first, p));
  }
  return out;
}

std::vector<IsoPoseRuns> iso_runs(const DeviceModel& model, const Log& log,
                                  const std::vector<std::string>& labels) {
  if (!holds(log, MeasurementType::kPosition))
    throw InputError(log.origin, 0, "--iso9283", "the log has no measured x, y, z to score");
  if (static_cast<int>(labels.size()) != log.rows) {
    throw InputError(log.origin, 0, "--iso9283",
                     fmt::format("{} rows, but the test plan has {}: the log must follow the "
                                 "plan row by row",
                                 log.rows, labels.size()));
  }
  const bool posed = holds(log, MeasurementType::kPose);
  std::vector<std::string> names = labels;
  std::sort(names.begin(), names.end(), pose_order);
  names.erase(std::unique(names.begin(), names.end()), names.end());
  const PreparedModel prepared(model);
  std::vector<IsoPoseRuns> out;
  for (const std::string& name : names) {
    IsoPoseRuns runs;
    runs.label = name;
    runs.orientation = posed;
    Eigen::VectorXd mean = Eigen::VectorXd::Zero(log.dof());
    int cycle = 0;
    for (int r = 0; r < log.rows; ++r) {
      if (labels[static_cast<size_t>(r)] != name) continue;
      mean += log.q.row(r).transpose();
      runs.cycles.push_back(++cycle);
      Frame<double> attained = Frame<double>::Identity();
      attained.p = log.position.row(r).transpose();
      if (posed) {
        const Eigen::Quaterniond q(log.orientation(r, 0), log.orientation(r, 1),
                                   log.orientation(r, 2), log.orientation(r, 3));
        attained.R = q.normalized().toRotationMatrix();
      }
      runs.attained.push_back(attained);
    }
    mean /= cycle;
    runs.commanded = prepared.forward(mean.data());
    out.push_back(std::move(runs));
  }
  return out;
}

void check_iso_labels(const Log& plan, const Log& log) {
  constexpr size_t kPoses = std::size(kIsoCycleOrder);
  const auto line_of = [](const Log& l, size_t r) {
    return r < l.line.size() ? l.line[r] : static_cast<int>(r) + 2;
  };
  for (size_t r = 0; r < plan.label.size(); ++r) {
    const std::string& label = plan.label[r];
    const char* expected = kIsoCycleOrder[r % kPoses];
    if (label == expected) continue;
    throw InputError(
        plan.origin, line_of(plan, r), "point",
        fmt::format("'{}' where a test plan has {} (cycle {}, its pose {} of {}): each cycle "
                    "visits the poses in the order {}",
                    printable(label, 40), expected, r / kPoses + 1, r % kPoses + 1, kPoses,
                    fmt::join(kIsoCycleOrder, ", ")));
  }
  if (plan.label.size() % kPoses != 0) {
    const size_t r = plan.label.size() - 1;
    throw InputError(plan.origin, line_of(plan, r), "point",
                     fmt::format("the plan ends inside cycle {} ({} of its {} poses): every cycle "
                                 "visits each pose once",
                                 r / kPoses + 1, r % kPoses + 1, kPoses));
  }
  for (size_t r = 0; r < log.label.size() && r < plan.label.size(); ++r) {
    if (log.label[r] == plan.label[r]) continue;
    throw InputError(
        log.origin, line_of(log, r), "point",
        fmt::format("'{}' where the plan ({} line {}) has {}", printable(log.label[r], 40),
                    plan.origin, line_of(plan, r), plan.label[r]));
  }
}

void check_iso_positions(const DeviceModel& model, const Log& log,
                         const std::vector<IsoPoseRuns>& runs) {
  const Eigen::Vector3d base = base_frame(model.structure(), model.kinematic_parameters().data()).p;
  double reach = 0, sum = 0;
  int n = 0;
  for (const IsoPoseRuns& run : runs) {
    reach = std::max(reach, (run.commanded.p - base).norm());
    for (const Frame<double>& a : run.attained) sum += (a.p - run.commanded.p).squaredNorm(), ++n;
  }
  const double limit = kImplausibleErrorFraction * reach, rms = std::sqrt(sum / std::max(n, 1));
  if (!(rms > limit)) return;
  // What the positions fit best, scaled and in a frame of their own (the poses'
  // means registered): a fit within a tenth of the poses' spread about their
  // centre names its cause (a cube is small beside the reach: any cloud shrunk
  // a thousandfold lies within the reach's 5 % of it).
  Eigen::Matrix3Xd a(3, static_cast<Eigen::Index>(runs.size())), b(3, a.cols());
  for (Eigen::Index k = 0; k < a.cols(); ++k) {
    const IsoPoseRuns& run = runs[static_cast<size_t>(k)];
    a.col(k) = run.commanded.p;
    b.col(k) = Eigen::Vector3d::Zero();
    for (const Frame<double>& f : run.attained) b.col(k) += f.p / run.attained.size();
  }
  const double spread = std::sqrt((a.colwise() - a.rowwise().mean()).squaredNorm() / a.cols());
  const auto registered_rms = [&](double scale) {
    try {
      return register_points(a, scale * b).rms;
    } catch (const InputError&) {  // fewer than three poses, or collinear
      return std::numeric_limits<double>::infinity();
    }
  };
  std::string hint = " Is this log from this device and this test?";
  double best = 0.1 * spread;
  for (const auto& [scale, unit] :
       {std::pair{1.0, ""}, std::pair{1e-3, "mm"}, std::pair{1e-6, "um"}}) {
    const double rms_scaled = registered_rms(scale);
    if (!(rms_scaled <= best)) continue;
    best = rms_scaled;
    hint = scale == 1.0
               ? std::string(" They fit its poses in another frame: give --register frame.")
               : fmt::format(
                     " The positions fit it in {0}: give the unit in the log's "
                     "header (x[{0}], y[{0}], z[{0}]; a bare column is metres).",
                     unit);
  }
  throw InputError(log.origin, 0, "x",
                   fmt::format("the attained positions are {:.4g} mm RMS from the model's "
                               "commanded poses, more than {:.0f} % of its reach ({:.1f} mm).{}",
                               rms * 1e3, kImplausibleErrorFraction * 100, reach * 1e3, hint));
}

}  // namespace hapticcal
