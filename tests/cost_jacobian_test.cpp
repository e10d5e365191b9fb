// The Ceres cost functions with hand-written Jacobians (step 1's fused capstan
// fit, step 2's distance and position measurements) against central differences
// of their own residuals, and the step-1 standard deviations against a Monte
// Carlo of the fit.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <random>

#include "hapticcal/identification/derivative_check.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/study/simulation.hpp"
#include "identification/families/family.hpp"
#include "identification/problem/capstan_cost.hpp"
#include "identification/problem/measurement_cost.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

using testing::perturbed;
using testing::random_readings;
using testing::source_path;

// Every device file shipped: data/devices/*.yaml and the Meca500 example.
std::vector<std::pair<std::string, DeviceModel>> devices() {
  std::vector<std::pair<std::string, DeviceModel>> out;
  for (const auto& entry : std::filesystem::directory_iterator(source_path("data/devices"))) {
    if (entry.path().extension() == ".yaml") {
      out.emplace_back(entry.path().stem().string(), load_device(entry.path().string()));
    }
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  out.emplace_back("meca500", testing::meca500());
  return out;
}

// A one-block cost's residuals and its analytic Jacobian (row-major from Ceres)
// at x.
struct Evaluation {
  Eigen::VectorXd r;
  Eigen::MatrixXd J;
};
Evaluation evaluate_cost(const ceres::CostFunction& cost, const Eigen::VectorXd& x) {
  const int m = cost.num_residuals();
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> J(m, x.size());
  Evaluation out{Eigen::VectorXd(m), {}};
  const double* params[] = {x.data()};
  double* jacobians[] = {J.data()};
  EXPECT_TRUE(cost.Evaluate(params, out.r.data(), jacobians));
  // Without a Jacobian the residuals are the same.
  Eigen::VectorXd r(m);
  EXPECT_TRUE(cost.Evaluate(params, r.data(), nullptr));
  EXPECT_EQ(r, out.r);
  out.J = J;
  return out;
}

// max over entries of |analytic - numeric| / (1 + |numeric|), numeric the
// central difference of the cost's residuals with per-parameter `steps`, and
// the column where it is largest.
DerivativeCheck check_cost_jacobian(const ceres::CostFunction& cost, const Eigen::VectorXd& x,
                                    const Eigen::VectorXd& steps,
                                    const std::vector<std::string>& names) {
  const Eigen::MatrixXd analytic = evaluate_cost(cost, x).J;
  const Eigen::MatrixXd numeric = central_difference(
      [&](const Eigen::VectorXd& p) {
        Eigen::VectorXd r(cost.num_residuals());
        const double* params[] = {p.data()};
        cost.Evaluate(params, r.data(), nullptr);
        return r;
      },
      x, steps);
  DerivativeCheck result;
  for (int k = 0; k < x.size(); ++k) {
    const double e =
        ((analytic.col(k) - numeric.col(k)).array().abs() / (1 + numeric.col(k).array().abs()))
            .maxCoeff();
    if (e > result.max_error) result = {e, names[k]};
  }
  return result;
}

// Step 1: d (c + dtheta(q; p) - target) / d [Re, ro, bo, ri, bi, c], eq. (1),
// on every capstan of every device, at random parameters with eccentricities
// up to 0.4 D, random readings within the joint's limits and random targets.
// Steps: 1e-6 for Re, the phases and c; 1e-6 D for the radii. Tolerance 1e-7
// relative to 1 + |numeric| (the numeric error is ~1e-9 here).
TEST(CostJacobian, CapstanCostMatchesCentralDifferencesOnEveryDevice) {
  const std::vector<std::string> names = {"Re", "r_out", "beta_out", "r_in", "beta_in", "c"};
  std::mt19937_64 rng(20240610);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  int checked = 0;
  for (const auto& [label, model] : devices()) {
    for (const Link& link : model.links) {
      const auto* nominal = std::get_if<Capstan>(&link.transmission.model());
      if (!nominal) continue;
      const double D = nominal->drum_distance;
      for (int trial = 0; trial < 20; ++trial) {
        SCOPED_TRACE(label + " " + link.name + " trial " + std::to_string(trial));
        const int n = 50;
        Eigen::VectorXd q(n), target(n);
        for (int i = 0; i < n; ++i) {
          q[i] = std::uniform_real_distribution<double>(link.lower, link.upper)(rng);
          target[i] = 0.05 * unit(rng);
        }
        Eigen::VectorXd x(6);
        x << 0.05 * unit(rng), 0.4 * D * unit(rng), std::numbers::pi * unit(rng),
            0.4 * D * unit(rng), std::numbers::pi * unit(rng), 0.01 * unit(rng);
        Eigen::VectorXd steps(6);
        steps << 1e-6, 1e-6 * D, 1e-6, 1e-6 * D, 1e-6, 1e-6;
        const detail::CapstanCost cost(*nominal, q, target);
        const DerivativeCheck c = check_cost_jacobian(cost, x, steps, names);
        EXPECT_LT(c.max_error, 1e-7) << c.worst;
        ++checked;
      }
    }
  }
  EXPECT_GE(checked, 120);  // 3 capstans on each of the two haptic devices
}

// A measurement of `type` off the tool frame by up to 1 mm (and 1 mrad).
template <typename Rng>
void measure(MeasurementType type, const Frame<double>& tool, Rng& rng, double* out) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  if (type == MeasurementType::kDistance) {  // one value
    out[0] = tool.p.norm() + 1e-3 * unit(rng);
    return;
  }
  for (int k = 0; k < 3; ++k) out[k] = tool.p[k] + 1e-3 * unit(rng);
  if (type == MeasurementType::kPose) {
    const Eigen::Vector3d w(1e-3 * unit(rng), 1e-3 * unit(rng), 1e-3 * unit(rng));
    const Eigen::Quaterniond q(Eigen::AngleAxisd(w.norm(), w.normalized()) * tool.R);
    out[3] = q.w();
    out[4] = q.x();
    out[5] = q.y();
    out[6] = q.z();
  }
}

constexpr MeasurementType kTypes[] = {MeasurementType::kDistance, MeasurementType::kPosition,
                                      MeasurementType::kPose};

// Step 2: d (predicted - measured) / d (all parameter slots), distances (paper
// eq. 5), positions and poses, on every device at random meaningful parameters (moved
// by up to 0.05 m or rad from the file's), random readings and measurements
// off the prediction by up to 1 mm. Steps 1e-6 (m or rad); tolerance 1e-7
// relative to 1 + |numeric|.
// `poses` random readings of `model` and a measurement of `type` of each (measure).
template <typename Rng>
void measure_poses(const DeviceModel& model, MeasurementType type, int poses, Rng& rng,
                   std::vector<Eigen::VectorXd>& joints, detail::RowMatrix& measured) {
  const ChainStructure s = model.structure();
  const Eigen::VectorXd params = model.kinematic_parameters();
  measured.resize(poses, traits(type).width);
  for (int i = 0; i < poses; ++i) {
    joints.push_back(random_readings(model, rng));
    measure(type, forward_kinematics(s, params.data(), joints[i].data()), rng,
            measured.row(i).data());
  }
}

// Each slot's parameter name ("slot k" for one without), for the derivative checks' reports.
std::vector<std::string> slot_names(const DeviceModel& model) {
  std::vector<std::string> names(model.structure().num_slots());
  for (size_t k = 0; k < names.size(); ++k) names[k] = "slot " + std::to_string(k);
  for (const ParameterInfo& info : model.parameter_info()) names[info.slot] = info.name;
  return names;
}

TEST(CostJacobian, MeasurementCostMatchesCentralDifferencesForEveryMeasurementType) {
  std::mt19937_64 rng(20240611);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (const auto& [label, file_model] : devices()) {
    for (const MeasurementType type : kTypes) {
      const detail::RowsOf kind{type, 0.3};
      const int d = kind.dimension();
      for (int trial = 0; trial < 5; ++trial) {
        SCOPED_TRACE(label + " " + traits(type).name + " trial " + std::to_string(trial));
        const DeviceModel model = perturbed(file_model, rng);
        const ChainStructure s = model.structure();
        const Eigen::VectorXd params = model.kinematic_parameters();
        const int poses = 20;
        std::vector<Eigen::VectorXd> joints;
        detail::RowMatrix measured;
        measure_poses(model, type, poses, rng, joints, measured);
        // Weighted rows (repeated poses) on odd trials.
        Eigen::VectorXd weights;
        if (trial % 2 == 1) weights = Eigen::VectorXd::LinSpaced(poses, 1.0, 2.0);
        const detail::MeasurementCost cost(s, joints, kind, measured, weights);
        ASSERT_EQ(cost.num_residuals(), poses * d);
        const DerivativeCheck c = check_cost_jacobian(
            cost, params, Eigen::VectorXd::Constant(params.size(), 1e-6), slot_names(model));
        EXPECT_LT(c.max_error, 1e-7) << c.worst;
        // The residuals are predicted - measured.
        const Evaluation e =
            evaluate_cost(detail::MeasurementCost(s, joints, kind, measured), params);
        const Frame<double> T0 = forward_kinematics(s, params.data(), joints[0].data());
        const Eigen::Vector3d p0 = T0.p;
        if (type == MeasurementType::kDistance) {
          EXPECT_NEAR(e.r[0], p0.norm() - measured(0, 0), 1e-15);
        } else {
          EXPECT_LT((e.r.head<3>() - (p0 - measured.row(0).head<3>().transpose())).norm(), 1e-15);
        }
        if (type ==
            MeasurementType::kPose) {  // 0.3 m/rad times the turn from measured to predicted
          const Eigen::Quaterniond qm(measured(0, 3), measured(0, 4), measured(0, 5),
                                      measured(0, 6));
          const Eigen::AngleAxisd turn(T0.R * qm.toRotationMatrix().transpose());
          EXPECT_LT((e.r.segment<3>(3) - 0.3 * turn.angle() * turn.axis()).norm(), 1e-12);
        }
      }
    }
  }
}

// A model's step-2 joint-error stages (`errors`) in the cost of 20 measured
// poses: their columns against central differences, and `folded` (the stages
// made part of the model) predicting the same rows through its compensate.
// The poses' values are readings, the cost's joint values those of the model
// `start` the stages were made from (StepTwoJoints) when one is given, else
// the readings themselves (with the stages' features after them).
template <typename Rng>
void expect_stage_rows(const DeviceModel& model, const DeviceModel& folded, MeasurementType type,
                       const std::vector<JointErrorStage>& errors, Rng& rng,
                       const DeviceModel* start = nullptr, bool directed = false) {
  const detail::RowsOf kind{type, 0.3, nullptr, &errors};
  const ChainStructure s = model.structure();
  const Eigen::VectorXd params = model.kinematic_parameters();
  const int poses = 20;
  std::vector<Eigen::VectorXd> readings;
  detail::RowMatrix measured;
  measure_poses(model, type, poses, rng, readings, measured);
  // Each joint's approach side (directed: -1, 0 or +1 at random).
  std::vector<Eigen::RowVectorXd> direction(poses);
  for (Eigen::RowVectorXd& d : direction) {
    if (!directed) continue;
    d.resize(model.dof());
    for (double& v : d) v = static_cast<double>(rng() % 3) - 1.0;
  }
  // The stages' features after the joint values (StepTwoJoints).
  std::vector<Eigen::VectorXd> joints = readings;
  const StepTwoJoints step_two(start ? *start : model);
  for (int i = 0; i < poses; ++i) {
    joints[i] = start ? step_two(readings[i], direction[i])
                      : step_two.with_features(readings[i], readings[i], direction[i]);
  }
  const detail::MeasurementCost cost(s, joints, kind, measured);
  const DerivativeCheck c = check_cost_jacobian(
      cost, params, Eigen::VectorXd::Constant(params.size(), 1e-6), slot_names(model));
  EXPECT_LT(c.max_error, 1e-7) << c.worst;
  const Eigen::VectorXd r = evaluate_cost(cost, params).r;
  const ChainStructure fs = folded.structure();
  const Eigen::VectorXd fp = folded.kinematic_parameters();
  for (int i = 0; i < poses; ++i) {
    Eigen::VectorXd moved = folded.compensate(readings[i]);
    folded.apply_backlash(direction[i], moved);
    Eigen::MatrixXd J(kind.dimension(), fs.num_slots());
    Eigen::VectorXd ri(kind.dimension());
    // A folded lateral compliance bends the links per pose (what the prepared
    // model does).
    const StepTwoJoints folded_values(folded);
    if (folded_values.bends()) {
      moved = folded_values.with_features(moved, readings[i], direction[i]);
    }
    detail::measurement_rows(fs, chain_constants(fs, fp.data()), fp.data(), moved.data(),
                             detail::RowsOf{type, 0.3, nullptr, nullptr, folded_values.bends()},
                             measured.row(i).data(), ri.data(), J);
    EXPECT_LT((ri - r.segment(i * kind.dimension(), kind.dimension())).norm(), 1e-12) << i;
  }
}

// Step 2's joint-error stages (issue 25): each turning joint's angle moved by
// harmonics of itself (frequencies 1, 2 and a motor's 10, 20) with random
// coefficients of up to 5 mrad; the cost's Jacobian, the stage parameters'
// columns included, against central differences, on every device and kind.
TEST(CostJacobian, JointErrorStagesMatchCentralDifferences) {
  std::mt19937_64 rng(20261202);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  int stages = 0;
  for (const auto& [label, file_model] : devices()) {
    for (const MeasurementType type : kTypes) {
      SCOPED_TRACE(label + " " + traits(type).name);
      DeviceModel model = perturbed(file_model, rng);
      model.joint_errors.assign(model.dof(), Transmission());
      for (int i = 0; i < model.dof(); ++i) {
        if (model.links[i].prismatic()) continue;
        // As calibrate offers them: none on a joint the coupling mixes (a stage
        // acts on the joint's own reading).
        if (model.coupled() && (model.coupling.row(i) != Eigen::RowVectorXd::Unit(model.dof(), i) ||
                                model.coupling.col(i) != Eigen::VectorXd::Unit(model.dof(), i)))
          continue;
        Harmonic h;
        h.frequencies = {1, 2, 10, 20};
        for (int k = 0; k < 8; ++k) h.coefficients.push_back(5e-3 * unit(rng));
        model.joint_errors[i] = Transmission(h);
      }
      model.fitted.push_back(detail::find_joint_error_family("harmonic")->block(model));
      const std::vector<JointErrorStage> errors = joint_error_stages(model);
      stages += static_cast<int>(errors.size());
      ASSERT_EQ(model.structure().errors, 8 * static_cast<int>(errors.size()));
      // The moved angle is the folded transmission's: a device whose links carry
      // the stages as transmissions predicts the same rows without them.
      DeviceModel folded = model;
      for (int i = 0; i < model.dof(); ++i) {
        if (!model.joint_errors[i].is_none()) folded.links[i].transmission = model.joint_errors[i];
      }
      folded.joint_errors.clear();
      folded.fitted.clear();
      // A coupled model's joint values are C q (StepTwoJoints), not the readings.
      expect_stage_rows(model, folded, type, errors, rng, model.coupled() ? &model : nullptr);
    }
  }
  EXPECT_GE(stages, 30);
}

// A device's perturbed model loaded by gravity: no transmissions or coupling,
// each link a mass of 0-2 kg at up to 5 cm from its frame and a random
// compliance of up to 1e-3 rad/N m in `field` (the joint's or the lateral).
template <typename Rng>
DeviceModel gravity_loaded(const DeviceModel& file_model, Rng& rng, double Link::*field) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  DeviceModel model = perturbed(file_model, rng);
  for (Link& l : model.links) {
    l.transmission = Transmission();
    l.mass = 1 + unit(rng);
    l.com = 0.05 * Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
    l.*field = 1e-3 * unit(rng);
  }
  model.coupling.resize(0, 0);
  return model;
}

// The compliance family's stages (issue 25, item 2a): one parameter k a joint,
// its column the joint's gravity torque (fixed at the start's geometry) times
// the joint value's, against central differences; and the fitted k, made the
// links' compliance, predicts the same rows through DeviceModel::compensate.
TEST(CostJacobian, ComplianceStagesMatchCentralDifferences) {
  std::mt19937_64 rng(20261203);
  int stages = 0;
  for (const auto& [label, file_model] : devices()) {
    for (const MeasurementType type : kTypes) {
      SCOPED_TRACE(label + " " + traits(type).name);
      DeviceModel model = gravity_loaded(file_model, rng, &Link::compliance);
      model.fitted.push_back(detail::find_joint_error_family("compliance")->block(model));
      const std::vector<JointErrorStage> errors = joint_error_stages(model);
      stages += static_cast<int>(errors.size());
      ASSERT_EQ(static_cast<int>(errors.size()), model.dof());
      ASSERT_EQ(model.structure().errors, model.dof());
      DeviceModel folded = model;
      folded.fitted.clear();
      expect_stage_rows(model, folded, type, errors, rng);
    }
  }
  EXPECT_GE(stages, 30);
}

// The lateral family's stages: one parameter kx a joint, moving the joint's
// alpha (URDF: roll) by kx tau_x, its column tau_x (fixed at the start's
// geometry) times the alpha / roll column, against central differences; the
// fitted kx, made the links' lateral compliance, predicts the same rows with
// the links bent per pose. And a lateral compliance step 2 holds (not fitted):
// the rows with each pose's links bent, against central differences.
TEST(CostJacobian, LateralStagesMatchCentralDifferences) {
  std::mt19937_64 rng(20261204);
  int stages = 0;
  for (const auto& [label, file_model] : devices()) {
    for (const MeasurementType type : kTypes) {
      SCOPED_TRACE(label + " " + traits(type).name);
      DeviceModel model = gravity_loaded(file_model, rng, &Link::lateral_compliance);
      DeviceModel held = model;
      model.fitted.push_back(detail::find_joint_error_family("lateral")->block(model));
      const std::vector<JointErrorStage> errors = joint_error_stages(model);
      stages += static_cast<int>(errors.size());
      ASSERT_EQ(static_cast<int>(errors.size()), model.dof());
      for (const JointErrorStage& e : errors) ASSERT_TRUE(e.geometry);
      DeviceModel folded = model;
      folded.fitted.clear();
      expect_stage_rows(model, folded, type, errors, rng);

      // Held: no stage, each pose's links bent by the model's own compliance.
      ASSERT_TRUE(held.laterally_compliant());
      const StepTwoJoints step_two(held);
      ASSERT_EQ(step_two.bends(), held.dof());
      const detail::RowsOf kind{type, 0.3, nullptr, nullptr, step_two.bends()};
      std::vector<Eigen::VectorXd> readings;
      detail::RowMatrix measured;
      measure_poses(held, type, 10, rng, readings, measured);
      for (Eigen::VectorXd& values : readings) values = step_two(values, Eigen::RowVectorXd());
      const detail::MeasurementCost cost(held.structure(), readings, kind, measured);
      const Eigen::VectorXd params = held.kinematic_parameters();
      const DerivativeCheck c = check_cost_jacobian(
          cost, params, Eigen::VectorXd::Constant(params.size(), 1e-6), slot_names(held));
      EXPECT_LT(c.max_error, 1e-7) << c.worst;
    }
  }
  EXPECT_GE(stages, 30);
}

// The coupling family's stages (--joint-errors coupling): each declared
// coefficient C_ik between two joints a parameter, its column the reading u_k
// (through its own transmission) times joint i's value column, against central
// differences; the fitted coefficients, made the model's coupling, predict the
// same rows through DeviceModel::compensate.
TEST(CostJacobian, CouplingStagesMatchCentralDifferences) {
  std::mt19937_64 rng(20261204);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  int stages = 0;
  for (const auto& [label, file_model] : devices()) {
    for (const MeasurementType type : kTypes) {
      SCOPED_TRACE(label + " " + traits(type).name);
      DeviceModel start = perturbed(file_model, rng);
      const int n = start.dof();
      start.coupling = Eigen::MatrixXd::Identity(n, n);
      for (int i = 1; i < n; ++i) start.coupling(i, i - 1) = unit(rng);
      start.coupling(0, n - 1) = unit(rng);
      start.fitted.push_back(detail::find_joint_error_family("coupling")->block(start));
      const std::vector<JointErrorStage> errors = joint_error_stages(start);
      stages += static_cast<int>(errors.size());
      ASSERT_EQ(static_cast<int>(errors.size()), n);
      ASSERT_EQ(start.structure().errors, n);
      DeviceModel model = start;
      for (const auto& c : start.fitted[0].parameters)
        model.coupling(c.link, c.element) += 0.05 * unit(rng);
      DeviceModel folded = model;
      folded.fitted.clear();
      expect_stage_rows(model, folded, type, errors, rng, &start);
    }
  }
  EXPECT_GE(stages, 30);
}

// Backlash (issue 25, --joint-errors backlash): each joint's value moved by its
// backlash times the side it approached from (-1, 0, +1); the start's backlash
// of up to 1 mrad (1 mm) is in the joint values, the fit's differs by up to 0.5.
// The cost's Jacobian against central differences on every device and kind,
// and the fitted values as the links' backlash give the same rows.
TEST(CostJacobian, BacklashStagesMatchCentralDifferences) {
  std::mt19937_64 rng(20261205);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  int stages = 0;
  for (const auto& [label, file_model] : devices()) {
    for (const MeasurementType type : kTypes) {
      SCOPED_TRACE(label + " " + traits(type).name);
      DeviceModel start = perturbed(file_model, rng);
      for (int i = 0; i < start.dof(); ++i) {
        start.links[i].backlash = 1e-3 * unit(rng);
      }
      start.fitted.push_back(detail::find_joint_error_family("backlash")->block(start));
      const std::vector<JointErrorStage> errors = joint_error_stages(start);
      stages += static_cast<int>(errors.size());
      ASSERT_EQ(static_cast<int>(errors.size()), start.dof());
      ASSERT_EQ(start.structure().errors, start.dof());
      DeviceModel model = start;
      for (Link& l : model.links) l.backlash += 5e-4 * unit(rng);
      DeviceModel folded = model;
      folded.fitted.clear();
      expect_stage_rows(model, folded, type, errors, rng, &start, /*directed=*/true);
    }
  }
  EXPECT_GE(stages, 30);
}

// The standard deviations fit_transmission reports for a capstan (s^2 (J^T J)^-1
// with the analytic Jacobian) are what the estimates actually scatter by: over
// 500 seeded simulations of the paper's capstans 1-3 (Table 2, R = 10, D = 5 mm)
// with 200 readings each and external-encoder noise sigma_e = 2 pi / 20000 / 3,
// the mean reported sd of Re, r_out, beta_out, r_in, beta_in and c is within 15 %
// of the RMS error about the truth. With 500 trials the RMSE itself is known to
// about 1 / sqrt(1000) = 3 % (3000 trials give ratios of 0.98-1.02).
// The compressed cost's Jacobian R is not the derivative of its residuals [c; e]
// (Q moves with the parameters): what LM uses from it must be the full cost's.
// R^T R = J^T J, R^T c = J^T r and |[c; e]|^2 = |r|^2, J and r from MeasurementCost
// (checked against central differences above), over several 256-pose blocks.
TEST(CostJacobian, CompressedMeasurementCostGivesTheFullGaussNewtonSystem) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (const auto& [label, file_model] : devices()) {
    for (const MeasurementType type : kTypes) {
      SCOPED_TRACE(label + " " + traits(type).name);
      const detail::RowsOf kind{type, 0.3};
      const DeviceModel model = perturbed(file_model, rng);
      const ChainStructure s = model.structure();
      const Eigen::VectorXd params = model.kinematic_parameters();
      const int poses = 700, n = s.num_slots();
      std::vector<Eigen::VectorXd> joints;
      detail::RowMatrix measured(poses, traits(type).width);
      for (int i = 0; i < poses; ++i) {
        joints.push_back(random_readings(model, rng));
        measure(type, forward_kinematics(s, params.data(), joints[i].data()), rng,
                measured.row(i).data());
      }
      // Repeat counts 1-4: rows weighted by their square roots.
      Eigen::VectorXd weights(poses);
      for (int i = 0; i < poses; ++i) weights[i] = std::sqrt(1.0 + (i % 4));
      const Evaluation full =
          evaluate_cost(detail::MeasurementCost(s, joints, kind, measured, weights), params);
      const detail::CompressedMeasurementCost compressed(s, joints, kind, measured, weights);
      ASSERT_EQ(compressed.num_residuals(), n + 1);
      Eigen::VectorXd z(n + 1), z_cost(n + 1);
      detail::RowMatrix Z(n + 1, n);
      const double* x[] = {params.data()};
      double* jac[] = {Z.data()};
      ASSERT_TRUE(compressed.Evaluate(x, z.data(), jac));
      ASSERT_TRUE(compressed.Evaluate(x, z_cost.data(), nullptr));
      const Eigen::MatrixXd JtJ = full.J.transpose() * full.J;
      const Eigen::VectorXd Jtr = full.J.transpose() * full.r;
      EXPECT_LT((Z.transpose() * Z - JtJ).norm(), 1e-12 * JtJ.norm());
      EXPECT_LT((Z.transpose() * z - Jtr).norm(), 1e-12 * (JtJ.norm() * full.r.norm()));
      EXPECT_NEAR(z.squaredNorm(), full.r.squaredNorm(), 1e-12 * full.r.squaredNorm());
      EXPECT_NEAR(z_cost.squaredNorm(), full.r.squaredNorm(), 1e-12 * full.r.squaredNorm());
      EXPECT_TRUE(Z.row(n).isZero());
    }
  }
}

TEST(CostJacobian, CapstanReportedSdMatchesMonteCarloRmseWithin15Percent) {
  const DeviceModel actual = paper_actual_device(testing::builtin("baser-7dof"));
  constexpr int kTrials = 500, kSamples = 200;
  const std::vector<std::string> names = {"Re", "r_out", "beta_out", "r_in", "beta_in", "c"};
  for (int joint = 0; joint < 3; ++joint) {
    const Link& link = actual.links[joint];
    const Eigen::VectorXd tp = link.transmission.parameters();
    Eigen::VectorXd truth(6);
    truth << tp, 1e-3 * (joint + 1);  // simulate_log's encoder zeros
    Eigen::VectorXd sum_sd = Eigen::VectorXd::Zero(6), sum_sq = Eigen::VectorXd::Zero(6);
    std::mt19937_64 rng(1000 + joint);
    std::normal_distribution<double> gauss(0.0, 1.0);
    for (int trial = 0; trial < kTrials; ++trial) {
      Eigen::VectorXd q(kSamples), ext(kSamples);
      for (int i = 0; i < kSamples; ++i) {
        q[i] = std::uniform_real_distribution<double>(link.lower, link.upper)(rng);
        ext[i] = q[i] + link.transmission.error(q[i]) + truth[5] + kPaperSigmaE * gauss(rng);
      }
      TransmissionFit fit;
      fit_transmission(actual, joint, q, ext, std::nullopt, fit);
      ASSERT_EQ(fit.kind, TransmissionKind::kCapstan);
      ASSERT_TRUE(fit.converged) << fit.message;
      Eigen::VectorXd value(6), sd(6);
      value << fit.value, fit.offset;
      sd << fit.sd, fit.offset_sd;
      Eigen::VectorXd error = value - truth;
      for (int k : {2, 4}) error[k] = std::remainder(error[k], 2 * std::numbers::pi);
      sum_sd += sd;
      sum_sq += error.cwiseAbs2();
    }
    for (int k = 0; k < 6; ++k) {
      const double mean_sd = sum_sd[k] / kTrials, rmse = std::sqrt(sum_sq[k] / kTrials);
      std::printf("%s.%-8s mean sd / RMSE %.3f\n", link.name.c_str(), names[k].c_str(),
                  mean_sd / rmse);
      EXPECT_LT(std::abs(mean_sd / rmse - 1), 0.15)
          << link.name << "." << names[k] << ": mean sd " << mean_sd << ", RMSE " << rmse;
    }
  }
}

// rotation_log against Eigen's AngleAxis, near 0, in between and near pi (where
// sin(a) carries no axis): the angle and the axis, for random axes.
TEST(CostJacobian, RotationLogMatchesAngleAxisUpToPi) {
  std::mt19937_64 rng(9);
  std::normal_distribution<double> n(0, 1);
  for (const double angle : {0.0, 1e-9, 1e-3, 1.0, 3.0, M_PI - 1e-5, M_PI - 1e-9, M_PI}) {
    for (int trial = 0; trial < 20; ++trial) {
      const Eigen::Vector3d axis = Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
      const Eigen::Matrix3d R = Eigen::AngleAxisd(angle, axis).toRotationMatrix();
      const Eigen::Vector3d phi = rotation_log(R);
      SCOPED_TRACE(angle);
      EXPECT_NEAR(phi.norm(), angle, 1e-8);
      // The same rotation (at pi, u and -u are one).
      EXPECT_LT((Eigen::AngleAxisd(phi.norm(), phi.normalized()).toRotationMatrix() - R).norm() *
                    (angle > 0),
                1e-8);
    }
  }
}

}  // namespace
}  // namespace hapticcal
