// Builds an orocos KDL chain from a URDF, independently of hapticcal's reader:
// urdfdom's tree is walked from the tip link up to the root link, and each joint
// becomes a KDL segment whose tip frame is the joint origin and whose KDL joint
// turns about (or slides along) the URDF axis through that origin, expressed in
// the parent link's frame (what kdl_parser does; it is not available here).
#pragma once

#include <urdf_parser/urdf_parser.h>

#include <algorithm>
#include <kdl/chain.hpp>
#include <kdl/frames.hpp>
#include <stdexcept>
#include <string>
#include <vector>

namespace hapticcal::testing {

inline KDL::Frame kdl_frame(const urdf::Pose& pose) {
  const urdf::Rotation& r = pose.rotation;
  return KDL::Frame(KDL::Rotation::Quaternion(r.x, r.y, r.z, r.w),
                    KDL::Vector(pose.position.x, pose.position.y, pose.position.z));
}

// The chain root -> tip of the URDF text; throws std::runtime_error if urdfdom
// cannot read it or the tip is not below the root (nor beside it, joined by
// fixed joints).
inline KDL::Chain kdl_chain_from_urdf(const std::string& urdf_text, const std::string& root,
                                      const std::string& tip) {
  const urdf::ModelInterfaceSharedPtr model = urdf::parseURDF(urdf_text);
  if (!model) throw std::runtime_error("urdfdom cannot read the URDF");
  // A root beside the chain (a measurement frame hanging below the robot's
  // root by fixed joints): up from it to the first link above the tip, each
  // fixed joint a segment with the inverse of its origin (as KDL::Tree::getChain
  // walks up a tree).
  std::vector<std::string> above_tip;
  for (urdf::LinkConstSharedPtr l = model->getLink(tip); l;
       l = l->parent_joint ? model->getLink(l->parent_joint->parent_link_name) : nullptr) {
    above_tip.push_back(l->name);
  }
  KDL::Chain chain;
  urdf::LinkConstSharedPtr top = model->getLink(root);
  while (top && std::find(above_tip.begin(), above_tip.end(), top->name) == above_tip.end()) {
    if (!top->parent_joint || top->parent_joint->type != urdf::Joint::FIXED) {
      throw std::runtime_error("tip is not below root, nor joined to it by fixed joints");
    }
    chain.addSegment(KDL::Segment(top->parent_joint->parent_link_name, KDL::Joint(KDL::Joint::None),
                                  kdl_frame(top->parent_joint->parent_to_joint_origin_transform)
                                      .Inverse()));
    top = model->getLink(top->parent_joint->parent_link_name);
  }
  if (!top) throw std::runtime_error("unknown root");
  std::vector<urdf::JointConstSharedPtr> joints;
  urdf::LinkConstSharedPtr link = model->getLink(tip);
  while (link && link != top) {
    if (!link->parent_joint) throw std::runtime_error("tip is not below root");
    joints.push_back(link->parent_joint);
    link = model->getLink(link->parent_joint->parent_link_name);
  }
  if (!link) throw std::runtime_error("unknown tip or root");
  std::reverse(joints.begin(), joints.end());

  for (const urdf::JointConstSharedPtr& j : joints) {
    const KDL::Frame origin = kdl_frame(j->parent_to_joint_origin_transform);
    KDL::Vector axis(j->axis.x, j->axis.y, j->axis.z);
    axis.Normalize();
    KDL::Joint joint(j->name, KDL::Joint::None);
    switch (j->type) {
      case urdf::Joint::REVOLUTE:
      case urdf::Joint::CONTINUOUS:
        joint = KDL::Joint(j->name, origin.p, origin.M * axis, KDL::Joint::RotAxis);
        break;
      case urdf::Joint::PRISMATIC:
        joint = KDL::Joint(j->name, origin.p, origin.M * axis, KDL::Joint::TransAxis);
        break;
      case urdf::Joint::FIXED:
        break;
      default:
        throw std::runtime_error("joint type not handled: " + j->name);
    }
    chain.addSegment(KDL::Segment(j->child_link_name, joint, origin));
  }
  return chain;
}

}  // namespace hapticcal::testing
