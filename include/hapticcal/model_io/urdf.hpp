// Device models from and to URDF. A URDF's chain from a root
// link to a tip link becomes a DeviceModel whose links have URDF origin + axis
// geometry; a device model is written as a URDF; a calibrated model goes back
// into its source URDF with only the chain's joint origins changed.
#pragma once

#include <string>
#include <vector>

#include "hapticcal/model/model.hpp"

namespace hapticcal {

// The chain root -> tip of the URDF `text` as a device model (`origin` names the
// text in error messages). root defaults to the URDF's root link; tip is needed
// unless the tree below the root has exactly one leaf link.
// - Each revolute, continuous or prismatic joint becomes a Link named after the
//   joint, with geometry kOrigin: its origin, its unit axis, offset 0. Limits are
//   the joint's <limit> (radians, metres); a continuous joint gets [-pi, pi].
// - Fixed joints are folded: those before a movable joint into its origin, those
//   after the last one into the tool pose.
// - The base is the identity pose: the measurement frame is the root link's frame
//   until a calibration moves it. A root that is not above the tip but joined
//   to the tip's branch by fixed joints only (calibrated_urdf's
//   hapticcal_measurement link) is the measurement frame: those joints, taken
//   upwards, are the base pose.
// - The model is named after <robot name>. Joints and links off the chain (and
//   mimic joints there) are ignored.
// InputError (one line, naming the file and the joint or link) for malformed XML
// or URDF, an unknown root or tip, a tip not below the root (nor joined to it by
// fixed joints), a floating, planar or mimic joint in the chain, a joint name
// that cannot name a link, more than kMaxDof movable joints, or none.
DeviceModel parse_urdf(const std::string& text, const std::string& origin, const std::string& tip,
                       const std::string& root = "");
DeviceModel load_urdf(const std::string& path, const std::string& tip,
                      const std::string& root = "");

// What of `model` a URDF cannot hold ("joint compliance, backlash, the
// transmissions' errors"), or empty: written only as comments.
std::string not_in_urdf(const DeviceModel& model);

// Written in a calibrated URDF's comment before what it leaves out (joint
// compliance, backlash, transmissions: URDF cannot express them).
inline constexpr const char* kLeftOut = "left out (URDF cannot express it): ";

// The link a calibrated URDF holds its calibration's measurement frame in (the
// one hapticcal wrote: a name holding "hapticcal_measurement", attached below
// the robot rather than its root; the last written if a file was calibrated
// again), or empty. Reading the chain from it (--root) reproduces the
// calibrated model in the tracker's frame.
std::string measurement_frame_link(const std::string& text, const std::string& origin);

// The model as a URDF: link `hapticcal_measurement` (the measurement frame) ->
// fixed joint `base_joint` (B) -> `base_link` -> one revolute or prismatic joint
// per link (named after it, child link `<name>_link`) -> fixed joint `tool_joint`
// -> link `tool`. Joint offsets (DH theta or d, MDH, origin offsets) are folded
// into the joint origins, so parse_urdf(..., "tool") gives the same kinematics.
// Transmissions cannot be expressed in URDF: each is written as an XML comment
// (its device-file YAML). A device file has no effort or velocity limits: the
// <limit> elements carry effort="0" velocity="0".
std::string device_to_urdf(const DeviceModel& model);

// The URDF `urdf_text` with the calibrated joint origins of the chain root -> tip
// (as parse_urdf reads it; `calibrated` is a calibration of that model). Each
// movable joint whose origin or offset changed gets the <origin> that gives the
// calibrated A_k with offset 0: F_k^-1 * O_k * motion(axis, offset_k), where F_k
// composes the fixed joints folded into it. A changed tool pose goes into the
// last fixed joint before the tip; if the tip is the child of a movable joint, a
// fixed joint `hapticcal_tool_joint` and link `hapticcal_tool` are added under
// it (and `notes` says so). A calibrated base (the measurement frame: a
// tracker's, registered or fitted) is written as a link `hapticcal_measurement`
// below the chain's root, by a fixed joint whose origin is B^-1: the chain
// hapticcal_measurement -> tip (parse_urdf goes up the fixed joint into the
// base) is the calibrated model, the chain root -> tip the robot alone. A chain
// read from such a root has that joint's origin replaced instead. Everything
// else of the text is kept byte for byte.
// InputError if `calibrated` does not match the chain (joint names, types, axes).
std::string calibrated_urdf(const std::string& urdf_text, const std::string& origin,
                            const std::string& tip, const std::string& root,
                            const DeviceModel& calibrated,
                            std::vector<std::string>* notes = nullptr);

}  // namespace hapticcal
