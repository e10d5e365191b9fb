// URDF models: the chain root -> tip read into a device model.
// urdfdom reads and checks the document; urdf_shape.cpp checks the text before
// it and locates the elements in it, for line numbers and for the origins
// exactly as written.
#include <console_bridge/console.h>
#include <fmt/format.h>
#include <urdf_parser/urdf_parser.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <map>
#include <mutex>
#include <numbers>
#include <optional>
#include <set>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/model/frame.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/model_io/urdf.hpp"
#include "model_io/urdf_internal.hpp"

namespace hapticcal::detail {
namespace {

// ---------------------------------------------------------------------------
// Reading with urdfdom.

// urdfdom reports through console_bridge: keep its first error for the message
// and keep everything off the terminal.
class CapturedLog : public console_bridge::OutputHandler {
 public:
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_ERROR && first_error.empty()) {
      first_error = text;
    }
  }
  std::string first_error;
};

// A loop of joints (a link its own ancestor): urdfdom accepts one below the
// root and then leaks the links of the loop (shared_ptr cycles), which a
// controller that loads models repeatedly would feel. Refused before it reads.
void check_no_joint_loop(const Document& doc, const std::string& origin) {
  std::map<std::string, std::string> parent_of, joint_of;  // child link -> parent link, joint
  for (const auto& [name, index] : doc.joints) {
    const XmlElement& joint = doc.elements[index];
    const XmlElement* parent = doc.child(joint, "parent");
    const XmlElement* child = doc.child(joint, "child");
    const XmlAttribute* p = parent ? parent->attribute("link") : nullptr;
    const XmlAttribute* c = child ? child->attribute("link") : nullptr;
    if (!p || !c) continue;
    const auto [at, added] = parent_of.emplace(c->value, p->value);
    if (!added) {  // a second way up: a loop (or two trees joined), never a tree
      throw InputError(origin, doc.link_line(c->value),
                       fmt::format("link '{}'", printable(c->value, 80)),
                       fmt::format("is the child of two joints, '{}' and '{}': the joints form a "
                                   "loop, not a tree",
                                   printable(joint_of[c->value], 80), printable(name, 80)));
    }
    joint_of[c->value] = name;
  }
  std::map<std::string, int> state;  // 1: on the current walk, 2: leads to a root
  for (const auto& [start, unused] : parent_of) {
    std::vector<std::string> walk;
    std::string link = start;
    while (state[link] == 0) {
      state[link] = 1;
      walk.push_back(link);
      const auto up = parent_of.find(link);
      if (up == parent_of.end()) break;
      link = up->second;
      if (state[link] == 1) {
        throw InputError(origin, doc.link_line(link), fmt::format("link '{}'", printable(link, 80)),
                         "is its own ancestor: the joints above it form a loop, not a tree");
      }
    }
    for (const std::string& l : walk) state[l] = 2;
  }
}

// urdfdom's model of a well-formed document. Its messages name a joint or link
// in brackets ("Joint [j2] is of type REVOLUTE but ..."): that element's line.
urdf::ModelInterfaceSharedPtr parse_with_urdfdom(const std::string& text, const std::string& origin,
                                                 const Document& doc) {
  // The output handler is global: one parse at a time.
  static std::mutex mutex;
  const std::lock_guard<std::mutex> lock(mutex);
  check_no_joint_loop(doc, origin);
  CapturedLog log;
  console_bridge::useOutputHandler(&log);
  urdf::ModelInterfaceSharedPtr model;
  std::string thrown;
  try {
    model = urdf::parseURDF(text);
  } catch (const std::exception& e) {
    thrown = e.what();
  }
  console_bridge::restorePreviousOutputHandler();
  if (model) return model;
  const std::string why = !thrown.empty()            ? thrown
                          : !log.first_error.empty() ? log.first_error
                                                     : "not a valid URDF";
  int line = 0;
  const size_t open = why.find('['), close = why.find(']', open + 1);
  if (open != std::string::npos && close != std::string::npos) {
    const std::string name = why.substr(open + 1, close - open - 1);
    line = doc.joint_line(name) > 0 ? doc.joint_line(name) : doc.link_line(name);
  }
  throw InputError(origin, line, "", "URDF: " + printable(why, 200));
}

// ---------------------------------------------------------------------------
// Frames and numbers.

// Roll, pitch, yaw of R = Rz(yaw) Ry(pitch) Rx(roll). Unlike matrix_rpy this
// stays exact near pitch = +-pi/2 (where roll and yaw turn about nearly the same
// axis): yaw first, then pitch and roll from Rz(yaw)^T R = Ry(pitch) Rx(roll).
Eigen::Vector3d rpy_of(const Eigen::Matrix3d& R) {
  const double yaw = std::atan2(R(1, 0), R(0, 0));
  const Eigen::Matrix3d M = rot_z(std::cos(yaw), std::sin(yaw)).transpose() * R;
  const double pitch = std::atan2(-M(2, 0), M(0, 0));
  const double roll = std::atan2(-M(1, 2), M(1, 1));
  return {roll, pitch, yaw};
}

}  // namespace

// x, y, z, roll, pitch, yaw of a frame (a negative zero written as 0).
std::array<double, 6> pose_of(const Frame<double>& f) {
  const Eigen::Vector3d rpy = rpy_of(f.R);
  return {f.p[0] + 0.0, f.p[1] + 0.0, f.p[2] + 0.0, rpy[0] + 0.0, rpy[1] + 0.0, rpy[2] + 0.0};
}

namespace {

// Three numbers separated by blanks, as urdfdom reads xyz and rpy.
std::optional<std::array<double, 3>> three_numbers(const std::string& text) {
  std::array<double, 3> out{};
  size_t count = 0, i = 0;
  while (i < text.size()) {
    while (i < text.size() && is_blank(text[i])) ++i;
    if (i >= text.size()) break;
    size_t k = i;
    while (k < text.size() && !is_blank(text[k])) ++k;
    if (count == 3) return std::nullopt;
    double v = 0;
    const auto [end, ec] = std::from_chars(text.data() + i, text.data() + k, v);
    if (ec != std::errc() || end != text.data() + k || !std::isfinite(v)) return std::nullopt;
    out[count++] = v;
    i = k;
  }
  if (count != 3) return std::nullopt;
  return out;
}

// ---------------------------------------------------------------------------
// The chain root -> tip.

// The joint's origin as written in the text (exact), else as urdfdom holds it.
std::array<double, 6> joint_origin(const urdf::Joint& joint, const Document& doc) {
  const urdf::Pose& pose = joint.parent_to_joint_origin_transform;
  const Eigen::Quaterniond q(pose.rotation.w, pose.rotation.x, pose.rotation.y, pose.rotation.z);
  const Frame<double> held{q.normalized().toRotationMatrix(),
                           Eigen::Vector3d(pose.position.x, pose.position.y, pose.position.z)};
  if (const XmlElement* e = doc.joint(joint.name)) {
    std::array<double, 6> exact{};
    bool read = true;
    if (const XmlElement* o = doc.child(*e, "origin")) {
      for (const auto& [key, at] : {std::pair{"xyz", 0}, std::pair{"rpy", 3}}) {
        const XmlAttribute* attr = o->attribute(key);
        if (!attr) continue;
        const auto v = three_numbers(attr->value);
        read = read && v.has_value();
        if (v) std::copy(v->begin(), v->end(), exact.begin() + at);
      }
    }
    // Taken only if it is the transform urdfdom read (as it should be).
    const Frame<double> f = pose_frame(exact);
    if (read && (f.R - held.R).cwiseAbs().maxCoeff() < 1e-9 &&
        (f.p - held.p).cwiseAbs().maxCoeff() < 1e-9) {
      return exact;
    }
  }
  return pose_of(held);
}

// The leaf links below `link`, depth first (without recursion: a URDF may be deep).
std::vector<std::string> leaves_below(const urdf::Link& link) {
  std::vector<std::string> out;
  std::vector<const urdf::Link*> open{&link};
  std::set<const urdf::Link*> seen;  // urdfdom accepts a loop of joints below the root
  while (!open.empty()) {
    const urdf::Link* l = open.back();
    open.pop_back();
    if (!seen.insert(l).second) continue;
    if (l->child_links.empty()) out.push_back(l->name);
    for (auto it = l->child_links.rbegin(); it != l->child_links.rend(); ++it) {
      open.push_back(it->get());
    }
  }
  return out;
}

std::string name_list(const std::vector<std::string>& names) {
  std::string out;
  for (size_t k = 0; k < names.size() && k < 8; ++k) {
    out += (k ? ", " : "") + printable(names[k], 40);
  }
  if (names.size() > 8) out += fmt::format(", ... ({} in all)", names.size());
  return out;
}

// The links from `link` up to the tree's root, `link` first. InputError on a
// loop of joints (urdfdom accepts one below the root).
std::vector<urdf::LinkConstSharedPtr> ancestry(const urdf::ModelInterface& urdf,
                                               urdf::LinkConstSharedPtr link,
                                               const std::string& origin, const Document& doc,
                                               const char* key) {
  std::vector<urdf::LinkConstSharedPtr> out;
  std::set<std::string> passed;
  while (link) {
    if (!passed.insert(link->name).second) {
      throw InputError(origin, doc.link_line(link->name), key,
                       fmt::format("link '{}' is its own ancestor: the joints above it form a "
                                   "loop, not a tree",
                                   printable(link->name, 80)));
    }
    out.push_back(link);
    if (!link->parent_joint) break;
    link = urdf.getLink(link->parent_joint->parent_link_name);
    if (!link) throw InputError(origin, 0, "", "URDF: broken tree");  // urdfdom checks this
  }
  return out;
}

// The joints from root to tip, urdfdom's. A root that is not above the tip may
// be joined to the tip's branch by fixed joints only (the measurement frame of
// a calibrated URDF hangs below the robot's root): those joints, from the root
// upwards, go to `up`.
std::vector<urdf::JointConstSharedPtr> chain_joints(const urdf::ModelInterface& urdf,
                                                    const std::string& origin, UrdfChain& chain,
                                                    std::vector<urdf::JointConstSharedPtr>& up) {
  urdf::LinkConstSharedPtr root = chain.root.empty() ? urdf.getRoot() : urdf.getLink(chain.root);
  if (!root) {
    throw InputError(origin, 0, "root",
                     fmt::format("link '{}' is not in the URDF", printable(chain.root, 80)));
  }
  chain.root = root->name;
  if (chain.tip.empty()) {
    const std::vector<std::string> leaves = leaves_below(*root);
    if (leaves.size() != 1) {
      throw InputError(origin, 0, "tip",
                       fmt::format("give the tip link: the tree below '{}' has {} leaf links ({})",
                                   printable(root->name, 80), leaves.size(), name_list(leaves)));
    }
    chain.tip = leaves[0];
  }
  urdf::LinkConstSharedPtr tip = urdf.getLink(chain.tip);
  if (!tip) {
    throw InputError(origin, 0, "tip",
                     fmt::format("link '{}' is not in the URDF", printable(chain.tip, 80)));
  }
  const std::vector<urdf::LinkConstSharedPtr> above_tip =
      ancestry(urdf, tip, origin, chain.doc, "tip");
  const std::vector<urdf::LinkConstSharedPtr> above_root =
      ancestry(urdf, root, origin, chain.doc, "root");
  // The first link above the root (itself included) that is above the tip too.
  size_t meet = 0;
  auto on_tip_branch = [&](const urdf::LinkConstSharedPtr& l) {
    return std::find(above_tip.begin(), above_tip.end(), l) != above_tip.end();
  };
  while (meet < above_root.size() && !on_tip_branch(above_root[meet])) ++meet;
  const bool moving_up = meet > 0 && meet < above_root.size() &&
                         std::all_of(above_root.begin(), above_root.begin() + meet, [](auto& l) {
                           return l->parent_joint->type == urdf::Joint::FIXED;
                         });
  if (meet == above_root.size() || (meet > 0 && !moving_up)) {
    throw InputError(origin, chain.doc.link_line(chain.tip), "tip",
                     fmt::format("link '{}' is not below the root link '{}'{}",
                                 printable(chain.tip, 80), printable(root->name, 80),
                                 meet > 0 && meet < above_root.size()
                                     ? " (a root beside the chain must be joined to it by fixed "
                                       "joints only)"
                                     : ""));
  }
  up.clear();
  for (size_t k = 0; k < meet; ++k) up.push_back(above_root[k]->parent_joint);
  std::vector<urdf::JointConstSharedPtr> joints;
  for (auto link = above_tip.begin(); *link != above_root[meet]; ++link) {
    joints.push_back((*link)->parent_joint);
  }
  std::reverse(joints.begin(), joints.end());
  return joints;
}

// Throws the first problem check_device finds, naming the joint or the robot.
void check_chain_model(const UrdfChain& chain, const std::string& origin) {
  const std::string why = check_device(chain.model);
  if (why.empty()) return;
  int index = -1;
  if (why.starts_with("links[")) {
    const size_t close = why.find(']');
    const std::string digits = why.substr(6, close - 6);
    std::from_chars(digits.data(), digits.data() + digits.size(), index);
  }
  if (index >= 0 && index < chain.model.dof()) {
    const std::string& name = chain.model.links[index].name;
    std::string rest = why.substr(why.find(']') + 1);
    if (rest.starts_with(".")) rest.erase(0, 1);
    if (rest.starts_with(": ")) rest.erase(0, 2);
    throw InputError(origin, chain.doc.joint_line(name), joint_key(name), rest);
  }
  const int line = chain.doc.robot >= 0 ? chain.doc.elements[chain.doc.robot].line : 0;
  if (why.starts_with("name: ")) throw InputError(origin, line, "robot name", why.substr(6));
  throw InputError(origin, line, "", why);
}

// The <inertial> mass of joint j's child link, at its centre (in the child's
// frame, which is `in_link` in the frame of the chain's last movable joint),
// lumped into that joint's link (joint compliance's gravity torques): links
// before the first movable joint carry nothing the joints feel.
void add_inertial(const urdf::ModelInterface& urdf, const urdf::Joint& j,
                  const Frame<double>& in_link, const std::string& origin, int line,
                  DeviceModel& model) {
  const urdf::LinkConstSharedPtr child = urdf.getLink(j.child_link_name);
  if (!child || !child->inertial || model.links.empty()) return;
  const double m = child->inertial->mass;
  const urdf::Vector3& c = child->inertial->origin.position;
  if (!std::isfinite(m) || m < 0 || m > kMaxLinkMass || !std::isfinite(c.x) ||
      !std::isfinite(c.y) || !std::isfinite(c.z)) {
    throw InputError(origin, line, fmt::format("link '{}'", printable(child->name, 80)),
                     fmt::format("<inertial>: a mass in [0, {}] kg and a finite origin are needed",
                                 kMaxLinkMass));
  }
  if (m == 0) return;
  Link& link = model.links.back();
  const Eigen::Vector3d at = in_link.R * Eigen::Vector3d(c.x, c.y, c.z) + in_link.p;
  const double total = link.mass + m;
  link.com = (link.mass * link.com + m * at) / total;
  link.mass = total;
}

}  // namespace

UrdfChain read_chain(const std::string& text, const std::string& origin, const std::string& tip,
                     const std::string& root) {
  check_xml(text, origin);
  UrdfChain chain;
  chain.doc = locate(text, origin);
  check_coupling_elements(chain.doc, origin);
  const urdf::ModelInterfaceSharedPtr urdf = parse_with_urdfdom(text, origin, chain.doc);
  chain.root = root;
  chain.tip = tip;
  std::vector<urdf::JointConstSharedPtr> up;
  const std::vector<urdf::JointConstSharedPtr> joints = chain_joints(*urdf, origin, chain, up);

  const auto movable = std::count_if(joints.begin(), joints.end(), [](const auto& j) {
    return j->type == urdf::Joint::REVOLUTE || j->type == urdf::Joint::CONTINUOUS ||
           j->type == urdf::Joint::PRISMATIC;
  });
  if (movable == 0) {
    throw InputError(origin, 0, "tip",
                     fmt::format("no movable joint between '{}' and '{}'",
                                 printable(chain.root, 80), printable(chain.tip, 80)));
  }
  if (movable > kMaxDof) {
    throw InputError(
        origin, 0, "tip",
        fmt::format("the chain '{}' -> '{}' has {} movable joints: at most {}",
                    printable(chain.root, 80), printable(chain.tip, 80), movable, kMaxDof));
  }

  DeviceModel& model = chain.model;
  model.name = urdf->getName();
  model.base_kind = BaseKind::kPose;
  Frame<double> base = Frame<double>::Identity();
  for (const auto& j : up) {
    const Frame<double> o = pose_frame(joint_origin(*j, chain.doc));
    chain.up_origins.push_back(o);
    chain.up_elements.push_back(chain.doc.joint_index(j->name));
    base = base * o.inverse();
  }
  if (!up.empty()) model.base = pose_of(base);
  Frame<double> fold = Frame<double>::Identity();
  bool folding = false;
  std::vector<Frame<double>> fixed_origins;
  std::vector<int> fixed_elements;
  std::vector<ChainMimic> mimics;
  std::vector<ChainCoupling> couplings;
  for (const auto& j : joints) {
    const int line = chain.doc.joint_line(j->name);
    const std::array<double, 6> o = joint_origin(*j, chain.doc);
    if (j->type == urdf::Joint::FIXED) {
      if (const auto terms = coupling_terms(chain.doc, j->name); !terms.empty()) {
        throw InputError(
            origin, terms.front()->line, joint_key(j->name),
            fmt::format("<{}> on a fixed joint, which has no value to drive", kCouplingElement));
      }
      fold = fold * pose_frame(o);
      add_inertial(*urdf, *j, fold, origin, line, model);
      folding = true;
      fixed_origins.push_back(pose_frame(o));
      fixed_elements.push_back(chain.doc.joint_index(j->name));
      continue;
    }
    if (j->type == urdf::Joint::FLOATING || j->type == urdf::Joint::PLANAR ||
        j->type == urdf::Joint::UNKNOWN) {
      const char* type = j->type == urdf::Joint::FLOATING ? "floating"
                         : j->type == urdf::Joint::PLANAR ? "planar"
                                                          : "unknown";
      throw InputError(origin, line, joint_key(j->name),
                       fmt::format("a {} joint cannot be in the chain '{}' -> '{}' (only "
                                   "revolute, continuous, prismatic and fixed joints)",
                                   type, printable(chain.root, 80), printable(chain.tip, 80)));
    }
    if (j->mimic) mimics.push_back({model.dof(), line, j->name, *j->mimic});
    if (auto terms = coupling_terms(chain.doc, j->name); !terms.empty()) {
      if (j->mimic) {
        throw InputError(
            origin, terms.front()->line, joint_key(j->name),
            fmt::format("both <mimic> and <{}>: give its readings one way", kCouplingElement));
      }
      couplings.push_back({model.dof(), j->name, std::move(terms)});
    }
    Link link;
    link.name = j->name;
    link.geometry = Geometry::kOrigin;
    link.type = j->type == urdf::Joint::REVOLUTE     ? JointType::kRevolute
                : j->type == urdf::Joint::CONTINUOUS ? JointType::kContinuous
                                                     : JointType::kPrismatic;
    link.origin = folding ? pose_of(fold * pose_frame(o)) : o;
    link.axis = Eigen::Vector3d(j->axis.x, j->axis.y, j->axis.z);
    if (!link.axis.allFinite() || !(link.axis.norm() > 0)) {
      throw InputError(origin, line, joint_key(j->name), "axis: zero or not finite");
    }
    link.axis = unit_axis(link.axis);
    if (link.continuous()) {
      link.lower = -std::numbers::pi;
      link.upper = std::numbers::pi;
    } else if (j->limits) {
      link.lower = j->limits->lower;
      link.upper = j->limits->upper;
    }
    model.links.push_back(std::move(link));
    add_inertial(*urdf, *j, Frame<double>::Identity(), origin, line, model);
    if (chain.folded.empty())  // the fixed joints from the root to the first movable one
      std::tie(chain.root_origins, chain.root_elements) = std::tie(fixed_origins, fixed_elements);
    chain.folded.push_back(fold);
    chain.joint_elements.push_back(chain.doc.joint_index(j->name));
    fold = Frame<double>::Identity();
    folding = false;
    fixed_origins.clear();
    fixed_elements.clear();
  }
  if (folding) model.tool = pose_of(fold);
  refuse_mimics_of_coupled(mimics, couplings, origin);
  couple_mimics(mimics, origin, model);
  couple_readings(couplings, origin, model);
  read_ranges(chain.doc, origin, model);
  read_effects(chain.doc, origin, model);
  chain.tool_origins = std::move(fixed_origins);
  chain.tool_elements = std::move(fixed_elements);
  check_chain_model(chain, origin);
  return chain;
}

}  // namespace hapticcal::detail

namespace hapticcal {

DeviceModel parse_urdf(const std::string& text, const std::string& origin, const std::string& tip,
                       const std::string& root) {
  return detail::read_chain(text, origin, tip, root).model;
}

DeviceModel load_urdf(const std::string& path, const std::string& tip, const std::string& root) {
  return parse_urdf(read_file(path, FileKind::kUrdf), path, tip, root);
}

std::string measurement_frame_link(const std::string& text, const std::string& origin) {
  detail::check_xml(text, origin);
  const detail::Document doc = detail::locate(text, origin);
  std::set<std::string> children;
  for (const auto& [name, index] : doc.joints) {
    if (const detail::XmlElement* child = doc.child(doc.elements[index], "child")) {
      if (const detail::XmlAttribute* link = child->attribute("link")) children.insert(link->value);
    }
  }
  // The last written: a later calibration of a calibrated.urdf adds its own.
  std::string found;
  int last = -1;
  for (const auto& [name, index] : doc.links) {
    if (name.find("hapticcal_measurement") == std::string::npos || !children.count(name)) continue;
    if (index > last) found = name, last = index;
  }
  return found;
}

}  // namespace hapticcal
