// Internal: the joint-error family interface (public:
// hapticcal/identification/joint_error_family.hpp) under the names the
// library's code uses.
#pragma once

#include "hapticcal/identification/joint_error_family.hpp"

namespace hapticcal::detail {

using hapticcal::add_block;
using hapticcal::add_block_stages;
using hapticcal::AddStage;
using hapticcal::drop_block;
using hapticcal::FamilyOffer;
using hapticcal::find_joint_error_family;
using hapticcal::joint_error_families;
using hapticcal::JointErrorFamily;
using hapticcal::own_reading;
using hapticcal::per_link_block;
using hapticcal::PoseFeatures;
using hapticcal::register_joint_error_family;

}  // namespace hapticcal::detail
