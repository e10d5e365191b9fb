// ISO 9283's pose and distance characteristics (study/iso9283.hpp) against an
// implementation written here from the standard's formulas (clauses 7.2.1,
// 7.2.2, 7.3.1, 7.3.2): the means and sample deviations summed in one pass,
// the angles a, b, c read from the matrix elements (R = Rz(c) Ry(b) Rx(a)),
// each attained angle taken relative to the commanded one by adding or
// subtracting 2 pi until it lies in (-pi, pi].
#include "hapticcal/study/iso9283.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>

#include "hapticcal/core/error.hpp"
#include "hapticcal/design/iso9283_plan.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
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
  for (int k = 0; k < 4; ++k)
    EXPECT_NEAR((plan.poses[k + 1].pose.p - corners[k]).norm(), 0.1 * diagonal, 1e-12);
  // A larger cube about the same centre leaves some pose out of reach.
  IsoCubeOptions larger;
  larger.centre = plan.centre;
  larger.size = plan.size + 2e-4;
  EXPECT_THROW(plan_iso_cube(model, larger), InputError);
}

TEST(Iso9283, TestCubeOfA6RAndA7RArmLiesWithinTheJointLimits) {
  check_cube(testing::meca500());
  check_cube(testing::panda_like());
}

}  // namespace
}  // namespace hapticcal
