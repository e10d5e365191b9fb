// Internal: a joint-error family of step 2 (harmonic, compliance, coupling,
// backlash) as one member of one interface. A family is one file in this
// folder and one line in registry.cpp; calibrate asks the registry which
// families exist, which apply to a model and log, and has each offer its
// parameters.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "hapticcal/model/model.hpp"

namespace hapticcal::detail {

struct CalibrationRun;

// A family's features of a pose, bound to one model (StepTwoJoints): its
// stored stages' features, in its stages' order, from the pose's joint
// values, readings and approach sides (none: empty).
class PoseFeatures {
 public:
  virtual ~PoseFeatures() = default;
  virtual void operator()(const double* joint, const Eigen::VectorXd& q,
                          const Eigen::Ref<const Eigen::RowVectorXd>& direction,
                          double* out) const = 0;
  // Whether they depend on the joint values alone (formed again when a pose's
  // joint values move: StepTwoJoints::refresh), not on its readings or sides.
  virtual bool of_joint_values() const { return false; }
};

// Adds a stage (JointErrorStage): its joint, first slot, parameters and their
// value in the joint values; `formed`: a stage whose features the rows form
// from the joint's value (a harmonic's), else they are stored a pose.
using AddStage =
    std::function<void(int link, int slot, int count, double nominal, const Transmission* formed)>;

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
  // Its stages on a model that has its parameters (joint_error_stages).
  virtual void add_stages(const DeviceModel& model, const AddStage& add) const = 0;
  // Its stored features of a pose on this model (none: it stores none).
  virtual std::unique_ptr<PoseFeatures> pose_features(const DeviceModel&) const { return nullptr; }
  // Its fitted parameters made the model's own (the calibrated model has no
  // step-2 parameters); why they cannot be, or "".
  virtual std::string fold(DeviceModel& model) const = 0;
};

// Every family, in the model search's order (registry.cpp).
const std::vector<const JointErrorFamily*>& joint_error_families();
// The family of this name, or null.
const JointErrorFamily* find_joint_error_family(std::string_view name);

// Whether joint i's value is its own reading alone and no other joint's uses
// it (a harmonic stage acts on the reading; a coupling mixes readings).
bool own_reading(const CalibrationRun& run, int i);

}  // namespace hapticcal::detail
