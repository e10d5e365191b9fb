// Several tips on one tree (identification/tree.hpp): the tree's parameters
// from its chains', and one fit of every tip's points.
#include "hapticcal/identification/tree.hpp"

#include <ceres/ceres.h>
#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <random>
#include <set>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/identification/registration.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/urdf.hpp"
#include "identification/solver_options.hpp"
#include "identification/stack.hpp"
#include "identification/tree_internal.hpp"

namespace hapticcal {
namespace {

constexpr std::uint64_t kTreeStructuralSeed = 20261203;  // synthetic readings of the rank test
constexpr int kTreeStructuralPoses = 400;

// A tree parameter's name: the chain's, but a tool's carries its tip.
std::string tree_name(const ParameterInfo& p, int dof, const std::string& tip) {
  return p.joint == dof ? tip + "." + p.name : p.name;
}

// Why a chain cannot be part of a tree, or empty.
std::string single_chain_feature(const DeviceModel& m) {
  if (!m.joint_errors.empty()) return "joint-error stages";
  if (m.coupled()) return "a coupling";
  if (m.compliant()) return "joint compliance";
  if (m.laterally_compliant()) return "lateral compliance";
  if (m.has_backlash()) return "backlash";
  if (m.instrument_zero) return "an instrument zero";
  return "";
}

bool same_joint(const Link& a, const Link& b) {
  return a.geometry == b.geometry && a.type == b.type && a.a == b.a && a.alpha == b.alpha &&
         a.d == b.d && a.theta == b.theta && a.beta == b.beta && a.origin == b.origin &&
         a.axis == b.axis && a.offset == b.offset && a.lower == b.lower && a.upper == b.upper;
}

}  // namespace

namespace detail {

TreeStack tree_stack(const DeviceTree& tree, const TreeData& data, const Eigen::VectorXd& values,
                     bool jacobian) {
  TreeStack out;
  Eigen::Index rows = 0;
  for (const auto& j : data.joints) rows += 3 * static_cast<Eigen::Index>(j.size());
  out.r.resize(rows);
  if (jacobian) out.J.setZero(rows, tree.num_slots());
  Eigen::Index at = 0;
  for (size_t c = 0; c < tree.chains.size(); ++c) {
    const Stack st = stack(data.s[c], tree.chain_values(values, static_cast<int>(c)),
                           data.joints[c], tree_rows(), data.measured[c], data.weights[c]);
    out.r.segment(at, st.r.size()) = st.r;
    out.rss.push_back(st.rss);
    if (jacobian) {
      for (Eigen::Index k = 0; k < st.J.cols(); ++k)
        out.J.block(at, tree.slot_of[c][static_cast<size_t>(k)], st.J.rows(), 1) += st.J.col(k);
    }
    at += st.r.size();
  }
  return out;
}

namespace {

// One Ceres cost over the tree's vector: each chain's cost at its part of it.
class TreeCost : public ceres::CostFunction {
 public:
  TreeCost(const DeviceTree& tree, const TreeData& data) : tree_(tree) {
    int rows = 0;
    for (size_t c = 0; c < tree.chains.size(); ++c) {
      costs_.emplace_back(measurement_cost(data.s[c], data.joints[c], tree_rows(), data.measured[c],
                                           data.weights[c], false));
      rows += costs_.back()->num_residuals();
    }
    set_num_residuals(rows);
    mutable_parameter_block_sizes()->push_back(tree.num_slots());
  }
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const Eigen::Map<const Eigen::VectorXd> values(parameters[0], tree_.num_slots());
    using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    std::optional<Eigen::Map<RowMajor>> J;
    if (jacobians && jacobians[0]) {
      J.emplace(jacobians[0], num_residuals(), tree_.num_slots());
      J->setZero();
    }
    int at = 0;
    for (size_t c = 0; c < costs_.size(); ++c) {
      const Eigen::VectorXd v = tree_.chain_values(values, static_cast<int>(c));
      const double* block = v.data();
      const int n = costs_[c]->num_residuals();
      RowMajor Jc(n, v.size());
      double* jc = Jc.data();
      if (!costs_[c]->Evaluate(&block, residuals + at, J ? &jc : nullptr)) return false;
      if (J) {
        for (Eigen::Index k = 0; k < Jc.cols(); ++k)
          J->block(at, tree_.slot_of[c][static_cast<size_t>(k)], n, 1) += Jc.col(k);
      }
      at += n;
    }
    return true;
  }

 private:
  const DeviceTree& tree_;
  std::vector<std::unique_ptr<ceres::CostFunction>> costs_;
};

}  // namespace

ceres::CostFunction* tree_cost(const DeviceTree& tree, const TreeData& data) {
  return new TreeCost(tree, data);
}

// Random tree readings over the joint limits, each chain's joint values.
std::vector<std::vector<Eigen::VectorXd>> tree_synthetic_joints(const DeviceTree& tree) {
  const Eigen::MatrixXd readings =
      tree_random_readings(tree, kTreeStructuralPoses, kTreeStructuralSeed);
  std::vector<std::vector<Eigen::VectorXd>> out(tree.chains.size());
  for (Eigen::Index i = 0; i < readings.rows(); ++i) {
    for (size_t c = 0; c < tree.chains.size(); ++c)
      out[c].push_back(tree.chains[c].compensate(
          tree.chain_reading(readings.row(i).transpose(), static_cast<int>(c))));
  }
  return out;
}

Eigen::VectorXd tree_column_scale(const DeviceTree& tree, double length) {
  Eigen::VectorXd scale = Eigen::VectorXd::Ones(tree.num_slots());
  for (const ParameterInfo& p : tree.parameters)
    if (p.unit == ParameterUnit::kAngle) scale[p.slot] = length;
  return scale;
}

bool tree_base_unset(const DeviceTree& tree) {
  const DeviceModel& first = tree.chains[0];
  return first.base_is_pose() &&
         std::all_of(first.base.begin(), first.base.end(), [](double v) { return v == 0; });
}

}  // namespace detail

Eigen::VectorXd DeviceTree::values() const {
  Eigen::VectorXd out(num_slots());
  for (size_t c = 0; c < chains.size(); ++c) {
    const Eigen::VectorXd v = chains[c].kinematic_parameters();
    for (Eigen::Index k = 0; k < v.size(); ++k) out[slot_of[c][static_cast<size_t>(k)]] = v[k];
  }
  return out;
}

void DeviceTree::set_values(const Eigen::VectorXd& values) {
  for (size_t c = 0; c < chains.size(); ++c)
    chains[c].set_kinematic_parameters(chain_values(values, static_cast<int>(c)));
}

Eigen::VectorXd DeviceTree::chain_values(const Eigen::VectorXd& values, int chain) const {
  const std::vector<int>& map = slot_of[static_cast<size_t>(chain)];
  Eigen::VectorXd out(static_cast<Eigen::Index>(map.size()));
  for (size_t k = 0; k < map.size(); ++k) out[static_cast<Eigen::Index>(k)] = values[map[k]];
  return out;
}

Eigen::VectorXd DeviceTree::chain_reading(const Eigen::VectorXd& reading, int chain) const {
  const std::vector<int>& map = joint_of[static_cast<size_t>(chain)];
  Eigen::VectorXd out(static_cast<Eigen::Index>(map.size()));
  for (size_t k = 0; k < map.size(); ++k) out[static_cast<Eigen::Index>(k)] = reading[map[k]];
  return out;
}

DeviceTree make_tree(std::vector<DeviceModel> chains, const std::vector<std::string>& tips) {
  if (chains.size() < 2 || chains.size() != tips.size())
    throw InputError("a tree needs two tips or more, one chain each");
  DeviceTree tree;
  tree.name = chains[0].name;
  tree.tips = tips;
  std::map<std::string, int> joint_index, slot_index;
  for (size_t c = 0; c < chains.size(); ++c) {
    const DeviceModel& m = chains[c];
    if (std::count(tips.begin(), tips.end(), tips[c]) > 1)
      throw InputError(fmt::format("tip '{}' is named twice", tips[c]));
    if (const std::string f = single_chain_feature(m); !f.empty())
      throw InputError(
          fmt::format("the chain to tip '{}' has {}: not supported on a tree yet", tips[c], f));
    if (m.base_kind != chains[0].base_kind || m.base != chains[0].base)
      throw InputError(
          fmt::format("the chain to tip '{}' does not start from the first's base", tips[c]));
    std::vector<int> joints;
    bool branched = false;
    for (int j = 0; j < m.dof(); ++j) {
      const Link& link = m.links[static_cast<size_t>(j)];
      const auto found = joint_index.find(link.name);
      if (found == joint_index.end()) {
        branched = true;
        joint_index[link.name] = tree.dof();
        tree.joints.push_back(link.name);
        joints.push_back(tree.dof() - 1);
        continue;
      }
      // A shared joint: before any joint of this chain's own, the same joint at
      // the same place of an earlier chain, behind the same joints.
      bool same = false;
      for (size_t k = 0; k < c && !same; ++k) {
        const DeviceModel& other = chains[k];
        same = !branched && j < other.dof() && other.links[j].name == link.name &&
               same_joint(other.links[j], link);
        for (int i = 0; same && i < j; ++i) same = other.links[i].name == m.links[i].name;
      }
      if (!same)
        throw InputError(fmt::format(
            "joint '{}' of the chain to tip '{}' is not the one its other chains share "
            "(another place on the path from the root, another geometry or other limits)",
            link.name, tips[c]));
      joints.push_back(found->second);
    }
    tree.joint_of.push_back(joints);
    std::vector<int> slots;
    for (const ParameterInfo& p : m.parameter_info()) {
      ParameterInfo t = p;
      t.name = tree_name(p, m.dof(), tips[c]);
      const auto [it, added] = slot_index.emplace(t.name, tree.num_slots());
      if (added) {
        t.slot = tree.num_slots();
        t.joint = p.joint < 0          ? -1
                  : p.joint == m.dof() ? -2 - static_cast<int>(c)
                                       : joints[p.joint];
        tree.parameters.push_back(t);
        tree.chains_of.emplace_back();
      }
      tree.chains_of[static_cast<size_t>(it->second)].push_back(static_cast<int>(c));
      slots.push_back(it->second);
    }
    tree.slot_of.push_back(slots);
  }
  tree.chains = std::move(chains);
  return tree;
}

DeviceTree parse_tree(const std::string& text, const std::string& origin,
                      const std::vector<std::string>& tips, const std::string& root) {
  std::vector<DeviceModel> chains;
  for (const std::string& tip : tips) chains.push_back(parse_urdf(text, origin, tip, root));
  DeviceTree tree = make_tree(std::move(chains), tips);
  // A tip below another (or joined to it by fixed joints only) shares the
  // fixed joints that carry the other's tool: calibrated_urdf could not write
  // both tools. Conservative: a tip on a fixed branch of its own beside
  // another's path is refused too.
  for (size_t a = 0; a < tips.size(); ++a) {
    for (size_t b = 0; b < tips.size(); ++b) {
      if (a == b) continue;
      const std::vector<int>& ja = tree.joint_of[a];
      const std::vector<int>& jb = tree.joint_of[b];
      if (ja.size() > jb.size() || !std::equal(ja.begin(), ja.end(), jb.begin())) continue;
      if (ja == jb)
        throw InputError(origin, 0, "--tip",
                         fmt::format("tips '{}' and '{}' are moved by the same joints: measure "
                                     "them as markers of one body (x1, y1, z1, ...) on one tip",
                                     tips[a], tips[b]));
      bool joined = true;
      try {
        parse_urdf(text, origin, tips[b], tips[a]);
      } catch (const InputError&) {
        joined = false;
      }
      if (joined)
        throw InputError(origin, 0, "--tip",
                         fmt::format("tip '{}' lies on the path to tip '{}' (or is joined to it "
                                     "by fixed joints only): give tips on separate branches",
                                     tips[a], tips[b]));
    }
  }
  return tree;
}

DeviceTree load_tree(const std::string& path, const std::vector<std::string>& tips,
                     const std::string& root) {
  return parse_tree(read_file(path, FileKind::kUrdf), path, tips, root);
}

DeviceModel tree_model(const DeviceTree& tree) {
  if (tree.dof() > kMaxDof)
    throw InputError(
        fmt::format("the tree has {} joints: at most {} are supported", tree.dof(), kMaxDof));
  DeviceModel m = tree.chains[0];
  m.links.assign(static_cast<size_t>(tree.dof()), Link{});
  m.parents.assign(static_cast<size_t>(tree.dof()), -1);
  for (size_t c = 0; c < tree.chains.size(); ++c) {
    const std::vector<int>& joints = tree.joint_of[c];
    for (size_t j = 0; j < joints.size(); ++j) {
      m.links[static_cast<size_t>(joints[j])] = tree.chains[c].links[j];
      m.parents[static_cast<size_t>(joints[j])] = j == 0 ? -1 : joints[j - 1];
    }
  }
  m.tip = tree.tips[0];
  m.tip_link = tree.joint_of[0].back();
  m.branches.clear();
  for (size_t c = 1; c < tree.chains.size(); ++c)
    m.branches.push_back({tree.tips[c], tree.joint_of[c].back(), tree.chains[c].tool});
  return m;
}

DeviceModel tip_chain(const DeviceModel& tree, int tip) {
  DeviceModel chain = tree;
  chain.links.clear();
  for (int i : tree.path(tip)) chain.links.push_back(tree.links[static_cast<size_t>(i)]);
  chain.tool = tree.tip_tool(tip);
  chain.parents.clear();
  chain.branches.clear();
  chain.tip.clear();
  chain.tip_link = -1;
  return chain;
}

namespace {

// The names of a URDF text's <link name="..."> (or '...') elements.
std::set<std::string> link_names(const std::string& text) {
  std::set<std::string> out;
  const std::string open = "<link name=";
  for (size_t at = text.find(open); at != std::string::npos; at = text.find(open, at + 1)) {
    const size_t quote = at + open.size();
    if (quote >= text.size() || (text[quote] != '"' && text[quote] != '\'')) continue;
    const size_t to = text.find(text[quote], quote + 1);
    if (to != std::string::npos) out.insert(text.substr(quote + 1, to - quote - 1));
  }
  return out;
}

}  // namespace

std::string tree_urdf(const std::string& text, const std::string& origin, const std::string& root,
                      const DeviceModel& tree, std::vector<std::string>& notes) {
  std::string out = text;
  std::string from = root;
  for (int t = 0; t < tree.tips(); ++t) {
    std::vector<std::string> said;
    out = calibrated_urdf(out, origin, tree.tip_name(t), from, tip_chain(tree, t), &said);
    for (std::string& note : said) {
      // A tree's set has no calibrated.yaml: the calibrated tree is the URDF's.
      const std::string yaml = "reproduces calibrated.yaml";
      if (const size_t at = note.find(yaml); at != std::string::npos)
        note.replace(at, yaml.size(), "gives the calibrated tree");
      if (std::find(notes.begin(), notes.end(), note) == notes.end()) notes.push_back(note);
    }
    if (t == 0) {
      // The measurement frame's link the first chain wrote, if it wrote one
      // (a name of its own: unique_name): the later chains are read from it.
      const std::set<std::string> before = link_names(text);
      for (const std::string& link : link_names(out)) {
        if (link.find("measurement") != std::string::npos && !before.count(link)) from = link;
      }
    }
  }
  return out;
}

Log tip_samples(const DeviceModel& tree, const Log& log) {
  const int k = tree.tips();
  if (log.marker_count != k)
    throw InputError(log.origin, log.line.empty() ? 0 : log.line[0], "x1",
                     fmt::format("the tree has {} tips: give x, y, z of each (x1 ... z{}); the "
                                 "log has {} points a row",
                                 k, k, log.marker_count));
  if (!log.label.empty() || log.has_orientation || log.has_distance || !log.columns.empty())
    throw InputError(log.origin, 0, "x1",
                     "a tree's log gives each tip's point only (no labels, orientations, "
                     "distances or other measurements yet)");
  Log out = log;
  out.rows = log.rows * k;
  out.marker_count = 0;
  out.markers.resize(0, 0);
  out.has_position = true;
  out.position.resize(out.rows, 3);
  out.q.resize(out.rows, log.dof());
  out.ext.resize(out.rows, log.ext.cols());
  out.direction.resize(out.rows, log.direction.cols());
  if (log.has_time) out.t.resize(out.rows);
  out.line.clear();
  out.tip.clear();
  for (int r = 0; r < log.rows; ++r) {
    for (int t = 0; t < k; ++t) {
      const int row = r * k + t;
      out.q.row(row) = log.q.row(r);
      if (log.ext.cols() > 0) out.ext.row(row) = log.ext.row(r);
      if (log.direction.cols() > 0) out.direction.row(row) = log.direction.row(r);
      if (log.has_time) out.t[row] = log.t[r];
      out.position.row(row) = log.markers.row(r).segment<3>(3 * t);
      out.line.push_back(r < static_cast<int>(log.line.size()) ? log.line[r] : 0);
      out.tip.push_back(t);
    }
  }
  return out;
}

Eigen::MatrixXd tree_random_readings(const DeviceTree& tree, int count, std::uint64_t seed) {
  std::vector<std::uniform_real_distribution<double>> joint(static_cast<size_t>(tree.dof()));
  for (size_t c = 0; c < tree.chains.size(); ++c) {
    for (size_t l = 0; l < tree.joint_of[c].size(); ++l) {
      const Link& link = tree.chains[c].links[l];
      joint[static_cast<size_t>(tree.joint_of[c][l])] =
          std::uniform_real_distribution<double>(link.lower, link.upper);
    }
  }
  std::mt19937_64 rng(seed);
  Eigen::MatrixXd out(count, tree.dof());
  for (int i = 0; i < count; ++i) {
    for (int j = 0; j < tree.dof(); ++j) out(i, j) = joint[static_cast<size_t>(j)](rng);
  }
  return out;
}

Log chain_log(const DeviceTree& tree, const Log& log, int chain) {
  const std::vector<int>& joints = tree.joint_of[static_cast<size_t>(chain)];
  Log out;
  out.origin = log.origin;
  out.rows = log.rows;
  out.line = log.line;
  const Eigen::Index n = static_cast<Eigen::Index>(joints.size());
  out.q.resize(log.rows, n);
  out.ext.setZero(log.rows, n);
  out.direction.setZero(log.rows, n);
  out.has_ext.assign(joints.size(), false);
  out.has_direction.assign(joints.size(), false);
  for (size_t k = 0; k < joints.size(); ++k) {
    out.q.col(static_cast<Eigen::Index>(k)) = log.q.col(joints[k]);
    out.q_unit.push_back(log.q_unit[static_cast<size_t>(joints[k])]);
    out.q_column.push_back(log.q_column[static_cast<size_t>(joints[k])]);
    out.ext_unit.push_back(ReadingUnit::kNone);
    out.ext_column.push_back("");
  }
  out.position = log.markers.middleCols(3 * chain, 3);
  out.has_position = true;
  return out;
}

std::vector<double> tree_position_rms(const DeviceTree& tree, const Log& log) {
  check_tree_log(tree, log);
  std::vector<double> out;
  for (size_t c = 0; c < tree.chains.size(); ++c) {
    const DeviceModel& m = tree.chains[c];
    const PreparedModel prepared(m);
    double sum = 0;
    for (int r = 0; r < log.rows; ++r) {
      const Eigen::VectorXd q = tree.chain_reading(log.q.row(r).transpose(), static_cast<int>(c));
      const Eigen::Vector3d p = prepared.forward(q.data()).p;
      sum += (p - log.markers.row(r).segment<3>(3 * static_cast<Eigen::Index>(c)).transpose())
                 .squaredNorm();
    }
    out.push_back(std::sqrt(sum / std::max(log.rows, 1)));
  }
  return out;
}

}  // namespace hapticcal
