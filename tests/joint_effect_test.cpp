// A joint effect is one class and one line: an effect written here, outside
// the library, and registered with its step-2 family by one call, is a term of
// the joint's value in the kinematics, written to and read from device files
// and URDF, simulated, fitted by calibrate (by name and by the default's model
// search) and folded into the calibrated model, with no edit to the model, the
// files, the kinematics or the fit; it includes public headers only, as a
// program linking the installed library would.
//
// The effect, "ratio": a drive whose ratio is off by c, theta = q + c q (the
// joint turns 1 + c times what its reading says). Checked against independent
// results: the forward kinematics of a model without the effect at the scaled
// readings, central differences, and the truth that made the logs.
#include "hapticcal/model/joint_effect.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/identification/joint_error_family.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/model_io/urdf.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "hapticcal/study/simulation.hpp"
#include "support/held_out.hpp"
#include "support/test_models.hpp"

namespace hapticcal {
namespace {

class Ratio : public JointEffect {
 public:
  std::string_view name() const override { return "ratio"; }
  double feature(double q) const override { return q; }
  double slope(double) const override { return 1; }
  double bound() const override { return 0.1; }
};

const Ratio kRatio;

// The one line.
const bool kRegistered = (register_joint_effect_family(&kRatio), true);

// The arm with each joint's drive 0.1 % to 0.3 % off (alternating signs).
DeviceModel ratio_arm(const DeviceModel& nominal, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  DeviceModel actual = testing::perturbed(nominal, rng, 1e-3);
  std::uniform_real_distribution<double> size(1e-3, 3e-3);
  for (int i = 0; i < actual.dof(); ++i)
    actual.links[i].effects["ratio"] = (i % 2 ? -1 : 1) * size(rng);
  return actual;
}

// The same arm without the effect, and its readings scaled as the effect scales them.
DeviceModel without_effects(DeviceModel model) {
  for (Link& l : model.links) l.effects.clear();
  return model;
}
Eigen::VectorXd scaled(const DeviceModel& model, Eigen::VectorXd q) {
  for (int i = 0; i < model.dof(); ++i) {
    const auto it = model.links[i].effects.find("ratio");
    if (it != model.links[i].effects.end()) q[i] *= 1 + it->second;
  }
  return q;
}

TEST(JointEffect, ItMovesTheJointValueAsItsFeatureSays) {
  ASSERT_TRUE(kRegistered);
  const DeviceModel actual = ratio_arm(testing::panda_like(), 3);
  const PreparedModel with(actual), plain(without_effects(actual));
  std::mt19937_64 rng(5);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::VectorXd q = actual.draw_readings(rng);
    const Eigen::VectorXd s = scaled(actual, q);
    const Frame<double> a = with.forward(q.data()), b = plain.forward(s.data());
    EXPECT_LT((a.p - b.p).norm(), 1e-12);
    EXPECT_LT((a.R - b.R).norm(), 1e-12);
    EXPECT_LT((actual.compensate(q) - s).norm(), 1e-12);
    // The readings' Jacobian against central differences of compensate.
    const Eigen::MatrixXd D = actual.reading_jacobian(q);
    std::vector<double> prepared(actual.dof() * actual.dof());
    with.reading_jacobian(q.data(), prepared.data());
    for (int k = 0; k < actual.dof(); ++k) {
      Eigen::VectorXd plus = q, minus = q;
      plus[k] += 1e-6;
      minus[k] -= 1e-6;
      const Eigen::VectorXd numeric = (actual.compensate(plus) - actual.compensate(minus)) / 2e-6;
      EXPECT_LT((D.col(k) - numeric).norm(), 1e-8) << "reading " << k;
      for (int i = 0; i < actual.dof(); ++i)
        EXPECT_NEAR(prepared[k * actual.dof() + i], numeric[i], 1e-8) << k << " " << i;
    }
  }
}

TEST(JointEffect, DeviceFilesAndUrdfWriteItAndReadItBack) {
  ASSERT_TRUE(kRegistered);
  const DeviceModel actual = ratio_arm(testing::panda_like(), 7);
  const std::string yaml = device_to_yaml(actual);
  EXPECT_NE(yaml.find("ratio:"), std::string::npos);
  const DeviceModel back = parse_device(yaml, "back.yaml");
  for (int i = 0; i < actual.dof(); ++i)
    EXPECT_EQ(back.links[i].effects, actual.links[i].effects) << i;
  // A key no effect has, or a value beyond the effect's bound, is refused.
  std::string typo = yaml;
  typo.replace(typo.find("ratio:"), 6, "ratoi:");
  EXPECT_THROW(parse_device(typo, "typo.yaml"), InputError);
  DeviceModel wild = actual;
  wild.links[0].effects["ratio"] = 0.5;
  EXPECT_THROW(parse_device(device_to_yaml(wild), "wild.yaml"), InputError);
  // URDF: its element in each joint, read back to the same values.
  const std::string urdf = device_to_urdf(actual);
  EXPECT_NE(urdf.find("<hapticcal_effect name=\"ratio\""), std::string::npos);
  const DeviceModel from_urdf = parse_urdf(urdf, "back.urdf", "", "");
  for (int i = 0; i < actual.dof(); ++i) {
    ASSERT_EQ(from_urdf.links[i].effects.size(), 1u) << i;
    EXPECT_NEAR(from_urdf.links[i].effects.at("ratio"), actual.links[i].effects.at("ratio"), 1e-15);
  }
}

TEST(JointEffect, ASimulatedLogIsTheDeviceWithItsEffect) {
  ASSERT_TRUE(kRegistered);
  const DeviceModel actual = ratio_arm(testing::panda_like(), 9);
  SimulationNoise noise;
  noise.sigma_position = 0;
  const Log log = simulate_log(actual, 50, noise, 4, /*distance=*/false, /*position=*/true);
  const PreparedModel plain(without_effects(actual));
  for (int r = 0; r < log.rows; ++r) {
    const Eigen::VectorXd s = scaled(actual, log.q.row(r).transpose());
    EXPECT_LT((plain.forward(s.data()).p - log.position.row(r).transpose()).norm(), 1e-12) << r;
  }
  EXPECT_GT(evaluate(without_effects(actual), log).figure("position")->stats.rms, 1e-4);
}

TEST(JointEffect, CalibrateFitsItFoldsItAndItsFileScoresTheSame) {
  ASSERT_TRUE(kRegistered);
  const DeviceModel nominal = testing::panda_like();
  const DeviceModel actual = ratio_arm(nominal, 41);
  testing::HeldOutStudy data = testing::held_out_study(actual, 250, 20e-6, 43);
  for (Log* log : {&data.cal, &data.val}) {  // no external encoders
    log->has_ext.assign(log->dof(), false);
    log->ext.setZero();
  }
  CalibrationOptions options;
  options.joint_errors = {"ratio"};
  const CalibrationResult r = calibrate(nominal, data.cal, options);
  ASSERT_EQ(r.status, CalibrationStatus::kConverged) << r.status_reason;
  EXPECT_TRUE(r.calibrated.fitted.empty());
  const double held_out = evaluate(r.calibrated, data.val).figure("position")->stats.rms;
  std::printf("ratio effect: held-out %.4f mm (noise floor %.4f mm)\n", held_out * 1e3,
              data.floor * 1e3);
  EXPECT_LT(held_out, 1.2 * data.floor);
  int identified = 0;
  for (int i = 0; i < nominal.dof(); ++i) {
    const std::string name = nominal.links[i].name + ".ratio";
    const ParameterEstimate* e = testing::find_parameter(r.kinematics, name);
    ASSERT_NE(e, nullptr) << name;
    if (!e->identifiable) continue;
    ++identified;
    EXPECT_EQ(r.calibrated.links[i].effects.at("ratio"), e->value) << name;
    const double truth = actual.links[i].effects.at("ratio");
    EXPECT_LT(std::abs(e->value - truth), 3 * e->sd) << name << " " << e->value << " +- " << e->sd;
  }
  EXPECT_GE(identified, nominal.dof() - 1);
  // The calibrated model's file, loaded back, scores what the model in memory does.
  const std::string path =
      (std::filesystem::temp_directory_path() / "hapticcal_joint_effect_test.yaml").string();
  save_device(r.calibrated, path);
  const DeviceModel loaded = load_device(path);
  std::filesystem::remove(path);
  EXPECT_NEAR(evaluate(loaded, data.val).figure("position")->stats.rms, held_out, 1e-12);

  // The default's search offers it without being asked.
  const CalibrationResult found = calibrate(nominal, data.cal, {});
  ASSERT_EQ(found.status, CalibrationStatus::kConverged) << found.status_reason;
  const auto& families = found.kinematics.joint_error_families;
  EXPECT_NE(std::find(families.begin(), families.end(), "ratio"), families.end());
  EXPECT_LT(evaluate(found.calibrated, data.val).figure("position")->stats.rms, 1.2 * data.floor);
}

}  // namespace
}  // namespace hapticcal
