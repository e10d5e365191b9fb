// Internal: the joint-error family interface (public:
// hapticcal/identification/joint_error_family.hpp) under the names the
// library's code uses.
#pragma once

#include <string_view>

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

// The gravity that loads a compliance family's joints, and the masses: the
// model's, or each link a lumped 1 kg at its frame's origin (on the offer's
// model and nominal, with a note naming the family and its parameter).
// InputError for zero gravity.
void gravity_loads(FamilyOffer& offer, std::string_view family, std::string_view parameter);

}  // namespace hapticcal::detail
