// A joint-error family is one file and one line: a family written here, outside
// the library, and registered with one call, is offered by --joint-errors and
// by the default's model search, estimated with its sd, named in the
// parameters, and folded into the calibrated model, with no edit to the model,
// the tolerances, the cost or the search; it includes public headers only, as
// a program linking the installed library would.
//
// The family, "scale": each revolute joint's angle off by s_i times its reading
// (a drive ratio error, theta_i = q_i + s_i q_i), folded into a monomial
// polynomial transmission dtheta(q) = s_i q. The truth is a Panda-like arm whose
// drives are 0.1 % to 0.3 % off; tracker positions carry no encoder, so step 1
// cannot see the ratios and only step 2's family can.
#include "hapticcal/identification/joint_error_family.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>
#include <variant>

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "support/held_out.hpp"
#include "support/test_models.hpp"

namespace hapticcal {
namespace {

// A drive ratio off by s: dtheta(q) = s q.
Transmission ratio_error(double s) {
  return Transmission::Model{Polynomial{PolynomialBasis::kMonomial, -1.0, 1.0, {0.0, s}}};
}

class ScaleFamily : public JointErrorFamily {
 public:
  std::string_view name() const override { return "scale"; }
  // Every revolute joint without a transmission of its own to fold into.
  bool applies(const DeviceModel& model, const Log&) const override {
    return !block(model).parameters.empty();
  }
  void offer(FamilyOffer& offer) const override {
    const DeviceModel::FittedBlock b = block(offer.model);
    if (b.parameters.empty()) {
      throw InputError("--joint-errors scale: no revolute joint without a transmission");
    }
    add_block(offer, b);
  }
  // s_i of each revolute link without a transmission: its value kept in the
  // block (no get / set: the model has no field for it until the fold).
  DeviceModel::FittedBlock block(const DeviceModel& model) const override {
    DeviceModel::FittedBlock b{"scale", {}};
    for (int i = 0; i < model.dof(); ++i) {
      if (!model.links[i].prismatic() && model.links[i].transmission.is_none())
        b.parameters.push_back({"s", ParameterUnit::kAngle, i, i});
    }
    return b;
  }
  void add_stages(const DeviceModel& model, const AddStage& add) const override {
    add_block_stages(model, name(), add, [](const DeviceModel::FittedParameter&) { return 0.0; });
  }
  // Its feature: the joint's own reading.
  class Readings : public PoseFeatures {
   public:
    explicit Readings(const DeviceModel& model) : model_(model) {}
    void operator()(const double*, const Eigen::VectorXd& q,
                    const Eigen::Ref<const Eigen::RowVectorXd>&, double* out) const override {
      for (const DeviceModel::FittedParameter& f : model_.fitted_block("scale")->parameters)
        *out++ = q[f.link];
    }

   private:
    const DeviceModel& model_;
  };
  std::unique_ptr<PoseFeatures> pose_features(const DeviceModel& model) const override {
    if (!model.fitted_block(name())) return nullptr;
    return std::make_unique<Readings>(model);
  }
  std::string fold(DeviceModel& model) const override {
    const DeviceModel::FittedBlock* b = model.fitted_block(name());
    if (!b) return "";
    for (const DeviceModel::FittedParameter& f : b->parameters) {
      model.links[f.link].transmission = ratio_error(f.value);
    }
    drop_block(model, name());
    return "";
  }
  double tolerance() const override { return 1e-2; }
};

const ScaleFamily kScale;

// The one line.
const bool kRegistered = (register_joint_error_family(&kScale), true);

// The fold's ratio error of link i (0 without one).
double folded_scale(const DeviceModel& m, int i) {
  const auto* p = std::get_if<Polynomial>(&m.links[i].transmission.model());
  return p && p->coefficients.size() == 2 ? p->coefficients[1] : 0.0;
}

struct Study {
  DeviceModel nominal, actual;
  testing::HeldOutStudy data;
};

Study scaled_arm() {
  Study s;
  s.nominal = testing::panda_like();
  std::mt19937_64 rng(41);
  s.actual = testing::perturbed(s.nominal, rng, 1e-3);
  std::uniform_real_distribution<double> size(1e-3, 3e-3);
  for (int i = 0; i < s.actual.dof(); ++i) {
    const double s_i = (i % 2 ? -1 : 1) * size(rng);
    s.actual.links[i].transmission = ratio_error(s_i);
  }
  s.data = testing::held_out_study(s.actual, 250, 20e-6, 43);
  for (Log* log : {&s.data.cal, &s.data.val}) {  // no external encoders
    log->has_ext.assign(log->dof(), false);
    log->ext.setZero();
  }
  return s;
}

TEST(JointErrorFamily, ARegisteredFamilyIsFittedFoldedAndNamed) {
  ASSERT_TRUE(kRegistered);
  ASSERT_NE(find_joint_error_family("scale"), nullptr);
  const Study s = scaled_arm();
  const double floor = s.data.floor;

  CalibrationOptions geometry_alone;
  geometry_alone.joint_errors = {"none"};
  const CalibrationResult geometric = calibrate(s.nominal, s.data.cal, geometry_alone);
  const double geometric_rms =
      evaluate(geometric.calibrated, s.data.val).figure("position")->stats.rms;

  CalibrationOptions options;
  options.joint_errors = {"scale"};
  const CalibrationResult r = calibrate(s.nominal, s.data.cal, options);
  ASSERT_EQ(r.status, CalibrationStatus::kConverged) << r.status_reason;
  EXPECT_TRUE(r.calibrated.fitted.empty());
  const double held_out = evaluate(r.calibrated, s.data.val).figure("position")->stats.rms;
  std::printf("scale family: held-out %.4f mm (geometry alone %.4f mm, noise floor %.4f mm)\n",
              held_out * 1e3, geometric_rms * 1e3, floor * 1e3);
  EXPECT_GT(geometric_rms, 3 * floor);
  EXPECT_LT(held_out, 1.2 * floor);

  // Each ratio the fit could identify is within 3 sd of the truth and is the
  // calibrated model's transmission; the ones it could not are named why.
  int identified = 0;
  for (int i = 0; i < s.nominal.dof(); ++i) {
    const std::string name = s.nominal.links[i].name + ".s";
    const ParameterEstimate* e = testing::find_parameter(r.kinematics, name);
    ASSERT_NE(e, nullptr) << name;
    EXPECT_EQ(folded_scale(r.calibrated, i), e->value) << name;
    if (!e->identifiable) {
      EXPECT_FALSE(e->reason.empty()) << name;
      continue;
    }
    ++identified;
    const double truth = folded_scale(s.actual, i);
    EXPECT_LT(std::abs(e->value - truth), 3 * e->sd)
        << name << " " << e->value << " +- " << e->sd << " (truth " << truth << ")";
    EXPECT_LT(e->sd, 0.2 * std::abs(truth)) << name;
  }
  EXPECT_GE(identified, s.nominal.dof() - 1);

  // A block of no registered family, or whose parameter has another's name
  // ("panda_joint1.x" is the geometry's), is refused before it is offered.
  DeviceModel model = s.nominal, nominal = s.nominal;
  std::vector<std::string> notes;
  FamilyOffer offer{model, nominal, s.data.cal, notes};
  DeviceModel::FittedBlock stray{"no-such-family", {{"s", ParameterUnit::kAngle, 0, 0}}};
  EXPECT_THROW(add_block(offer, stray), std::logic_error);
  DeviceModel::FittedBlock clash{"scale", {{"x", ParameterUnit::kLength, 0, 0}}};
  EXPECT_THROW(add_block(offer, clash), std::logic_error);
  EXPECT_TRUE(model.fitted.empty());
  // A second family of a name a family has is refused.
  EXPECT_THROW(register_joint_error_family(&kScale), std::invalid_argument);
  // Its default tolerance is the family's, and a user's overrides it.
  Tolerances t;
  EXPECT_EQ(t.family("scale"), 1e-2);
  t.by_family["scale"] = 5e-3;
  EXPECT_EQ(t.family("scale"), 5e-3);
  // A tolerance of no family, or out of range, is a clear refusal.
  for (const auto& [family, value] : {std::pair{"scales", 1e-2}, std::pair{"scale", 0.0}}) {
    CalibrationOptions o = options;
    o.tolerances.by_family[family] = value;
    EXPECT_THROW(calibrate(s.nominal, s.data.cal, o), InputError) << family << " " << value;
  }
}

// The default's search offers it without being asked, and keeps it on held-out
// error; a model it cannot apply to refuses it by name.
TEST(JointErrorFamily, TheDefaultSearchOffersARegisteredFamily) {
  ASSERT_TRUE(kRegistered);
  const Study s = scaled_arm();
  const CalibrationResult found = calibrate(s.nominal, s.data.cal, {});
  ASSERT_EQ(found.status, CalibrationStatus::kConverged) << found.status_reason;
  const auto& families = found.kinematics.joint_error_families;
  EXPECT_NE(std::find(families.begin(), families.end(), "scale"), families.end());
  EXPECT_LT(evaluate(found.calibrated, s.data.val).figure("position")->stats.rms,
            1.2 * s.data.floor);

  DeviceModel driven = s.nominal;
  for (Link& l : driven.links) l.transmission = ratio_error(0.0);
  CalibrationOptions options;
  options.joint_errors = {"scale"};
  try {
    calibrate(driven, s.data.cal, options);
    ADD_FAILURE() << "a model with transmissions everywhere accepted --joint-errors scale";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("scale"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace hapticcal
