// A tree in a device file (model_io/device_tree.hpp).
#include "model_io/device_tree.hpp"

#include <fmt/format.h>

#include <cmath>

#include "hapticcal/core/error.hpp"

namespace hapticcal::detail {

// A tree (version 2): each link's `parent` (an earlier link's name, or `base`;
// absent: the link before it) and `tips`, a list of {name, link, pose} (the
// link each tip ends at and its tool), in place of `tool`. Without `tips` no
// link has a parent: the file is a chain.
void read_tree(const YamlReader& r, const YAML::Node& root, const YAML::Node& links,
               DeviceModel& model) {
  const int n = model.dof();
  const YAML::Node tips = root["tips"];
  if (!tips) {
    for (int i = 0; i < n; ++i) {
      if (links[i]["parent"])
        r.fail(links[i]["parent"], fmt::format("links[{}].parent", i),
               "a link's parent belongs to a tree: name its tips (tips)");
    }
    return;
  }
  if (root["tool"]) r.fail(root["tool"], "tool", "a tree's tools are its tips' (tips)");
  if (!tips.IsSequence() || tips.size() < 2 || tips.size() > static_cast<size_t>(kMaxDof))
    r.fail(tips, "tips",
           fmt::format("expected a list of 2 to {} tips (a chain's tool is `tool`)", kMaxDof));
  const auto link_named = [&](const YAML::Node& node, const std::string& key, bool base) {
    const std::string name = r.string(node, key);
    if (base && name == "base") return -1;
    for (int k = 0; k < n; ++k) {
      if (model.links[k].name == name) return k;
    }
    r.fail(node, key, fmt::format("'{}' is not a link{}", printable(name), base ? " or base" : ""));
  };
  model.parents.resize(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    const YAML::Node parent = links[i]["parent"];
    const std::string key = fmt::format("links[{}].parent", i);
    model.parents[i] = parent ? link_named(parent, key, true) : i - 1;
    if (model.parents[i] >= i) r.fail(parent, key, "the parent must be a link before this one");
  }
  for (size_t t = 0; t < tips.size(); ++t) {
    const YAML::Node tip = tips[t];
    const std::string path = fmt::format("tips[{}]", t);
    r.check_keys(tip, path, {"name", "link", "pose"});
    DeviceModel::Branch b;
    b.tip = r.string(r.require(tip, path, "name"), join(path, "name"));
    if (const std::string why = device_name_problem(b.tip); !why.empty() || b.tip.empty())
      r.fail(tip["name"], join(path, "name"), why.empty() ? "empty" : why);
    for (size_t u = 0; u < t; ++u) {
      if (r.string(tips[u]["name"], "") == b.tip)
        r.fail(tip["name"], join(path, "name"), fmt::format("'{}' repeats tips[{}]", b.tip, u));
    }
    b.link = link_named(r.require(tip, path, "link"), join(path, "link"), false);
    r.pose(r.require(tip, path, "pose"), join(path, "pose"), b.tool);
    if (t == 0) {
      model.tip = b.tip;
      model.tip_link = b.link;
      model.tool = b.tool;
    } else {
      model.branches.push_back(b);
    }
  }
  if (const std::string why = tree_problem(model); !why.empty()) r.fail(tips, "tips", why);
}

std::string tips_problem(const DeviceModel& model) {
  if (const std::string why = tree_problem(model); !why.empty()) return "tips: " + why;
  for (int t = 0; t < model.tips() && model.tree(); ++t) {
    if (const std::string why = device_name_problem(model.tip_name(t));
        !why.empty() || model.tip_name(t).empty())
      return fmt::format("tips[{}].name: {}", t, why.empty() ? "empty" : why);
    for (double v : model.tip_tool(t)) {
      if (!std::isfinite(v)) return fmt::format("tips[{}].pose: non-finite value", t);
    }
  }
  return {};
}

std::string parent_yaml(const DeviceModel& model, int i) {
  const int parent = model.parent(i);
  return fmt::format("    parent: {}\n",
                     parent < 0 ? std::string("base") : quoted(model.links[parent].name));
}

std::string tips_yaml(const DeviceModel& model) {
  std::string out = "tips:\n";
  for (int t = 0; t < model.tips(); ++t) {
    const std::array<double, 6>& p = model.tip_tool(t);
    out +=
        fmt::format("  - {{name: {}, link: {}, pose: {{xyz: [{}, {}, {}], rpy: [{}, {}, {}]}}}}\n",
                    quoted(model.tip_name(t)), quoted(model.links[model.tip_link_of(t)].name), p[0],
                    p[1], p[2], p[3], p[4], p[5]);
  }
  return out;
}

}  // namespace hapticcal::detail
