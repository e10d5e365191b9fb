// Several tips on one tree (identification/tree.hpp): the tree's parameters
// from its chains', the tree as one model, its URDF written back and its
// logs as one sample a tip.
#include "hapticcal/identification/tree.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <stdexcept>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/identification/measurement.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/model_source.hpp"
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

std::vector<std::string> tip_names(const std::string& tip) {
  std::vector<std::string> out;
  if (tip.empty()) return out;
  size_t from = 0;
  for (size_t comma = tip.find(','); comma != std::string::npos; comma = tip.find(',', from)) {
    out.push_back(tip.substr(from, comma - from));
    from = comma + 1;
  }
  out.push_back(tip.substr(from));
  for (const std::string& name : out) {
    if (name.empty()) throw InputError("--tip: an empty tip name in '" + tip + "'");
  }
  return out;
}

DeviceModel load_model_or_tree(const std::string& path, const std::string& tip,
                               const std::string& root, const std::string* urdf_text) {
  if (const std::vector<std::string> tips = tip_names(tip); tips.size() > 1)
    return load_model_or_tree(path, tips, root, urdf_text);
  return urdf_text ? parse_urdf(*urdf_text, path, tip, root) : load_model(path, tip, root);
}

DeviceModel load_model_or_tree(const std::string& path, const std::vector<std::string>& tips,
                               const std::string& root, const std::string* urdf_text) {
  if (tips.size() <= 1)
    return load_model_or_tree(path, tips.empty() ? std::string() : tips[0], root, urdf_text);
  return tree_model(urdf_text ? parse_tree(*urdf_text, path, tips, root)
                              : load_tree(path, tips, root));
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

namespace {

// A tree fixture log's row labels (point1 .. pointK, joined by ',' as the log
// reader keeps them), one a tip; InputError naming the row for another count.
std::vector<std::string> row_labels(const Log& log, int r, int tips) {
  std::vector<std::string> out;
  const std::string& joined = log.label[static_cast<size_t>(r)];
  size_t from = 0;
  for (size_t comma = joined.find(','); comma != std::string::npos;
       comma = joined.find(',', from)) {
    out.push_back(joined.substr(from, comma - from));
    from = comma + 1;
  }
  out.push_back(joined.substr(from));
  if (static_cast<int>(out.size()) != tips) {
    const char* label = traits(measurement_type(log)).name;  // "point" or "plane"
    throw InputError(log.origin, r < static_cast<int>(log.line.size()) ? log.line[r] : 0,
                     fmt::format("{}1", label),
                     fmt::format("the tree has {} tips: a fixture log names a label a tip "
                                 "({}1 .. {}{}); this row has {}",
                                 tips, label, label, tips, out.size()));
  }
  return out;
}

}  // namespace

Log tip_samples(const DeviceModel& tree, const Log& log, std::optional<int> only) {
  const int k = tree.tips();
  if (only && (*only < 0 || *only >= k))
    throw std::out_of_range("tip_samples: tip " + std::to_string(*only));
  const bool fixture = holds_fixture(log);
  // Markers a tip: 1, a point; 3 or more, a rigid body on each tip (the same
  // layout on every one), x1 .. x<M> the first tip's, x<M+1> .. the second's.
  const int per_tip = fixture ? 0 : log.marker_count / k;
  if (!fixture && (log.marker_count % k != 0 || per_tip == 0 || per_tip == 2)) {
    std::vector<std::string> names;
    for (int t = 0; t < k; ++t) names.push_back(tree.tip_name(t));
    throw InputError(
        log.origin, 0, "header",
        fmt::format("{} tips ({}) need the points x1, y1, z1 .. x{}, y{}, z{}; the log has {}", k,
                    fmt::join(names, ", "), k, k, k,
                    log.marker_count ? fmt::format("{} point{}", log.marker_count,
                                                   log.marker_count > 1 ? "s" : "")
                                     : std::string("none")) +
            fmt::format(" (a rigid body of M >= 3 markers on each tip: x1 .. x{}M)", k));
  }
  // Nothing measured but the markers, or but the labels.
  if (kinds_in(log).size() > (fixture ? 1u : 0u) || (fixture && log.marker_count > 0))
    throw InputError(log.origin, 0, "x1",
                     "a tree's log gives each tip's point, or each tip's fixture label, only (no "
                     "orientations, distances or other measurements yet)");
  Log out = log;
  const int per_row = only ? 1 : k;
  out.rows = log.rows * per_row;
  out.marker_count = per_tip > 1 ? per_tip : 0;
  out.markers.resize(per_tip > 1 ? out.rows : 0, 3 * out.marker_count);
  MeasuredValues points(per_tip == 1 ? out.rows : 0, 3);  // a marker a tip: its positions
  out.q.resize(out.rows, log.dof());
  out.ext.resize(out.rows, log.ext.cols());
  out.direction.resize(out.rows, log.direction.cols());
  if (log.has_time) out.t.resize(out.rows);
  out.line.clear();
  out.tip.clear();
  out.label.clear();
  for (int r = 0; r < log.rows; ++r) {
    const std::vector<std::string> labels =
        fixture ? row_labels(log, r, k) : std::vector<std::string>();
    for (int t = only.value_or(0); t < (only ? *only + 1 : k); ++t) {
      const int row = only ? r : r * k + t;
      out.q.row(row) = log.q.row(r);
      if (log.ext.cols() > 0) out.ext.row(row) = log.ext.row(r);
      if (log.direction.cols() > 0) out.direction.row(row) = log.direction.row(r);
      if (log.has_time) out.t[row] = log.t[r];
      if (fixture) {
        out.label.push_back(labels[static_cast<size_t>(t)]);
      } else if (per_tip == 1) {
        points.row(row) = log.markers.row(r).segment<3>(3 * t);
      } else {
        out.markers.row(row) = log.markers.row(r).segment(3 * per_tip * t, 3 * per_tip);
      }
      out.line.push_back(r < static_cast<int>(log.line.size()) ? log.line[r] : 0);
      out.tip.push_back(t);
    }
  }
  if (per_tip == 1) kind_of(MeasurementType::kPosition).to_log(points, out);
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
  kind_of(MeasurementType::kPosition).to_log(log.markers.middleCols(3 * chain, 3), out);
  return out;
}

std::string samples_text(int samples, int tips, const char* noun) {
  const int rows = tips > 1 ? samples / tips : samples;
  const std::string counted = fmt::format("{} {}{}", rows, noun, rows == 1 ? "" : "s");
  return tips > 1 ? fmt::format("{} of {} tips, {} points", counted, tips, samples) : counted;
}

}  // namespace hapticcal
