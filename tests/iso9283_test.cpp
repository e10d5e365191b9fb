// ISO 9283's pose and distance characteristics (study/iso9283.hpp) against an
// implementation written here from the standard's formulas (clauses 7.2.1,
// 7.2.2, 7.3.1, 7.3.2): the means and sample deviations summed in one pass,
// the angles a, b, c read from the matrix elements (R = Rz(c) Ry(b) Rx(a)),
// each attained angle taken relative to the commanded one by adding or
// subtracting 2 pi until it lies in (-pi, pi].
#include "hapticcal/study/iso9283.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <random>
#include <sstream>

#include "hapticcal/core/error.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/identification/information.hpp"
#include "hapticcal/identification/two_step.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/model_io/model_source.hpp"
#include "hapticcal/study/iso9283_cube.hpp"
#include "hapticcal/study/simulation.hpp"
#include "hapticcal/study/study.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

constexpr double kPi = std::numbers::pi;

Eigen::Matrix3d rotation(double a, double b, double c) {
  return (Eigen::AngleAxisd(c, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(b, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(a, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

// a, b, c of R = Rz(c) Ry(b) Rx(a) from its elements.
Eigen::Vector3d abc(const Eigen::Matrix3d& R) {
  return {std::atan2(R(2, 1), R(2, 2)), std::asin(-R(2, 0)), std::atan2(R(1, 0), R(0, 0))};
}

double relative(double angle, double commanded) {
  double d = angle - commanded;
  while (d > kPi) d -= 2 * kPi;
  while (d <= -kPi) d += 2 * kPi;
  return d;
}

// mean and 3 x the sample sd of values, in one pass: sums of the values and
// their squares, shifted by the first value (which keeps the difference of
// the sums exact enough).
std::pair<double, double> mean_and_three_s(const std::vector<double>& v) {
  const double shift = v.front();
  double s = 0, s2 = 0;
  for (double x : v) {
    s += x - shift;
    s2 += (x - shift) * (x - shift);
  }
  const double n = static_cast<double>(v.size());
  return {shift + s / n, 3 * std::sqrt(std::max(0.0, (s2 - s * s / n) / (n - 1)))};
}

IsoPoseRuns runs(std::mt19937_64& rng, const std::string& label, int cycles, double scatter,
                 const Eigen::Vector3d& commanded_abc, const std::vector<int>& missing = {}) {
  std::normal_distribution<double> g(0, 1);
  IsoPoseRuns r;
  r.label = label;
  r.orientation = true;
  r.commanded = {rotation(commanded_abc[0], commanded_abc[1], commanded_abc[2]),
                 Eigen::Vector3d(g(rng), g(rng), g(rng)) * 0.3};
  const Eigen::Vector3d bias(g(rng) * 1e-4, g(rng) * 1e-4, g(rng) * 1e-4);
  const Eigen::Vector3d turn(g(rng) * 1e-3, g(rng) * 1e-3, g(rng) * 1e-3);
  for (int j = 1; j <= cycles; ++j) {
    if (std::find(missing.begin(), missing.end(), j) != missing.end()) continue;
    const Eigen::Vector3d angles =
        commanded_abc + turn + Eigen::Vector3d(g(rng), g(rng), g(rng)) * scatter * 10;
    r.cycles.push_back(j);
    r.attained.push_back(
        {rotation(angles[0], angles[1], angles[2]),
         r.commanded.p + bias + Eigen::Vector3d(g(rng), g(rng), g(rng)) * scatter});
  }
  return r;
}

void check_pose(const IsoPoseRuns& r) {
  const IsoPoseCriteria c = iso_pose_criteria(r);
  const int n = static_cast<int>(r.attained.size());
  ASSERT_EQ(c.cycles, n);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int k = 0; k < 3; ++k) {
    std::vector<double> v;
    for (const Frame<double>& f : r.attained) v.push_back(f.p[k]);
    mean[k] = mean_and_three_s(v).first;
    EXPECT_NEAR(c.ap_xyz[k], mean[k] - r.commanded.p[k], 1e-12);  // AP_x = x_mean - x_c
  }
  EXPECT_NEAR(c.ap, (mean - r.commanded.p).norm(), 1e-12);  // AP_P
  std::vector<double> l;
  for (const Frame<double>& f : r.attained) l.push_back((f.p - mean).norm());
  const auto [l_mean, three_s_l] = mean_and_three_s(l);
  EXPECT_NEAR(c.rp, l_mean + three_s_l, 1e-12);  // RP_l = l_mean + 3 S_l
  const Eigen::Vector3d commanded = abc(r.commanded.R);
  for (int k = 0; k < 3; ++k) {
    std::vector<double> v;
    for (const Frame<double>& f : r.attained) v.push_back(relative(abc(f.R)[k], commanded[k]));
    const auto [m, three_s] = mean_and_three_s(v);
    EXPECT_NEAR(c.ap_abc[k], m, 1e-12);        // AP_a = a_mean - a_c
    EXPECT_NEAR(c.rp_abc[k], three_s, 1e-12);  // RP_a = 3 S_a
  }
}

TEST(Iso9283, PoseCriteriaFollowTheStandardsFormulas) {
  std::mt19937_64 rng(1);
  check_pose(runs(rng, "P1", 30, 2e-5, {0.3, -0.2, 1.1}));             // the standard's 30 cycles
  check_pose(runs(rng, "P2", 5, 2e-5, {-1.0, 0.4, -2.0}));             // fewer
  check_pose(runs(rng, "P3", 30, 2e-5, {0.1, 0.2, 0.3}, {4, 9, 17}));  // some absent
}

// Near +-pi the attained angles fall on both sides of the wrap: their mean is
// still the small turn about the commanded one, not an angle near 0.
TEST(Iso9283, OrientationNearPiIsNotSplitAcrossTheWrap) {
  std::mt19937_64 rng(2);
  for (const Eigen::Vector3d commanded :
       {Eigen::Vector3d(kPi - 1e-4, 0.1, 0.2), Eigen::Vector3d(0.2, 0.1, -kPi + 1e-4),
        Eigen::Vector3d(kPi, 0.0, kPi)}) {
    const IsoPoseRuns r = runs(rng, "P1", 30, 2e-5, commanded);
    check_pose(r);
    const IsoPoseCriteria c = iso_pose_criteria(r);
    EXPECT_LT(c.ap_abc.cwiseAbs().maxCoeff(), 0.01);
    EXPECT_LT(c.rp_abc.maxCoeff(), 0.01);
  }
}

TEST(Iso9283, DistanceCriteriaPairTheCyclesThatAttainedBoth) {
  std::mt19937_64 rng(3);
  const IsoPoseRuns p1 = runs(rng, "P1", 30, 2e-5, {0, 0, 0}, {3});
  const IsoPoseRuns p2 = runs(rng, "P2", 30, 2e-5, {0, 0, 0}, {3, 7, 21});
  const IsoDistanceCriteria d = iso_distance_criteria(p1, p2);
  std::vector<double> distances;
  for (size_t i = 0; i < p1.cycles.size(); ++i) {
    for (size_t j = 0; j < p2.cycles.size(); ++j) {
      if (p1.cycles[i] == p2.cycles[j])
        distances.push_back((p1.attained[i].p - p2.attained[j].p).norm());
    }
  }
  ASSERT_EQ(d.cycles, 27);
  ASSERT_EQ(distances.size(), 27u);
  const auto [mean, three_s] = mean_and_three_s(distances);
  const double commanded = (p1.commanded.p - p2.commanded.p).norm();
  EXPECT_NEAR(d.commanded, commanded, 1e-12);
  EXPECT_NEAR(d.ad, mean - commanded, 1e-12);  // AD = D_mean - D_c
  EXPECT_NEAR(d.rd, three_s, 1e-12);           // RD = 3 S_D
  const IsoCriteria all = iso_criteria({p1, p2, runs(rng, "P3", 30, 2e-5, {0, 0, 0})});
  ASSERT_EQ(all.poses.size(), 3u);
  EXPECT_EQ(all.distances[0].from, "P1");
  ASSERT_EQ(all.distances.size(), 2u);
  EXPECT_EQ(all.distances[1].to, "P3");
}

TEST(Iso9283, OneCycleHasNoRepeatability) {
  std::mt19937_64 rng(4);
  const IsoPoseCriteria c = iso_pose_criteria(runs(rng, "P1", 1, 2e-5, {0, 0, 0}));
  EXPECT_EQ(c.cycles, 1);
  EXPECT_TRUE(std::isfinite(c.ap));
  EXPECT_TRUE(std::isnan(c.rp));
  EXPECT_TRUE(std::isnan(c.rp_abc[0]));
  const IsoPoseCriteria none = iso_pose_criteria({});
  EXPECT_EQ(none.cycles, 0);
  EXPECT_TRUE(std::isnan(none.ap));
}

// The test cube of a 6R and a 7R arm: its five poses within the joint limits,
// the plan's readings reproducing them by forward kinematics, P1 the centre
// and P2 .. P5 at 10 % of the measuring plane's diagonal from its corners.
void check_cube(const DeviceModel& model) {
  const IsoCubePlan plan = plan_iso_cube(model);
  ASSERT_EQ(plan.poses.size(), 5u);
  ASSERT_EQ(plan.corners.size(), 8u);
  EXPECT_GT(plan.size, 0.02);
  EXPECT_TRUE(plan.orientation_held);
  std::printf("%s: cube edge %.1f mm about (%.1f, %.1f, %.1f) mm\n", model.name.c_str(),
              plan.size * 1e3, plan.centre.x() * 1e3, plan.centre.y() * 1e3, plan.centre.z() * 1e3);
  const PreparedModel prepared(model);
  for (const IsoTestPose& p : plan.poses) {
    SCOPED_TRACE(p.label);
    for (int i = 0; i < model.dof(); ++i) {
      EXPECT_GE(p.readings[i], model.links[i].lower);
      EXPECT_LE(p.readings[i], model.links[i].upper);
    }
    const Frame<double> reached = prepared.forward(p.readings.data());
    EXPECT_LT((reached.p - p.pose.p).norm(), 1e-9);
    EXPECT_LT((reached.R - plan.poses[0].pose.R).norm(), 1e-9);  // the centre's orientation
  }
  // The corners from the cube's definition, independently: edges along the
  // base frame's axes, C1 .. C8 bottom then top face.
  const Eigen::Vector3d c = plan.centre;
  const double h = plan.size / 2;
  const auto at = [&](double x, double y, double z) {
    return Eigen::Vector3d(c + plan.axes * Eigen::Vector3d(x * h, y * h, z * h));
  };
  const Eigen::Vector3d c1 = at(-1, -1, -1), c2 = at(1, -1, -1), c7 = at(1, 1, 1),
                        c8 = at(-1, 1, 1);
  EXPECT_LT((plan.corners[0] - c1).norm(), 1e-12);
  EXPECT_LT((plan.corners[6] - c7).norm(), 1e-12);
  const double diagonal = (c7 - c1).norm();
  EXPECT_NEAR(diagonal, plan.size * std::sqrt(3.0), 1e-12);
  EXPECT_LT((plan.poses[0].pose.p - c).norm(), 1e-12);
  const Eigen::Vector3d corners[4] = {c1, c2, c7, c8};
  const Eigen::Vector3d opposite[4] = {c7, c8, c1, c2};
  for (int k = 0; k < 4; ++k) {
    EXPECT_NEAR((plan.poses[k + 1].pose.p - corners[k]).norm(), 0.1 * diagonal, 1e-12);
    EXPECT_LT((plan.poses[k + 1].pose.p - (0.9 * corners[k] + 0.1 * opposite[k])).norm(), 1e-12);
  }
  // Each pose away from singularities: the smallest singular value of the
  // Jacobian by the readings (rotation rows at 0.1 m/rad), by central differences.
  for (const IsoTestPose& p : plan.poses) {
    Eigen::MatrixXd J(6, model.dof());
    for (int i = 0; i < model.dof(); ++i) {
      Eigen::VectorXd up = p.readings, down = p.readings;
      up[i] += 1e-6, down[i] -= 1e-6;
      const Frame<double> a = prepared.forward(up.data()), b = prepared.forward(down.data());
      J.col(i).head<3>() = (a.p - b.p) / 2e-6;
      const Eigen::AngleAxisd turn(Eigen::Matrix3d(a.R * b.R.transpose()));
      J.col(i).tail<3>() = 0.1 * turn.angle() * turn.axis() / 2e-6;
    }
    EXPECT_GE(Eigen::JacobiSVD<Eigen::MatrixXd>(J).singularValues().minCoeff(),
              0.999 * kIsoAwayFromSingular)
        << p.label;
  }
  // The eight corners within reach: each one's position reached within the limits.
  for (const Eigen::Vector3d& corner : plan.corners) {
    EXPECT_TRUE(
        reach_pose(model, plan.poses[0].readings, {Eigen::Matrix3d::Identity(), corner}, false))
        << corner.transpose();
  }
  // A larger cube about the same centre at the same orientation does not fit.
  IsoCubeOptions larger;
  larger.centre = plan.centre;
  larger.orientation = plan.poses[0].pose.R;
  larger.size = plan.size + 2e-4;
  EXPECT_THROW(plan_iso_cube(model, larger), InputError);
}

TEST(Iso9283, TestCubeOfA6RAndA7RArmLiesWithinTheJointLimits) {
  check_cube(testing::meca500());
  check_cube(testing::panda_like());
}

// The standard's cube: the largest in the workspace. The Meca500 example's and
// a 7R arm's with the iiwa14's joint origins and limits, against the planner
// itself given 40 other centres (the tool points of readings drawn with
// another seed): none more than 10 % larger.
void check_largest(const std::string& file, double at_least) {
  const DeviceModel model = load_model(testing::source_path(file));
  const IsoCubePlan plan = plan_iso_cube(model);
  std::printf("%s: default cube %.1f mm (%s)\n", model.name.c_str(), plan.size * 1e3,
              iso_search_text(plan.search).c_str());
  EXPECT_GE(plan.size, at_least);
  EXPECT_FALSE(plan.search.centre_given);
  EXPECT_FALSE(plan.search.stopped.empty());
  const PreparedModel prepared(model);
  for (const IsoTestPose& p : plan.poses)
    EXPECT_LT((prepared.forward(p.readings.data()).p - p.pose.p).norm(), 1e-9) << p.label;
  std::mt19937_64 rng(59);
  double largest_other = 0;
  for (int trial = 0; trial < 40; ++trial) {
    Eigen::VectorXd q(model.dof());
    for (int i = 0; i < model.dof(); ++i) {
      q[i] =
          std::uniform_real_distribution<double>(model.links[i].lower, model.links[i].upper)(rng);
    }
    IsoCubeOptions given;
    given.centre = prepared.forward(q.data()).p;
    given.draws = 64;
    given.seed = 100 + trial;
    try {
      largest_other = std::max(largest_other, plan_iso_cube(model, given).size);
    } catch (const InputError&) {  // no cube of 10 mm about that centre
    }
  }
  std::printf("  the largest of 40 other centres: %.1f mm\n", largest_other * 1e3);
  EXPECT_GT(largest_other, 0);
  EXPECT_LE(largest_other, 1.1 * plan.size);
}

TEST(Iso9283, TheDefaultCubeIsTheLargestTheWorkspaceHolds) {
  check_largest("examples/meca500/meca500.yaml", 0.150);
  check_largest("tests/data/iiwa14.yaml", 0.500);
}

// A simulated 6R arm with geometric errors, calibrated on 100 tracker
// positions, then put through the ISO test at its cube's five poses (30
// cycles, 10 um attained-pose scatter). Over 30 calibrations: AP falls from the
// nominal model's to within 10 % of the calibration's own prediction,
// sqrt(trace(J C J^T) + 3 sigma^2 / n) (J the position's derivatives by the
// identified parameters, C their covariance); RP is the robot's and the same
// for both models.
TEST(Iso9283, CalibrationBringsApToItsPredictionAndLeavesRpAlone) {
  const DeviceModel nominal = testing::meca500();
  const IsoCubePlan plan = plan_iso_cube(nominal);
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  DeviceModel truth = nominal;
  Eigen::VectorXd values = truth.kinematic_parameters();
  for (const ParameterInfo& info : truth.parameter_info())
    values[info.slot] += u(rng) * (info.unit == ParameterUnit::kLength ? 5e-4 : 5e-3);
  truth.set_kinematic_parameters(values);
  const PreparedModel actual(truth), before(nominal);
  constexpr double kScatter = 1e-5;
  constexpr int kCycles = 30, kTrials = 30;
  CalibrationOptions options;
  options.search = false;
  options.keep_all = true;
  double ap2_nominal = 0, ap2_calibrated = 0, predicted2 = 0;
  int terms = 0;
  for (int trial = 0; trial < kTrials; ++trial) {
    SimulationNoise noise;
    noise.sigma_position = 2e-5;
    const Log cal = simulate_log(truth, 100, noise, 100 + trial, false, true);
    const CalibrationResult result = calibrate(nominal, cal, options);
    ASSERT_EQ(result.status, CalibrationStatus::kConverged);
    const KinematicFit& fit = result.kinematics;
    std::vector<int> slots;
    std::vector<double> sd;
    for (const std::string& name : fit.identified_names) {
      for (const ParameterEstimate& e : fit.parameters) {
        if (e.name == name) slots.push_back(e.slot), sd.push_back(e.sd);
      }
    }
    const int n = static_cast<int>(slots.size());
    Eigen::MatrixXd covariance(n, n);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) covariance(i, j) = sd[i] * sd[j] * fit.correlation(i, j);
    const PreparedModel after(result.calibrated);
    // The ISO test: the poses' readings, the attained positions scattered.
    std::normal_distribution<double> g(0, kScatter);
    std::vector<IsoPoseRuns> runs_nominal, runs_calibrated;
    for (const IsoTestPose& pose : plan.poses) {
      IsoPoseRuns r;
      r.label = pose.label;
      const Eigen::Vector3d at = actual.forward(pose.readings.data()).p;
      for (int j = 1; j <= kCycles; ++j) {
        r.cycles.push_back(j);
        r.attained.push_back(
            {Eigen::Matrix3d::Identity(), at + Eigen::Vector3d(g(rng), g(rng), g(rng))});
      }
      r.commanded = before.forward(pose.readings.data());
      runs_nominal.push_back(r);
      r.commanded = after.forward(pose.readings.data());
      runs_calibrated.push_back(r);
      // The prediction: the position's covariance through the identified parameters.
      Eigen::MatrixXd J(3, n);
      const Eigen::VectorXd p = result.calibrated.kinematic_parameters();
      for (int i = 0; i < n; ++i) {
        DeviceModel moved = result.calibrated;
        Eigen::VectorXd shifted = p;
        shifted[slots[i]] += 1e-7;
        moved.set_kinematic_parameters(shifted);
        J.col(i) = (PreparedModel(moved).forward(pose.readings.data()).p - r.commanded.p) / 1e-7;
      }
      predicted2 += (J * covariance * J.transpose()).trace() + 3 * kScatter * kScatter / kCycles;
    }
    const IsoCriteria a = iso_criteria(runs_nominal), b = iso_criteria(runs_calibrated);
    for (size_t k = 0; k < a.poses.size(); ++k) {
      ap2_nominal += a.poses[k].ap * a.poses[k].ap;
      ap2_calibrated += b.poses[k].ap * b.poses[k].ap;
      EXPECT_EQ(a.poses[k].rp, b.poses[k].rp);  // the robot's, not the model's
      EXPECT_NEAR(a.poses[k].rp, kScatter * 3.6,
                  kScatter * 1.5);  // about l + 3 S_l of a 3-D scatter
      ++terms;
    }
  }
  const double nominal_ap = std::sqrt(ap2_nominal / terms),
               calibrated_ap = std::sqrt(ap2_calibrated / terms),
               predicted_ap = std::sqrt(predicted2 / terms);
  std::printf(
      "AP (RMS over %d poses and calibrations): nominal %.4f mm, calibrated %.4f mm, "
      "predicted %.4f mm\n",
      terms, nominal_ap * 1e3, calibrated_ap * 1e3, predicted_ap * 1e3);
  EXPECT_GT(nominal_ap, 10 * calibrated_ap);
  EXPECT_NEAR(calibrated_ap / predicted_ap, 1.0, 0.10);
}

// The command line: plan --iso9283 writes the plan, a test log follows it row
// by row, evaluate --iso9283 scores the model and the reference as the
// library does; a log that does not follow the plan is refused in one line.
TEST(Iso9283, PlanThenEvaluateOnTheCommandLine) {
  const std::string dir = testing::fresh_folder("iso9283_cli");
  const std::string model = testing::source_path("examples/meca500/meca500.yaml");
  const auto planned = testing::run_cli(
      {"plan", "--model", model, "--iso9283", "--cycles", "5", "--out", dir + "/plan"});
  ASSERT_EQ(planned.exit_code, 0) << planned.err;
  const Log plan = read_log(dir + "/plan/plan.csv");
  ASSERT_EQ(plan.rows, 25);
  ASSERT_TRUE(plan.has_point);
  EXPECT_EQ(plan.label[1], "P5");  // P1, P5, P4, P3, P2
  // The attained poses: a deviated arm's, scattered.
  DeviceModel truth = testing::meca500();
  truth.links[1].a += 5e-4;
  truth.links[2].theta += 5e-3;
  const PreparedModel actual(truth);
  std::mt19937_64 rng(5);
  std::normal_distribution<double> g(0, 1e-5);
  std::string csv = "q1,q2,q3,q4,q5,q6,x,y,z\n";
  std::vector<Eigen::Vector3d> attained;
  for (int r = 0; r < plan.rows; ++r) {
    const Eigen::VectorXd q = plan.q.row(r).transpose();
    const Eigen::Vector3d p = actual.forward(q.data()).p + Eigen::Vector3d(g(rng), g(rng), g(rng));
    attained.push_back(p);
    for (int i = 0; i < 6; ++i) csv += fmt::format("{:.17g},", q[i]);
    csv += fmt::format("{:.17g},{:.17g},{:.17g}\n", p.x(), p.y(), p.z());
  }
  std::ofstream(dir + "/test.csv") << csv;
  save_device(truth, dir + "/truth.yaml");
  // Scored against the truth (the model: AP the scatter's) and the nominal model
  // (the reference: AP its error).
  const auto scored =
      testing::run_cli({"evaluate", "--model", dir + "/truth.yaml", "--log", dir + "/test.csv",
                        "--iso9283", dir + "/plan/plan.csv", "--reference", model, "--json"});
  ASSERT_EQ(scored.exit_code, 0) << scored.err;
  const nlohmann::json j = nlohmann::json::parse(scored.out)["iso9283"];
  // The expected runs built here from the plan's rows: pose P<k>'s rows in
  // order are its cycles; its commanded pose a model's at the plan's readings.
  const auto expected_for = [&](const DeviceModel& m) {
    const PreparedModel prepared(m);
    std::vector<IsoPoseRuns> runs;
    for (const char* label : {"P1", "P2", "P3", "P4", "P5"}) {
      IsoPoseRuns run;
      run.label = label;
      for (int r = 0; r < plan.rows; ++r) {
        if (plan.label[static_cast<size_t>(r)] != label) continue;
        const Eigen::VectorXd q = plan.q.row(r).transpose();
        run.commanded = prepared.forward(q.data());
        run.cycles.push_back(static_cast<int>(run.cycles.size()) + 1);
        run.attained.push_back({Eigen::Matrix3d::Identity(), attained[static_cast<size_t>(r)]});
      }
      runs.push_back(run);
    }
    return iso_criteria(runs);
  };
  const IsoCriteria expected = expected_for(truth), nominal = expected_for(testing::meca500());
  ASSERT_EQ(j["model"]["poses"].size(), 5u);
  for (size_t k = 0; k < 5; ++k) {
    EXPECT_EQ(j["model"]["poses"][k]["pose"], expected.poses[k].label);
    EXPECT_NEAR(j["model"]["poses"][k]["AP"].get<double>(), expected.poses[k].ap, 1e-12);
    EXPECT_NEAR(j["model"]["poses"][k]["RP"].get<double>(), expected.poses[k].rp, 1e-12);
    EXPECT_NEAR(j["reference"]["poses"][k]["AP"].get<double>(), nominal.poses[k].ap, 1e-12);
    EXPECT_GT(nominal.poses[k].ap, 10 * expected.poses[k].ap);  // the nominal model's error
  }
  ASSERT_EQ(j["model"]["distances"].size(), 5u);  // P2-P4, then P1 to each other pose
  EXPECT_EQ(j["model"]["distances"][0]["from"], "P2");
  EXPECT_EQ(j["model"]["distances"][0]["to"], "P4");
  for (size_t k = 0; k < 5; ++k) {
    EXPECT_NEAR(j["model"]["distances"][k]["AD"].get<double>(), expected.distances[k].ad, 1e-12);
    EXPECT_NEAR(j["reference"]["distances"][k]["AD"].get<double>(), nominal.distances[k].ad, 1e-12);
    EXPECT_NEAR(j["model"]["distances"][k]["RD"].get<double>(), expected.distances[k].rd, 1e-12);
  }
  const auto text = testing::run_cli({"evaluate", "--model", model, "--log", dir + "/test.csv",
                                      "--iso9283", dir + "/plan/plan.csv"});
  EXPECT_NE(text.out.find("ISO 9283 pose characteristics"), std::string::npos) << text.out;
  // The reports: the plan's poses and cube; the test laid out as the standard's report.
  EXPECT_NE(testing::slurp(dir + "/plan/report.html").find("<h2>Test poses</h2>"),
            std::string::npos);
  EXPECT_TRUE(std::ifstream(dir + "/plan/figures/iso9283_cube.svg").good());
  const auto reported =
      testing::run_cli({"evaluate", "--model", model, "--log", dir + "/test.csv", "--iso9283",
                        dir + "/plan/plan.csv", "--reference", model, "--conditions",
                        "load 0.5 kg, 21 C", "--out", dir + "/scored"});
  ASSERT_EQ(reported.exit_code, 0) << reported.err;
  const std::string html = testing::slurp(dir + "/scored/report.html");
  EXPECT_NE(html.find("Test conditions: load 0.5 kg, 21 C."), std::string::npos);
  EXPECT_NE(html.find("AP reference [mm]"), std::string::npos);
  EXPECT_NE(html.find("RD [mm]"), std::string::npos);
  const auto no_test = testing::run_cli(
      {"evaluate", "--model", model, "--log", dir + "/test.csv", "--conditions", "21 C"});
  EXPECT_EQ(no_test.exit_code, 2);
  EXPECT_NE(no_test.err.find("--conditions"), std::string::npos) << no_test.err;
  // Refused: a log of other rows, one whose readings are not the plan's, a plan without labels.
  std::ofstream(dir + "/short.csv") << csv.substr(0, csv.rfind('\n', csv.size() - 2) + 1);
  std::string moved = csv;
  moved.replace(moved.find('\n') + 1, 1, "1");  // row 1's q1: 1 rad instead of 0
  std::ofstream(dir + "/moved.csv") << moved;
  for (const std::string& bad : {dir + "/short.csv", dir + "/moved.csv"}) {
    const auto refused = testing::run_cli(
        {"evaluate", "--model", model, "--log", bad, "--iso9283", dir + "/plan/plan.csv"});
    EXPECT_EQ(refused.exit_code, 2) << refused.out << refused.err;
    EXPECT_NE(refused.err.find("--iso9283"), std::string::npos) << refused.err;
  }
  const auto no_plan = testing::run_cli(
      {"evaluate", "--model", model, "--log", dir + "/test.csv", "--iso9283", dir + "/test.csv"});
  EXPECT_EQ(no_plan.exit_code, 2);
  EXPECT_NE(no_plan.err.find("not a test plan"), std::string::npos) << no_plan.err;
}

// A test's files as a careless user leaves them: a plan whose labels break its
// pattern, positions in mm under bare x, y, z, positions in the tracker's own
// frame, a centre 1e300 m away. Each is one line naming the file, line and
// column (exit 2), never a score.
TEST(Iso9283, CarelessPlansAndLogsAreRefused) {
  const std::string dir = testing::fresh_folder("iso9283_careless");
  const std::string model = testing::source_path("examples/meca500/meca500.yaml");
  ASSERT_EQ(testing::run_cli(
                {"plan", "--model", model, "--iso9283", "--cycles", "5", "--out", dir + "/plan"})
                .exit_code,
            0);
  const std::string plan_csv = testing::slurp(dir + "/plan/plan.csv");
  const Log plan = read_log(dir + "/plan/plan.csv");
  const PreparedModel nominal(testing::meca500());
  // The log: each row's position the nominal's, written with `header` in `scale` units,
  // turned by `turn` about z and moved by `shift` (another frame).
  const auto log_csv = [&](const std::string& header, double scale, double turn,
                           const Eigen::Vector3d& shift) {
    std::string csv = "q1,q2,q3,q4,q5,q6," + header + "\n";
    const Eigen::Matrix3d R = Eigen::AngleAxisd(turn, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    for (int r = 0; r < plan.rows; ++r) {
      const Eigen::VectorXd q = plan.q.row(r).transpose();
      const Eigen::Vector3d p = scale * (R * nominal.forward(q.data()).p + shift);
      for (int i = 0; i < 6; ++i) csv += fmt::format("{:.17g},", q[i]);
      csv += fmt::format("{:.17g},{:.17g},{:.17g}\n", p.x(), p.y(), p.z());
    }
    return csv;
  };
  const auto score = [&](const std::string& log, const std::string& plan_file) {
    std::ofstream(dir + "/log.csv") << log;
    return testing::run_cli({"evaluate", "--model", model, "--log", dir + "/log.csv", "--iso9283",
                             plan_file, "--json"});
  };
  const auto refused = [](const testing::CliResult& c, const std::string& what) {
    EXPECT_EQ(c.exit_code, 2) << c.out;
    EXPECT_NE(c.err.find(what), std::string::npos) << c.err;
    EXPECT_EQ(c.err.find('\n'), c.err.size() - 1) << c.err;
  };
  const std::string metres = log_csv("x,y,z", 1, 0, Eigen::Vector3d::Zero());
  const auto good = score(metres, dir + "/plan/plan.csv");
  ASSERT_EQ(good.exit_code, 0) << good.err;
  const double ap = nlohmann::json::parse(good.out)["iso9283"]["model"]["poses"][0]["AP"];
  EXPECT_LT(ap, 1e-9);
  // The log may keep the plan's point column (the plan's file with x, y, z
  // added): the same figures; a label that is not the plan's is refused.
  std::string kept = "q1,q2,q3,q4,q5,q6,point,x,y,z\n";
  {
    std::istringstream plan_lines(plan_csv), log_lines(metres);
    std::string a, b;
    std::getline(plan_lines, a), std::getline(log_lines, b);  // the headers
    while (std::getline(plan_lines, a) && std::getline(log_lines, b)) {
      std::size_t xyz = 0;  // after the log row's sixth comma: x, y, z
      for (int k = 0; k < 6; ++k) xyz = b.find(',', xyz) + 1;
      kept += a + "," + b.substr(xyz) + "\n";
    }
  }
  const auto with_labels = score(kept, dir + "/plan/plan.csv");
  ASSERT_EQ(with_labels.exit_code, 0) << with_labels.err;
  EXPECT_EQ(nlohmann::json::parse(with_labels.out)["iso9283"],
            nlohmann::json::parse(good.out)["iso9283"]);
  // The whole evaluation, not only the ISO part: the pose names are no fixture's
  // labels (no labels, no plane or point figures), the position's figures are the same.
  EXPECT_EQ(nlohmann::json::parse(with_labels.out), nlohmann::json::parse(good.out));
  std::string mislabelled = kept;
  mislabelled.replace(mislabelled.find(",P5,"), 4, ",P3,");  // line 3: cycle 1's second row
  refused(score(mislabelled, dir + "/plan/plan.csv"),
          dir + "/log.csv:3: point: 'P3' where the plan (" + dir + "/plan/plan.csv line 3) has P5");
  // P2 labelled P1 (line 6: cycle 1's fifth row): P1's "60 cycles" are refused.
  std::string relabelled = plan_csv;
  for (std::size_t at = relabelled.find(",P2\n"); at != std::string::npos;
       at = relabelled.find(",P2\n", at))
    relabelled.replace(at, 4, ",P1\n");
  std::ofstream(dir + "/relabelled.csv") << relabelled;
  refused(score(metres, dir + "/relabelled.csv"),
          dir +
              "/relabelled.csv:6: point: 'P1' where a test plan has P2 (cycle 1, its pose 5 of "
              "5): each cycle visits the poses in the order P1, P5, P4, P3, P2");
  // Two poses swapped in cycle 3 (lines 12 and 13).
  std::vector<std::string> lines;
  std::istringstream in(plan_csv);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  std::swap(lines[11], lines[12]);
  std::string swapped;
  for (const std::string& line : lines) swapped += line + "\n";
  std::ofstream(dir + "/swapped.csv") << swapped;
  refused(score(metres, dir + "/swapped.csv"), dir + "/swapped.csv:12: point: 'P5' where a test");
  // A plan cut inside its last cycle (and the log with it): 23 rows.
  const auto first_lines = [](const std::string& text, int n) {
    std::size_t at = 0;
    for (int k = 0; k < n; ++k) at = text.find('\n', at) + 1;
    return text.substr(0, at);
  };
  std::ofstream(dir + "/cut.csv") << first_lines(plan_csv, 24);
  refused(score(first_lines(metres, 24), dir + "/cut.csv"),
          dir + "/cut.csv:24: point: the plan ends inside cycle 5 (3 of its 5 poses)");
  // Positions in mm under bare x, y, z: AP would be 1000 times the arm's reach.
  refused(score(log_csv("x,y,z", 1e3, 0, Eigen::Vector3d::Zero()), dir + "/plan/plan.csv"),
          dir + "/log.csv: x: the attained positions are");
  refused(score(log_csv("x,y,z", 1e3, 0, Eigen::Vector3d::Zero()), dir + "/plan/plan.csv"),
          "The positions fit it in mm: give the unit in the log's header (x[mm], y[mm], z[mm]; a "
          "bare column is metres).");
  const auto in_mm =
      score(log_csv("x[mm],y[mm],z[mm]", 1e3, 0, Eigen::Vector3d::Zero()), dir + "/plan/plan.csv");
  ASSERT_EQ(in_mm.exit_code, 0) << in_mm.err;
  EXPECT_LT(nlohmann::json::parse(in_mm.out)["iso9283"]["model"]["poses"][0]["AP"].get<double>(),
            1e-9);
  // Measured in the tracker's frame, 1 m away and turned: --register says so.
  refused(score(log_csv("x,y,z", 1, 0.5, Eigen::Vector3d(1, -0.5, 0.2)), dir + "/plan/plan.csv"),
          "They fit its poses in another frame: give --register frame.");
  // A cube centre 1e300 m away: refused in a short line, the number as a person writes it.
  const auto far = testing::run_cli(
      {"plan", "--model", model, "--iso9283", "--cube-centre", "1e300,0,0", "--out", dir + "/far"});
  refused(far, "--cube-centre: (1e+300, 0, 0) m: each coordinate within +-100 m");
  EXPECT_LT(far.err.size(), 200u) << far.err;
  EXPECT_FALSE(std::filesystem::exists(dir + "/far"));
}

// The prediction of a simulated ISO test, built here: the tool point's
// derivatives by central differences of the forward kinematics in each fitted
// step-1 parameter (joint by joint), then each identified kinematic parameter,
// through the covariance C given in that order.
std::vector<double> expected_ap(const CalibrationResult& full, const Eigen::MatrixXd& C,
                                const IsoSimulation& iso) {
  const auto point = [](const DeviceModel& m, const Eigen::VectorXd& q) {
    return PreparedModel(m).forward(q.data()).p;
  };
  std::vector<double> out;
  for (const IsoTestPose& pose : iso.plan.poses) {
    const Eigen::VectorXd& q = pose.readings;
    Eigen::MatrixXd G(3, C.cols());
    int column = 0;
    for (const TransmissionFit& f : full.transmissions) {
      const Eigen::VectorXd p = full.calibrated.links[f.joint].transmission.parameters();
      for (int i = 0; i < p.size(); ++i) {
        const double h = 1e-6 * std::max(1.0, std::abs(p[i]));
        DeviceModel up = full.calibrated, down = full.calibrated;
        Eigen::VectorXd pu = p, pd = p;
        pu[i] += h;
        pd[i] -= h;
        up.links[f.joint].transmission.set_parameters(pu.data());
        down.links[f.joint].transmission.set_parameters(pd.data());
        G.col(column++) = (point(up, q) - point(down, q)) / (2 * h);
      }
    }
    const Eigen::VectorXd p = full.calibrated.kinematic_parameters();
    for (const std::string& name : full.kinematics.identified_names) {
      for (const ParameterEstimate& e : full.kinematics.parameters) {
        if (e.name != name) continue;
        const double h = 1e-7;
        DeviceModel up = full.calibrated, down = full.calibrated;
        Eigen::VectorXd pu = p, pd = p;
        pu[e.slot] += h;
        pd[e.slot] -= h;
        up.set_kinematic_parameters(pu);
        down.set_kinematic_parameters(pd);
        G.col(column++) = (point(up, q) - point(down, q)) / (2 * h);
      }
    }
    EXPECT_EQ(column, C.cols());
    out.push_back(std::sqrt((G * C * G.transpose()).trace() +
                            3 * iso.scatter * iso.scatter / iso.plan.cycles));
  }
  return out;
}

std::vector<int> identified_slots(const KinematicFit& fit) {
  std::vector<int> slots;
  for (const std::string& name : fit.identified_names) {
    for (const ParameterEstimate& e : fit.parameters) {
      if (e.name == name) slots.push_back(e.slot);
    }
  }
  return slots;
}

// One trial of `sc` with the test at its cube (20 um scatter), its files in a
// fresh folder (the identification log read back into the figures).
TrialResult trial_with_test(Scenario sc, const std::string& name) {
  IsoSimulation iso;
  iso.scatter = 2e-5;
  iso.plan = plan_iso_cube(sc.nominal);
  sc.iso9283 = iso;
  sc.trajectory_seconds = 1;
  sc.trajectory_rate_hz = 100;
  const TrialResult t = run_trial(sc, 17, testing::fresh_folder(name));
  EXPECT_TRUE(t.iso.has_value());
  return t;
}

void expect_prediction(const TrialResult& t, const Eigen::MatrixXd& C, const Scenario& sc) {
  IsoSimulation iso;
  iso.scatter = 2e-5;
  iso.plan = plan_iso_cube(sc.nominal);
  const std::vector<double> expected = expected_ap(t.full, C, iso);
  ASSERT_EQ(t.iso->predicted_ap.size(), expected.size());
  for (size_t k = 0; k < expected.size(); ++k) {
    EXPECT_NEAR(t.iso->predicted_ap[k] / expected[k], 1.0, 1e-4) << iso.plan.poses[k].label;
    EXPECT_EQ(t.iso->nominal.poses[k].rp, t.iso->calibrated.poses[k].rp);  // the robot's
  }
}

// After a two-step calibration (the paper's device: capstans and a polynomial
// from external encoders, then the kinematics from distances, every distance
// with the same sd): the prediction is information.hpp's two_step_covariance
// through the tool point.
TEST(Iso9283, PredictedApIsTheTwoStepCovarianceThroughTheToolPoint) {
  Scenario sc = default_scenario(testing::source_path("data/devices/baser-7dof.yaml"));
  sc.random = {5e-4, 5e-3, 3};
  assign_truth(sc, "test");
  const TrialResult t = trial_with_test(sc, "iso9283_two_step");
  const CalibrationResult& full = t.full;
  ASSERT_FALSE(full.transmissions.empty());  // step 1 ran
  std::vector<StepOneModel> step_one;
  for (const TransmissionFit& f : full.transmissions) {
    const Transmission& m = full.calibrated.links[f.joint].transmission;
    step_one.push_back({f.joint, m, {f.names.begin(), f.names.begin() + m.num_parameters()}});
  }
  const TwoStepJacobians J =
      two_step_jacobians(full.calibrated, MeasurementType::kDistance, 1.0,
                         identified_slots(full.kinematics), step_one, t.figures.identification.q);
  expect_prediction(
      t, two_step_covariance(J.kinematic, measurement_sigma(sc), J.step_one, sc.noise.sigma_ext),
      sc);
}

// After a calibration on a tracker's poses (a Meca500: no transmissions), the
// rotation rows (scaled by the fit's length scale) noisier than the position
// rows: the prediction is the least-squares sandwich A J^T V J A, A = (J^T J)^-1,
// V the rows' variances, built here.
TEST(Iso9283, PredictedApOfAPoseCalibrationIsTheSandwich) {
  Scenario sc = default_scenario(testing::source_path("examples/meca500/meca500.yaml"));
  sc.measurement = MeasurementType::kPose;
  sc.noise.sigma_distance = sc.noise.sigma_position = 2e-5;
  sc.noise.sigma_orientation = 2e-4;
  sc.identification_poses = 100;
  sc.validation_poses = 20;
  assign_truth(sc, "test");
  const TrialResult t = trial_with_test(sc, "iso9283_pose");
  const KinematicFit& fit = t.full.kinematics;
  ASSERT_TRUE(t.full.transmissions.empty());
  const Eigen::MatrixXd J =
      two_step_jacobians(t.full.calibrated, MeasurementType::kPose, fit.rotation_scale,
                         identified_slots(fit), {}, t.figures.identification.q)
          .kinematic;
  Eigen::VectorXd v(J.rows());
  for (Eigen::Index r = 0; r < v.size(); ++r) {
    v[r] = r % 6 < 3 ? std::pow(2e-5, 2) : std::pow(fit.rotation_scale * 2e-4, 2);
  }
  const Eigen::MatrixXd A = (J.transpose() * J).inverse();
  const Eigen::MatrixXd C = A * J.transpose() * v.asDiagonal() * J * A;
  expect_prediction(t, C, sc);
  // One sd for every row (the calibration's own sigma) predicts otherwise: the
  // check tells the two apart.
  IsoSimulation iso;
  iso.scatter = 2e-5;
  iso.plan = plan_iso_cube(sc.nominal);
  const std::vector<double> one_sd = expected_ap(t.full, std::pow(fit.sigma, 2) * A, iso);
  double ratio = 0;
  for (size_t k = 0; k < one_sd.size(); ++k) ratio += t.iso->predicted_ap[k] / one_sd[k];
  ratio /= static_cast<double>(one_sd.size());
  std::printf("the sandwich's AP / one sd's: %.3f\n", ratio);
  EXPECT_GT(std::abs(ratio - 1), 0.05);
}

// After a fixture's calibration (the PHANToM's two sockets, their positions
// unknown): the covariance the calibration states, its sd and correlations.
TEST(Iso9283, PredictedApOfAFixtureCalibrationIsItsStatedCovariance) {
  const Scenario sc = load_scenario(testing::source_path("data/scenarios/phantom-two-socket.yaml"),
                                    builtin_device_path());
  const TrialResult t = trial_with_test(sc, "iso9283_fixture");
  const KinematicFit& fit = t.full.kinematics;
  const auto n = static_cast<Eigen::Index>(fit.identified_names.size());
  Eigen::MatrixXd C(n, n);
  std::vector<double> sd;
  for (const std::string& name : fit.identified_names) {
    for (const ParameterEstimate& e : fit.parameters) {
      if (e.name == name) sd.push_back(e.sd);
    }
  }
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index j = 0; j < n; ++j) C(i, j) = sd[i] * sd[j] * fit.correlation(i, j);
  }
  expect_prediction(t, C, sc);
}

// simulate with an ISO test on three kinds of device: the paper's (distances,
// capstans and a polynomial fitted first), the dVRK MTM (a tracker's poses,
// coupled joints) and a Meca500 (positions), each with random deviations, 40
// calibrations: the calibrated model's AP (RMS over trials and poses) within
// 10 % of the prediction from the calibrations' covariance, far below the
// nominal model's; results.json, iso9283.csv and the report agree.
TEST(Iso9283, SimulateRunsTheTestAfterEveryCalibration) {
  const std::string dir = testing::fresh_folder("iso9283_simulate");
  const std::string devices = testing::source_path("data/devices");
  const std::string scenarios[] = {
      "random_deviations: {lengths: 5.0e-4, angles: 5.0e-3}\n",
      "device: " + devices +
          "/dvrk-mtm.yaml\nmeasurement: pose\n"
          "noise: {sigma_m: 1.0e-4, sigma_r: 1.0e-3}\n"
          "random_deviations: {lengths: 1.0e-3, angles: 1.0e-3}\n",
      "device: " + testing::source_path("examples/meca500/meca500.yaml") +
          "\nmeasurement: position\nposes: {identification: 100}\nnoise: {sigma_m: 2.0e-5}\n"
          "random_deviations: {lengths: 5.0e-4, angles: 5.0e-3}\n"};
  int index = 0;
  for (const std::string& body : scenarios) {
    SCOPED_TRACE(body);
    const std::string out = dir + fmt::format("/out{}", index);
    const std::string path = dir + fmt::format("/s{}.yaml", index++);
    std::ofstream(path) << "format: hapticcal-scenario/1\ntrials: 100\n"
                        << "trajectory: {seconds: 1, rate_hz: 100}\n"
                        << body << "iso9283: {cycles: 30, scatter: 1.0e-5}\n";
    const auto r = testing::run_cli({"simulate", "--scenario", path, "--out", out});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.out.find("ISO 9283 test after each calibration"), std::string::npos) << r.out;
    std::ifstream in(out + "/results.json");
    const nlohmann::json j = nlohmann::json::parse(in)["iso9283"];
    const double nominal = j["ap_nominal"], calibrated = j["ap_calibrated"],
                 predicted = j["ap_predicted"];
    std::printf("AP nominal %.4f mm, calibrated %.4f mm, predicted %.4f mm (ratio %.3f)\n",
                nominal * 1e3, calibrated * 1e3, predicted * 1e3, calibrated / predicted);
    EXPECT_NEAR(calibrated / predicted, 1.0, 0.10);
    EXPECT_GT(nominal, 10 * calibrated);
    EXPECT_EQ(j["trials"], 100);
    ASSERT_EQ(j["poses"].size(), 5u);
    // iso9283.csv: a row a pose of a trial; its RMS the json's.
    std::ifstream rows(out + "/iso9283.csv");
    std::string line;
    std::getline(rows, line);
    EXPECT_EQ(line, "trial,pose,ap_nominal,ap_calibrated,ap_predicted,rp");
    double sum = 0;
    int n = 0;
    while (std::getline(rows, line)) {
      std::vector<std::string> cells;
      std::istringstream fields(line);
      for (std::string cell; std::getline(fields, cell, ',');) cells.push_back(cell);
      ASSERT_EQ(cells.size(), 6u);
      sum += std::pow(std::stod(cells[3]), 2);
      ++n;
    }
    EXPECT_EQ(n, 500);  // 100 trials of 5 poses
    EXPECT_NEAR(std::sqrt(sum / n), calibrated, 1e-12);
    const std::string html = testing::slurp(out + "/report.html");
    EXPECT_NE(html.find("ISO 9283 test after calibration (simulated)"), std::string::npos);
    EXPECT_TRUE(std::ifstream(out + "/figures/iso9283_ap.svg").good());
    EXPECT_TRUE(std::ifstream(out + "/figures/iso9283_cube.svg").good());
  }
  // The paper's own truth deviates where distances cannot see (a turn about the
  // cable's anchor): said, as the reason AP stays above its prediction.
  const std::string paper = dir + "/paper.yaml";
  std::ofstream(paper) << "format: hapticcal-scenario/1\ntrials: 2\niso9283: {cycles: 5}\n";
  const auto r = testing::run_cli({"simulate", "--scenario", paper, "--out", dir + "/paper"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("parameters the calibration held (base.alpha"), std::string::npos) << r.out;
}

// The scenario's iso9283 section: every bad value refused naming the file,
// line and key, in the section's words (not plan's options); nothing written.
TEST(Iso9283, ScenarioSectionIsChecked) {
  const std::string dir = testing::fresh_folder("iso9283_scenario");
  struct Case {
    std::string section, key, reason;
  };
  const Case cases[] = {
      {"iso9283: {cycle: 3}\n", "iso9283.cycle", "unknown key"},
      {"iso9283: [30]\n", "iso9283", "mapping"},
      {"iso9283: {cycles: 0}\n", "iso9283.cycles", "integer"},
      {"iso9283: {cycles: 2.5}\n", "iso9283.cycles", "integer"},
      {"iso9283: {scatter: -1e-5}\n", "iso9283.scatter", "outside"},
      {"iso9283: {cube_size: 5}\n", "iso9283", "cube_size: a cube of 5000.0 mm"},
      {"iso9283: {cube_size: .nan}\n", "iso9283.cube_size", "not finite"},
      {"iso9283: {cube_size: .inf}\n", "iso9283.cube_size", "not finite"},
      {"iso9283: {cycles: 1001}\n", "iso9283.cycles", "[1, 1000]"},
      {"iso9283: {scatter: 2}\n", "iso9283.scatter", "outside"},
      {"iso9283: {cube_centre: [0.5, .nan, 0]}\n", "iso9283.cube_centre", "not finite"},
      {"iso9283: {cube_centre: [1, 2]}\n", "iso9283.cube_centre", "[X, Y, Z]"},
      {"iso9283: {cube_centre: [9, 9, 9]}\n", "iso9283", "cube_centre: the tool cannot reach"},
      {"measurement: position\nsession: {seconds: 10}\niso9283: {}\n", "iso9283",
       "session study runs no ISO 9283 test"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.section);
    const std::string path = dir + "/s.yaml";
    std::ofstream(path) << "format: hapticcal-scenario/1\n" << c.section;
    const auto r = testing::run_cli({"simulate", "--scenario", path, "--out", dir + "/out"});
    EXPECT_EQ(r.exit_code, 2) << r.out << r.err;
    EXPECT_NE(r.err.find(path + ":"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(c.key), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(c.reason), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("--cube"), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir + "/out"));
  }
  // No scatter is a test of its own: RP 0 at every pose.
  const std::string exact = dir + "/exact.yaml";
  std::ofstream(exact) << "format: hapticcal-scenario/1\nmeasurement: position\ntrials: 1\n"
                       << "poses: {identification: 50, validation: 10}\n"
                       << "trajectory: {seconds: 1, rate_hz: 10}\n"
                       << "iso9283: {cycles: 3, scatter: 0}\n";
  const auto ran = testing::run_cli({"simulate", "--scenario", exact, "--out", dir + "/exact"});
  ASSERT_EQ(ran.exit_code, 0) << ran.err;
  std::ifstream in(dir + "/exact/results.json");
  const nlohmann::json j = nlohmann::json::parse(in)["iso9283"];
  ASSERT_EQ(j["poses"].size(), 5u);
  // (0 to rounding: the barycentre of equal points is their sum over n.)
  for (const auto& pose : j["poses"]) EXPECT_NEAR(pose["rp"].get<double>(), 0.0, 1e-15);
}

}  // namespace
}  // namespace hapticcal
