// Several tips on one tree: the chains root -> tip of one URDF (two hands on a
// shared torso, two tools on one base). The tree is one model (tree_model:
// DeviceModel::tree), in which a joint the chains share is one set of
// parameters; load_model (model_source.hpp) loads it from a URDF and several
// tips.
#pragma once

#include <string>
#include <vector>

#include "hapticcal/model/model.hpp"

namespace hapticcal {

// The tree's parameters are the chains' by name: the base (every chain's: one
// root, one measurement frame), each movable joint once (its URDF name), and a
// tool a tip ("<tip>.tool.x"). Its joints, in order of first appearance over
// the tips (the first chain's, then the second's that are new, ...), are a
// log's q1..qN.
struct DeviceTree {
  std::string name;
  std::vector<std::string> tips;
  std::vector<DeviceModel> chains;          // one a tip, in the order of tips
  std::vector<std::string> joints;          // the tree's movable joints
  std::vector<std::vector<int>> joint_of;   // chain c's link j: its tree joint
  std::vector<ParameterInfo> parameters;    // slot k is the tree's k-th value
  std::vector<std::vector<int>> slot_of;    // chain c's slot: its tree slot
  std::vector<std::vector<int>> chains_of;  // tree slot: the chains that use it

  int dof() const { return static_cast<int>(joints.size()); }
  int num_slots() const { return static_cast<int>(parameters.size()); }
};

// The tree of these chains, chain c ending at tips[c]. InputError (one line)
// for fewer than two chains, a tip named twice, chains that do not start from
// one base, a joint two chains share with different geometry or limits or not
// on their common path from the root, or a chain with joint-error stages,
// compliance or backlash (a device file's, which holds one chain). A chain's
// coupling (a URDF's <mimic> or <hapticcal_coupling>) becomes the tree
// model's (tree_model); two chains that couple a joint they share differently
// are refused there.
DeviceTree make_tree(std::vector<DeviceModel> chains, const std::vector<std::string>& tips);
// The chains root -> tip of a URDF's text, one a tip (parse_urdf); InputError
// besides make_tree's for a tip on the path to another or joined to it by
// fixed joints only (their tools could not both be written back).
DeviceTree parse_tree(const std::string& text, const std::string& origin,
                      const std::vector<std::string>& tips, const std::string& root = "");
// The same from a file.
DeviceTree load_tree(const std::string& path, const std::vector<std::string>& tips,
                     const std::string& root = "");

// The tree as one model (DeviceModel::tree): its links the tree's joints in
// order (a log's q1..qN), each with its parent on the path from the root, the
// first chain's tip and tool, and the other chains' as branches. Tip k's
// kinematics (structure(k), path(k)) are chain k's.
DeviceModel tree_model(const DeviceTree& tree);

// Tip k's chain of a tree model as a model of its own: the links on its path,
// its tool, the tree's base and gravity (its links' masses only: the joints it
// shares carry the other branches too in the tree, not in this chain).
DeviceModel tip_chain(const DeviceModel& tree, int tip);

// The URDF `text` with a tree model's calibrated joints, base and tools written
// back: calibrated_urdf chain by chain, the later chains read from the
// measurement frame the first wrote (a shared joint is written again with the
// same origin). Its notes (once each) into `notes`.
std::string tree_urdf(const std::string& text, const std::string& origin, const std::string& root,
                      const DeviceModel& tree, std::vector<std::string>& notes);

}  // namespace hapticcal
