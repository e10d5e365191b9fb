// A joint-error family of step 2 (harmonic, compliance, coupling, backlash, or
// one of a program's own) as one member of one interface: what it offers for a
// model and log, its stages and per-pose features, how its fitted values become
// the calibrated model's, and its tolerance. A family is one file and one
// register_joint_error_family call (the built-in ones: src/identification/
// families/, one line each in registry.cpp); calibrate asks the registry which
// families exist, which apply, and has each offer its parameters.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "hapticcal/core/log.hpp"
#include "hapticcal/model/model.hpp"

namespace hapticcal {

// What a family sees of a calibration when it offers its parameters: step 2's
// start and nominal (add_block appends its block to both; a family may set what
// its parameters need on both, e.g. lumped masses), the poses, and the notes
// the result will carry.
struct FamilyOffer {
  DeviceModel& model;
  DeviceModel& nominal;
  const Log& poses;
  std::vector<std::string>& notes;
};

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
  // Whether it applies to this model (step 1's) and these poses: the model
  // search offers it without being asked.
  virtual bool applies(const DeviceModel& model, const Log& poses) const = 0;
  // Its parameters offered (add_block); InputError (one line) where this
  // model or log cannot have them.
  virtual void offer(FamilyOffer& offer) const = 0;
  // Its block on this model: every parameter it could fit (offer keeps those
  // the log can see); tests build a model's block with it.
  virtual DeviceModel::FittedBlock block(const DeviceModel& model) const = 0;
  // Its stages on a model that has its parameters (joint_error_stages).
  virtual void add_stages(const DeviceModel& model, const AddStage& add) const = 0;
  // Whether its stages bend their link about its lateral axis
  // (Link::lateral_compliance's, kinematics.hpp) instead of moving the joint
  // value (the default).
  virtual bool bends() const { return false; }
  // Its stored features of a pose on this model (none: it stores none).
  virtual std::unique_ptr<PoseFeatures> pose_features(const DeviceModel&) const { return nullptr; }
  // Its fitted parameters made the model's own (the calibrated model has no
  // step-2 parameters); why they cannot be, or "".
  virtual std::string fold(DeviceModel& model) const = 0;
  // The tolerance prior's sd of its parameters (SI).
  virtual double tolerance() const = 0;
};

// A family's block (its name a string literal) added to the offer's model and
// nominal, after the blocks offered before it.
void add_block(FamilyOffer& offer, const DeviceModel::FittedBlock& block);
// A block of one parameter per link, its value the link's `Field` (compliance,
// backlash), named `name`, in `prismatic_unit` on a prismatic link.
template <double Link::*Field>
DeviceModel::FittedBlock per_link_block(const DeviceModel& model, const char* family,
                                        const char* name, ParameterUnit unit,
                                        ParameterUnit prismatic_unit) {
  DeviceModel::FittedBlock block{family, {}};
  for (int i = 0; i < model.dof(); ++i) {
    DeviceModel::FittedParameter p{name, model.links[i].prismatic() ? prismatic_unit : unit, i, i};
    p.get = [](const DeviceModel& m, const DeviceModel::FittedParameter& f) {
      return m.links[f.link].*Field;
    };
    p.set = [](DeviceModel& m, const DeviceModel::FittedParameter& f, double value) {
      m.links[f.link].*Field = value;
    };
    block.parameters.push_back(p);
  }
  return block;
}
// One stage a parameter of the family's block on the model (its link, its
// slot, one parameter) with its value in the joint values `nominal`.
void add_block_stages(const DeviceModel& model, std::string_view family, const AddStage& add,
                      const std::function<double(const DeviceModel::FittedParameter&)>& nominal);
// The family's block removed from the model (fold: its values are the model's).
void drop_block(DeviceModel& model, std::string_view family);
// A family registered after the built-in ones (not thread-safe: before any
// calibration runs). std::invalid_argument if a family has its name.
void register_joint_error_family(const JointErrorFamily* family);

// A joint effect (model/joint_effect.hpp) and its step-2 family, registered
// together: the family's name is the effect's, one parameter c a joint whose
// reading is its own, its feature the effect's f at the reading, its fold the
// links' effects, its tolerance the effect's bound (a weak prior). The one
// call a new effect needs (families/effect.cpp).
class JointEffect;
void register_joint_effect_family(const JointEffect* effect);

// Every family, in the model search's order (registry.cpp).
const std::vector<const JointErrorFamily*>& joint_error_families();
// The family of this name, or null.
const JointErrorFamily* find_joint_error_family(std::string_view name);

// Whether joint i's value is its own reading alone and no other joint's uses
// it (a harmonic stage acts on the reading; a coupling mixes readings).
bool own_reading(const DeviceModel& model, int i);

}  // namespace hapticcal
