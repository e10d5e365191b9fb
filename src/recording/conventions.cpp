#include "recording/conventions.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <numbers>

#include "hapticcal/core/error.hpp"
#include "recording/import_topics.hpp"

namespace hapticcal::recording {

std::vector<std::string> Convention::reading_names() const {
  std::vector<std::string> out;
  for (const Reading& r : readings_) out.push_back(r.name);
  return out;
}

void Convention::bind(const std::vector<std::string>& names, const std::string& what) {
  index_.clear();
  for (const Reading& r : readings_) {
    std::vector<int> at;
    for (const Term& t : r.terms) {
      const auto found = std::find(names.begin(), names.end(), t.joint);
      if (found == names.end()) {
        throw InputError("", 0, "--convention",
                         fmt::format("{}: the joint '{}' is not among {}'s joints ({})", name_,
                                     t.joint, what, bounded_list(names)));
      }
      at.push_back(static_cast<int>(found - names.begin()));
    }
    index_.push_back(std::move(at));
  }
}

std::vector<int> Convention::positions_used() const {
  std::vector<int> out;
  for (const std::vector<int>& at : index_) out.insert(out.end(), at.begin(), at.end());
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

void Convention::readings_of(const double* positions, std::vector<double>& out) const {
  out.assign(readings_.size(), 0.0);
  for (std::size_t i = 0; i < readings_.size(); ++i) {
    double value = readings_[i].offset;
    for (std::size_t k = 0; k < readings_[i].terms.size(); ++k)
      value += readings_[i].terms[k].coefficient * positions[index_[i][k]];
    out[i] = value;
  }
}

std::string Convention::note() const {
  return fmt::format("joints mapped by the convention {} ({}; {})", name_, device_, source_);
}

// The Touch's drivers all publish the waist negated and the elbow relative to
// the shoulder (OpenHaptics' joint angles t = {joints[0], joints[1],
// joints[2] - joints[1]}); they differ in the gimbal's signs and offsets, and
// share their joint names, so a recording cannot say which driver wrote it:
// the user names it. Each map inverts the driver's published formula (quoted).
std::vector<Convention> conventions() {
  using R = Convention::Reading;
  constexpr double pi = std::numbers::pi;
  // q1 = -waist, q2 = shoulder, q3 = elbow + shoulder: the device file's raw
  // HD_CURRENT_JOINT_ANGLES from every driver's arm joints.
  const std::vector<R> arm = {{"q1 (waist)", {{"waist", -1}}, 0},
                              {"q2 (shoulder)", {{"shoulder", 1}}, 0},
                              {"q3 (elbow)", {{"elbow", 1}, {"shoulder", 1}}, 0}};
  const auto touch = [&](std::vector<R> gimbal) {
    std::vector<R> all = arm;
    all.insert(all.end(), gimbal.begin(), gimbal.end());
    return all;
  };
  return {
      Convention("ros-geomagic", "geomagic-touch",
                 "WPI-AIM/ros_geomagic geomagic_control/src/device_node.cpp (commit 02bb7ea8): "
                 "position[3] = "
                 "-thetas[4] + M_PI, [4] = -thetas[5] - 3*M_PI/4, [5] = -(-thetas[6] - M_PI)",
                 touch({{"q4 (yaw)", {{"yaw", -1}}, pi},
                        {"q5 (pitch)", {{"pitch", -1}}, -3 * pi / 4},
                        {"q6 (roll)", {{"roll", 1}}, -pi}})),
      Convention("phantom-omni", "geomagic-touch",
                 "the fsuarez6/phantom_omni line, e.g. bharatm11/Geomagic_Touch_ROS_Drivers "
                 "omni_common/src/omni_state.cpp (commit 0340cbe1): as ros-geomagic but "
                 "position[5] = -thetas[6] - M_PI",
                 touch({{"q4 (yaw)", {{"yaw", -1}}, pi},
                        {"q5 (pitch)", {{"pitch", -1}}, -3 * pi / 4},
                        {"q6 (roll)", {{"roll", -1}}, -pi}})),
      Convention(
          "touch-common", "geomagic-touch",
          "Carrot404/Touch_ROS_Drivers_Applications touch_common/src/touch_state.cpp (commit "
          "907d207f): "
          "position[3] = -gimbal_angles[0], [4] = gimbal_angles[1] + 1.49, [5] = gimbal_angles[2]",
          touch({{"q4 (yaw)", {{"yaw", -1}}, 0},
                 {"q5 (pitch)", {{"pitch", 1}}, -1.49},
                 {"q6 (roll)", {{"roll", 1}}, 0}})),
      Convention(
          "saw-sensable-phantom", "geomagic-touch",
          "jhu-saw/sawSensablePhantom core/components/code/mtsSensableHD.cpp (commit 38dd0d68), "
          "default "
          "joint-scales 1 and joint-offsets 0: Position()[0] = -Position()[0], Position()[2] -= "
          "Position()[1], the gimbal's as read",
          touch({{"q4 (yaw)", {{"yaw", 1}}, 0},
                 {"q5 (pitch)", {{"pitch", 1}}, 0},
                 {"q6 (roll)", {{"roll", 1}}, 0}})),
      // The dVRK publishes joint positions (measured_js: the actuators through
      // ActuatorToJointPosition); the device file's readings are the actuators.
      Convention("dvrk-mtm", "dvrk-mtm",
                 "sawIntuitiveResearchKit 2.x measured_js (mtsIntuitiveResearchKitArm.cpp commit "
                 "08179d87: "
                 "ActuatorToJointPosition * the actuators; share/kinematic/mtmr.json commit "
                 "2a3ae486 lines 83-84: "
                 "joint 3 = a3 - a2, joint 4 = a4 + 0.6697 (a2 - a3)), inverted",
                 {{"q1 (outer_yaw)", {{"outer_yaw", 1}}, 0},
                  {"q2 (shoulder_pitch)", {{"shoulder_pitch", 1}}, 0},
                  {"q3 (elbow_pitch)", {{"elbow_pitch", 1}, {"shoulder_pitch", 1}}, 0},
                  {"q4 (wrist_platform)", {{"wrist_platform", 1}, {"elbow_pitch", 0.6697}}, 0},
                  {"q5 (wrist_pitch)", {{"wrist_pitch", 1}}, 0},
                  {"q6 (wrist_yaw)", {{"wrist_yaw", 1}}, 0},
                  {"q7 (wrist_roll)", {{"wrist_roll", 1}}, 0}}),
  };
}

Convention convention_named(const std::string& name) {
  std::vector<std::string> known;
  for (const Convention& c : conventions()) {
    if (c.name() == name) return c;
    known.push_back(c.name());
  }
  throw InputError("", 0, "--convention",
                   fmt::format("'{}': not a convention hapticcal knows ({}){}", printable(name),
                               known.empty() ? "none" : fmt::format("{}", fmt::join(known, ", ")),
                               did_you_mean(name, known)));
}

}  // namespace hapticcal::recording
