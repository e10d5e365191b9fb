// Which parameters these measurements identify: the candidates, the structural
// and the data's rank test.
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

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/identification/registration.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "identification/problem/measurement_cost.hpp"
#include "identification/problem/solver_options.hpp"
#include "identification/problem/stack.hpp"

namespace hapticcal {
namespace {

constexpr std::uint64_t kStructuralSeed = 20130601;  // synthetic poses of the structural analysis
constexpr int kStructuralPoses = 400;

using detail::names_of;
using detail::predicted_values;
using detail::rows_of;
using detail::RowsOf;
using detail::Stack;
using detail::stack;

using Verdict = detail::RankVerdict;

}  // namespace

namespace detail {

std::map<int, RankVerdict> rank_test(const Eigen::MatrixXd& J, const std::vector<int>& order,
                                     double tolerance) {
  std::map<int, Verdict> out;
  double largest = 0;
  for (int slot : order) largest = std::max(largest, J.col(slot).norm());
  // Gram-Schmidt on the unit columns accepted: basis Q and R with unit
  // column k = sum_i R(i, k) Q_i (upper triangular), so that a dependent
  // column's combination of the accepted ones is R^-1 Q^T of it.
  const Eigen::Index rows = J.rows();
  Eigen::MatrixXd basis(rows, static_cast<Eigen::Index>(order.size()));
  Eigen::MatrixXd R = Eigen::MatrixXd::Zero(basis.cols(), basis.cols());
  std::vector<int> accepted;
  for (int slot : order) {
    const double norm = J.col(slot).norm();
    if (!(norm > 1e-10 * largest) || largest == 0) {
      out[slot] = {Verdict::kNoEffect, {}};
      continue;
    }
    const Eigen::Index k = static_cast<Eigen::Index>(accepted.size());
    Eigen::VectorXd v = J.col(slot) / norm;
    Eigen::VectorXd c = Eigen::VectorXd::Zero(k);
    for (int pass = 0; pass < 2; ++pass) {  // Gram-Schmidt twice: orthogonal to rounding
      const Eigen::VectorXd d = basis.leftCols(k).transpose() * v;
      v -= basis.leftCols(k) * d;
      c += d;
    }
    const double rest = v.norm();
    if (rest < tolerance) {
      // Which accepted parameters reproduce its effect.
      const Eigen::VectorXd x = R.topLeftCorner(k, k).triangularView<Eigen::Upper>().solve(c);
      std::vector<std::pair<double, int>> weights;
      for (Eigen::Index a = 0; a < k; ++a) weights.push_back({std::abs(x[a]), accepted[a]});
      std::sort(weights.rbegin(), weights.rend());
      Verdict verdict{Verdict::kDependent, {}};
      for (size_t a = 0; a < weights.size() && a < 3; ++a) {
        if (weights[a].first > 0.1 * weights[0].first) verdict.on.push_back(weights[a].second);
      }
      out[slot] = verdict;
      continue;
    }
    basis.col(k) = v / rest;
    R.col(k).head(k) = c;
    R(k, k) = rest;
    accepted.push_back(slot);
    out[slot] = {Verdict::kIdentified, {}};
  }
  return out;
}

}  // namespace detail

namespace {

using detail::rank_test;

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

// The other joint whose axis link `link`'s twist alpha turns into (or from):
// DH: A_i twists joint i's axis into joint i+1's; MDH: joint i-1's into joint i's.
// None for the last DH link and the first MDH link (the tool or base pose).
std::optional<int> twist_partner(const DeviceModel& model, int link) {
  const int step = traits(model.links[link].geometry).twist_partner;
  if (step == 0) return std::nullopt;
  const int partner = link + step;
  if (partner < 0 || partner >= model.dof()) return std::nullopt;
  return partner;
}

bool is_beta(const DeviceModel& model, const ParameterInfo& p) {
  return p.block == ParameterBlock::kLink && model.links[p.joint].dh_parameters() &&
         p.element == kLinkBeta;
}

}  // namespace

namespace detail {

// Why a beta is not a candidate.
std::string beta_left_out_reason(const DeviceModel& model, int link) {
  const std::string& name = model.links[link].name;
  const auto partner = twist_partner(model, link);
  if (!partner) {
    return fmt::format("not a candidate: no joint {} {} (free it by name)",
                       traits(model.links[link].geometry).partner_word, name);
  }
  const auto [first, second] = std::minmax(link, *partner);
  return fmt::format(
      "not a candidate: the axes of {} and {} are not within {} deg of parallel (free it by "
      "name)",
      model.links[first].name, model.links[second].name, kParallelAxesDeg);
}

}  // namespace detail

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
  // Links, tool, base, then the instrument's (held in favour of the device's)
  // and the joint errors, in slot order.
  using B = ParameterBlock;
  for (const std::vector<B>& blocks :
       {std::vector<B>{B::kLink}, {B::kTool}, {B::kBase}, {B::kInstrument, B::kJointError}}) {
    for (const ParameterInfo& p : info) {
      if (std::find(blocks.begin(), blocks.end(), p.block) != blocks.end()) take(p);
    }
  }
  return order;
}

namespace {

std::vector<Eigen::VectorXd> consistent_joints(const ChainStructure& s, const Eigen::VectorXd& p,
                                               std::vector<Eigen::VectorXd> joints,
                                               const FixtureLabels& labels) {
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
      if (!labels.points) e = normal * normal.dot(e);  // onto the plane
      if (e.norm() < 1e-13) break;
      geometric_jacobian(s, frames.data(), tool, JacobianFrame::kMeasurement, J);
      const Eigen::MatrixXd Jp = J.topRows<3>();
      joints[i].head(s.dof) +=
          Jp.transpose() *
          (Jp * Jp.transpose() + 1e-10 * Eigen::Matrix3d::Identity()).ldlt().solve(e);
    }
  }
  return joints;
}

}  // namespace

namespace {

// What the rank tests found, for record_verdicts: the candidates in the order
// tested, each one's verdict on synthetic poses (structural) and on the data's,
// and the fixture's facts the reasons mention.
struct RankFindings {
  const std::vector<int>& order;
  const std::map<int, Verdict>& structural;
  const std::map<int, Verdict>& data;
  std::map<int, bool>& sized;  // held only because the fixture cannot see the robot's size
  bool rigid = false;          // the fixture absorbs a rigid motion of the whole robot
  bool sizeless = false;       // the fixture cannot see the robot's size
};

// Each candidate identified, or held with its reason.
void record_verdicts(const KinematicProblem& problem, const RankFindings& f,
                     const std::map<int, std::string>& name, IdentifiabilityAnalysis& out) {
  const ChainStructure s = problem.model.structure();
  const bool labels = problem.labelled();
  const bool rigid = f.rigid, sizeless = f.sizeless;
  const auto is_base = [&](int slot) { return slot < s.base_slots(); };
  std::map<int, bool>& sized = f.sized;
  for (int slot : f.order) {
    const Verdict& sv = f.structural.at(slot);
    const Verdict& dv = f.data.at(slot);
    if (rigid && is_base(slot)) {
      out.reason[slot] = fmt::format(
          "no effect on the measurements: the unknown places of the fixture's {} absorb a "
          "rigid motion of the whole robot",
          traits(problem.type).plural);
    } else if (dv.kind == Verdict::kIdentified) {
      out.identified.push_back(slot);
    } else if (sv.kind == Verdict::kNoEffect) {
      out.reason[slot] = "no effect on the measurements";
      if (labels) {
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
            problem.labels.points ? "fixture points without a known distance" : "plane contacts");
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
}

// The rank test's synthetic poses: readings uniform over the joint limits
// (seeded), each joint with a fitted backlash approached from either side,
// formed into step 2's joint values through the model's coupling.
std::vector<Eigen::VectorXd> structural_joints(const DeviceModel& model) {
  std::mt19937_64 rng(kStructuralSeed);
  std::vector<Eigen::VectorXd> synthetic;
  const StepTwoJoints step_two(model);
  for (int pose = 0; pose < kStructuralPoses; ++pose) {
    Eigen::VectorXd reading(model.dof());
    for (int j = 0; j < model.dof(); ++j) {
      reading[j] =
          std::uniform_real_distribution<double>(model.links[j].lower, model.links[j].upper)(rng);
    }
    Eigen::RowVectorXd direction;
    if (const auto* backlash = model.fitted_block("backlash")) {
      direction.setZero(model.dof());
      for (const auto& b : backlash->parameters) direction[b.link] = rng() % 2 ? 1.0 : -1.0;
    }
    for (int tip = 0; tip < model.tips(); ++tip)  // a tree's: each tip at each
      synthetic.push_back(step_two(reading, direction, tip));
  }
  return synthetic;
}

}  // namespace

IdentifiabilityAnalysis analyze_identifiability(const KinematicProblem& problem,
                                                const std::vector<int>& candidates,
                                                double tolerance) {
  const DeviceModel& model = problem.model;
  const ChainStructure s = model.structure();
  const Eigen::VectorXd p0 = model.kinematic_parameters();
  // A held lateral compliance's bends left out: a bend about an URDF origin's
  // x axis would tell apart an rpy and an offset that turn about the joint's
  // axis alike (a gauge the geometry cannot see), and the fit would drift along it.
  RowsOf kind = rows_of(problem);
  kind.bends.reset();
  // On synthetic poses over the joint limits (structural) and on the data.
  const std::vector<Eigen::VectorXd> synthetic = structural_joints(model);
  // A fixture's rows change with the residual itself (p_i - m_L turns with the
  // robot): at the data, directions that only turn or stretch the residuals look
  // identifiable, with an information that is the noise's. The rank test runs
  // where the nominal model meets the fixture exactly: each pose moved (damped
  // least squares in the joints) until its tool point is at its label's mean
  // point, or on its label's best plane.
  std::vector<Eigen::VectorXd> joints =
      kind.labels ? consistent_joints(s, p0, problem.joints, problem.labels) : problem.joints;
  if (kind.labels) {  // the moved poses' features of their joint values
    const StepTwoJoints step_two(model);
    for (Eigen::VectorXd& j : joints) step_two.refresh(j);
  }
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
      std::stable_partition(links, order.end(), [&](int slot) {
        return slot >= s.tool_slot() && slot < s.instrument_slot();  // every tip's tool
      });
    }
  }
  // Planes, and points without a known distance, cannot see the robot's size
  // (every length times 1 + e leaves the residuals as they are): the rank test
  // finds one length dependent on the others; its reason says so.
  const bool sizeless =
      kind.labels && (!problem.labels.points ||
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
  if (sizeless && problem.labels.points) {
    const auto is_length = [&](int slot) {
      return !is_base(slot) && length[static_cast<size_t>(slot)];
    };
    size_held = exchange_faint_carriers(scaled(data.J), order, is_length, data_verdict);
    for (int slot : size_held) sized[slot] = true;
  }
  const auto structural_verdict =
      kind.labels ? data_verdict : rank_test(scaled(structural.J), order, tolerance);
  record_verdicts(problem, {order, structural_verdict, data_verdict, sized, rigid, sizeless}, name,
                  out);
  return out;
}

}  // namespace hapticcal
