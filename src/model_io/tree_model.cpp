// Several tips on one tree (model_io/tree_model.hpp): the tree's parameters
// from its chains', the tree as one model, a tip's chain, and its URDF
// written back.
#include "hapticcal/model_io/tree_model.hpp"

#include <fmt/format.h>

#include <Eigen/Core>
#include <algorithm>
#include <map>
#include <set>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/model_io/urdf.hpp"

namespace hapticcal {

namespace {

// A tree parameter's name: the chain's, but a tool's carries its tip.
std::string tree_name(const ParameterInfo& p, int dof, const std::string& tip) {
  return p.joint == dof ? tip + "." + p.name : p.name;
}

// Why a chain cannot be part of a tree, or empty.
std::string single_chain_feature(const DeviceModel& m) {
  if (!m.joint_errors.empty()) return "joint-error stages";
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
  // Each chain's coupling (a passive joint driven by readings of its path) in
  // the tree's joints; a shared joint's row the same from each of its chains.
  m.coupling.resize(0, 0);
  std::vector<int> row_from(static_cast<size_t>(tree.dof()), -1);  // the chain that set it
  for (size_t c = 0; c < tree.chains.size(); ++c) {
    const DeviceModel& chain = tree.chains[c];
    if (!chain.coupled()) continue;
    if (!m.coupled()) m.coupling = Eigen::MatrixXd::Identity(tree.dof(), tree.dof());
    const std::vector<int>& joints = tree.joint_of[c];
    for (int i = 0; i < chain.dof(); ++i) {
      Eigen::RowVectorXd row = Eigen::RowVectorXd::Zero(tree.dof());
      for (int k = 0; k < chain.dof(); ++k)
        row[joints[static_cast<size_t>(k)]] = chain.coupling(i, k);
      const auto at = static_cast<size_t>(joints[static_cast<size_t>(i)]);
      if (row_from[at] >= 0 && row != m.coupling.row(static_cast<Eigen::Index>(at)))
        throw InputError(fmt::format("the chains to '{}' and '{}' couple joint '{}' differently",
                                     tree.tips[static_cast<size_t>(row_from[at])], tree.tips[c],
                                     tree.joints[at]));
      m.coupling.row(static_cast<Eigen::Index>(at)) = row;
      row_from[at] = static_cast<int>(c);
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
  if (tree.coupled()) {  // the path's rows and readings (a URDF's couplings stay on a path)
    const std::vector<int> path = tree.path(tip);
    const auto n = static_cast<Eigen::Index>(path.size());
    chain.coupling.resize(n, n);
    for (Eigen::Index i = 0; i < n; ++i) {
      for (Eigen::Index k = 0; k < n; ++k)
        chain.coupling(i, k) =
            tree.coupling(path[static_cast<size_t>(i)], path[static_cast<size_t>(k)]);
    }
  }
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

}  // namespace hapticcal
