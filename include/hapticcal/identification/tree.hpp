// Several tips on one tree: the chains root -> tip of one URDF (two hands on a
// shared torso, two tools on one base), measured together (a log's x1, y1, z1
// at the first tip, x2, y2, z2 at the second, ...). The tree is one model
// (tree_model: DeviceModel::tree), in which a joint the chains share is one set
// of parameters, calibrated, evaluated and planned by the chain's procedure on
// one sample a tip (tip_samples).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "hapticcal/core/log.hpp"
#include "hapticcal/identification/identification.hpp"
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

// The tips of a --tip value: its comma-separated names (one: a chain).
std::vector<std::string> tip_names(const std::string& tip);
// The one way a command loads its model: `path` with a --tip value. Several
// tips, the URDF's tree (tree_model of parse_tree); else load_model's (a
// device file may hold a tree). `urdf_text`: the URDF's text already read (the
// text calibrate writes calibrated.urdf into) instead of reading `path` again.
DeviceModel load_model_or_tree(const std::string& path, const std::string& tip,
                               const std::string& root = "",
                               const std::string* urdf_text = nullptr);
// The same with the tips already named (a tree's, in order).
DeviceModel load_model_or_tree(const std::string& path, const std::vector<std::string>& tips,
                               const std::string& root, const std::string* urdf_text = nullptr);

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

// A tree log (x1, y1, z1 at the first tip, x2, ... at the second, ...) as
// one sample a tip of each row, in row order (Log::tip): each a position of
// its tip, with the row's readings, directions, time and line. InputError
// naming the log for another number of marker points than the model's tips.
// M >= 3 markers a tip (x1 .. x<KM>, the first tip's M first): each sample
// its tip's markers, a rigid body (one layout on every tip: calibrate turns
// them into the body's poses, markers.hpp).
// A fixture log of a tree names a label a tip (point1 .. pointK, which the
// log reader keeps joined by ','): each sample its tip's label.
// `only`: that tip's sample of each row alone (none: every tip's).
Log tip_samples(const DeviceModel& tree, const Log& log, std::optional<int> only = std::nullopt);

// How many of the log's `noun`s ("row", "pose") `samples` of a fit are: "10
// poses" for a chain; a tree's a sample a tip of each, "5 poses of 2 tips, 10
// points".
std::string samples_text(int samples, int tips, const char* noun);

// Chain c's log: its readings (the tree's columns of its joints) and its tip's
// point (the tree log's marker c) as positions.
Log chain_log(const DeviceTree& tree, const Log& log, int chain);

}  // namespace hapticcal
