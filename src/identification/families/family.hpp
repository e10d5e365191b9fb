// Internal: a joint-error family of step 2 (harmonic, compliance, coupling,
// backlash) as one member of one interface. A family is one file in this
// folder and one line in registry.cpp; calibrate asks the registry which
// families exist, which apply to a model and log, and has each offer its
// parameters.
#pragma once

#include <string_view>
#include <vector>

namespace hapticcal::detail {

struct CalibrationRun;

class JointErrorFamily {
 public:
  virtual ~JointErrorFamily() = default;
  // Its --joint-errors name.
  virtual std::string_view name() const = 0;
  // Whether it applies to the run's model and poses: the model search offers
  // it without being asked.
  virtual bool applies(const CalibrationRun& run) const = 0;
  // Its parameters offered on run.model and run.step2_nominal; InputError (one
  // line) where this model or log cannot have them.
  virtual void offer(CalibrationRun& run) const = 0;
};

// Every family, in the model search's order (registry.cpp).
const std::vector<const JointErrorFamily*>& joint_error_families();
// The family of this name, or null.
const JointErrorFamily* find_joint_error_family(std::string_view name);

// Whether joint i's value is its own reading alone and no other joint's uses
// it (a harmonic stage acts on the reading; a coupling mixes readings).
bool own_reading(const CalibrationRun& run, int i);

}  // namespace hapticcal::detail
