// A joint effect of a program's own: a term c f(q) in a joint's value, where a
// transmission's error is (theta_i = q_i + dtheta_i(q_i) + sum_e c_e f_e(q_i)
// + offset_i, before a coupling mixes the readings), c the link's value of the
// effect (Link::effects, by the effect's name) and f a function of the joint's
// own reading. A new effect is one subclass and one registration
// (register_joint_effect; with its step-2 family, register_joint_effect_family
// in identification/joint_error_family.hpp): the device files (a link's key of
// the effect's name), the URDF files (<hapticcal_effect name="" value=""/> in a
// joint), the kinematics, the simulation and the driver's tables take it, and
// a program that has not registered it refuses a file that names it.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "hapticcal/model/model.hpp"

namespace hapticcal {

class JointEffect {
 public:
  virtual ~JointEffect() = default;
  // Its name: a link's key in a device file ([a-z_]+, no key a link has).
  virtual std::string_view name() const = 0;
  // f(q) and its slope f'(q) at the joint's reading q.
  virtual double feature(double q) const = 0;
  virtual double slope(double q) const = 0;
  // The largest |c| a file may give (beyond it, a typo: refused).
  virtual double bound() const = 0;
};

// Adds an effect (before any model is read or a calibration runs: the registry
// is not locked). std::invalid_argument for an effect whose name an effect or a
// link key has, or that is not [a-z_]+.
void register_joint_effect(const JointEffect* effect);
// Every registered effect, in the order they were registered.
const std::vector<const JointEffect*>& joint_effects();
// The effect of this name, or null.
const JointEffect* find_joint_effect(std::string_view name);

// The link's effects at reading q: sum_e c_e f_e(q), and its slope.
double effects_error(const Link& link, double q);
double effects_slope(const Link& link, double q);
// Whether some link of the model has an effect.
bool has_joint_effects(const DeviceModel& model);

}  // namespace hapticcal
