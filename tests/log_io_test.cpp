// CSV logs: headers, units, --columns, comments.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <random>

#include "hapticcal/error.hpp"
#include "hapticcal/io.hpp"

namespace hapticcal {
namespace {

TEST(LogIo, ReadsHeaderUnitsAndCommentsIntoSiUnits) {
  const Log log = parse_log(
      "# a comment\n"
      "t[ms], q1[deg], q2, ext1[deg], distance[mm], x[mm], y[um], z\n"
      "1, 90, 0.5, 45, 250, 1, 2, 3\n"
      "\n"
      "2, -180, -0.5, 0, 0, 0, 0, 0  \n",
      "test.csv");
  ASSERT_EQ(log.rows, 2);
  ASSERT_EQ(log.dof(), 2);
  EXPECT_DOUBLE_EQ(log.t[0], 1e-3);
  EXPECT_DOUBLE_EQ(log.q(0, 0), std::numbers::pi / 2);
  EXPECT_DOUBLE_EQ(log.q(1, 0), -std::numbers::pi);
  EXPECT_DOUBLE_EQ(log.q(0, 1), 0.5);
  EXPECT_TRUE(log.has_ext[0]);
  EXPECT_FALSE(log.has_ext[1]);
  EXPECT_DOUBLE_EQ(log.ext(0, 0), std::numbers::pi / 4);
  EXPECT_DOUBLE_EQ(log.distance[0], 0.25);
  EXPECT_DOUBLE_EQ(log.position(0, 0), 1e-3);
  EXPECT_DOUBLE_EQ(log.position(0, 1), 2e-6);
  EXPECT_DOUBLE_EQ(log.position(0, 2), 3);
  EXPECT_EQ(log.line[1], 5);
}

TEST(LogIo, ColumnsOptionReadsAHeaderlessLogAndSkipsUnderscores) {
  const Log log =
      parse_log("10,20,1,2,3,0,0\n", "raw.csv", split_columns("q1[deg],q2[deg],x,y,z,_,_"));
  ASSERT_EQ(log.rows, 1);
  EXPECT_DOUBLE_EQ(log.q(0, 1), 20 * std::numbers::pi / 180);
  EXPECT_TRUE(log.has_position);
  EXPECT_FALSE(log.has_distance);
}

TEST(LogIo, ErrorsNameFileLineAndColumn) {
  try {
    parse_log("q1,q2,distance\n0,0,1\n0,abc,1\n", "bad.csv");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "bad.csv:3: q2: 'abc' is not a number");
    EXPECT_EQ(e.line(), 3);
    EXPECT_EQ(e.key(), "q2");
  }
}

// A double anywhere in the finite range: random sign, mantissa and binary
// exponent from the subnormals (2^-1074) to the largest (just under 2^1024).
double random_finite(std::mt19937_64& rng) {
  const double mantissa = std::uniform_real_distribution<double>(0.5, 1.0)(rng);
  const int exponent = std::uniform_int_distribution<int>(-1073, 1024)(rng);
  const double v = std::ldexp(mantissa, exponent);
  return std::bernoulli_distribution(0.5)(rng) ? -v : v;
}

// log_to_csv -> parse_log gives back every number bit for bit: random logs with
// every column kind (t, q, ext on some joints, distance, x y z), random values
// over the whole finite range, and the extremes (largest, smallest normal,
// smallest subnormal, -0, both signs).
TEST(LogIo, LogToCsvRoundTripsEveryColumnKindAndExtremeFiniteValues) {
  constexpr double kMax = std::numeric_limits<double>::max();
  constexpr double kMinNormal = std::numeric_limits<double>::min();
  constexpr double kSubnormal = std::numeric_limits<double>::denorm_min();
  const double extremes[] = {kMax, -kMax, kMinNormal, -kMinNormal, kSubnormal, -kSubnormal,
                             -0.0, 0.0,   0.1,        1.0 / 3,     1e-300,     -1e300};
  std::mt19937_64 rng(17);
  for (int trial = 0; trial < 40; ++trial) {
    SCOPED_TRACE(trial);
    const int dof = std::uniform_int_distribution<int>(1, 7)(rng), rows = 1 + trial % 9;
    Log log;
    log.origin = "written";
    log.rows = rows;
    log.has_time = trial % 2 == 0;
    log.has_distance = trial % 3 != 1;
    log.has_position = trial % 3 != 0;  // at least one of distance and position
    log.has_ext.resize(dof);
    for (int j = 0; j < dof; ++j) log.has_ext[j] = std::bernoulli_distribution(0.5)(rng);
    int next_extreme = trial;
    auto value = [&] {
      return (next_extreme++ % 4 == 0) ? extremes[next_extreme % std::size(extremes)]
                                       : random_finite(rng);
    };
    log.q.resize(rows, dof);
    log.ext.setZero(rows, dof);
    if (log.has_time) log.t.resize(rows);
    if (log.has_distance) log.distance.resize(rows);
    if (log.has_position) log.position.resize(rows, 3);
    for (int r = 0; r < rows; ++r) {
      if (log.has_time) log.t[r] = value();
      for (int j = 0; j < dof; ++j) {
        log.q(r, j) = value();
        if (log.has_ext[j]) log.ext(r, j) = value();
      }
      if (log.has_distance) log.distance[r] = std::abs(value());  // never negative
      if (log.has_position) {
        for (int k = 0; k < 3; ++k) log.position(r, k) = value();
      }
    }
    const Log back = parse_log(log_to_csv(log), "round-trip.csv");
    ASSERT_EQ(back.rows, rows);
    ASSERT_EQ(back.dof(), dof);
    EXPECT_EQ(back.has_ext, log.has_ext);
    ASSERT_EQ(back.has_time, log.has_time);
    ASSERT_EQ(back.has_distance, log.has_distance);
    ASSERT_EQ(back.has_position, log.has_position);
    // Bit for bit (distinguishes -0 from 0).
    auto same = [](const auto& a, const auto& b) {
      if (a.size() != b.size()) return false;
      for (Eigen::Index i = 0; i < a.size(); ++i) {
        if (std::bit_cast<std::uint64_t>(a.data()[i]) != std::bit_cast<std::uint64_t>(b.data()[i]))
          return false;
      }
      return true;
    };
    EXPECT_TRUE(same(back.q, log.q));
    EXPECT_TRUE(same(back.ext, log.ext));
    if (log.has_time) {
      EXPECT_TRUE(same(back.t, log.t));
    }
    if (log.has_distance) {
      EXPECT_TRUE(same(back.distance, log.distance));
    }
    if (log.has_position) {
      EXPECT_TRUE(same(back.position, log.position));
    }
  }
}

// The same text with a unit on every column reads as value x unit: [rad] [m]
// [s] leave the numbers as they are; [deg] [mm] [um] [ms] scale them by pi/180,
// 1e-3, 1e-6 and 1e-3 (within 4 ulp).
TEST(LogIo, UnitsScaleRoundTrippedValues) {
  std::mt19937_64 rng(18);
  Log log;
  log.rows = 50;
  log.has_time = log.has_distance = log.has_position = true;
  log.has_ext = {true, false};
  log.q.resize(50, 2);
  log.ext.setZero(50, 2);
  log.t.resize(50);
  log.distance.resize(50);
  log.position.resize(50, 3);
  for (int r = 0; r < 50; ++r) {
    log.t[r] = random_finite(rng);
    log.q(r, 0) = random_finite(rng);
    log.q(r, 1) = random_finite(rng);
    log.ext(r, 0) = random_finite(rng);
    log.distance[r] = std::abs(random_finite(rng));
    for (int k = 0; k < 3; ++k) log.position(r, k) = random_finite(rng);
  }
  const std::string csv = log_to_csv(log);
  const std::string body = csv.substr(csv.find('\n'));
  ASSERT_EQ(csv.substr(0, csv.find('\n')), "t,q1,q2,ext1,distance,x,y,z");
  const Log si =
      parse_log("t[s],q1[rad],q2[rad],ext1[rad],distance[m],x[m],y[m],z[m]" + body, "si");
  EXPECT_EQ(si.q, log.q);
  EXPECT_EQ(si.position, log.position);
  const Log scaled =
      parse_log("t[ms],q1[deg],q2[rad],ext1[deg],distance[mm],x[um],y[mm],z[m]" + body, "scaled");
  const double deg = std::numbers::pi / 180;
  for (int r = 0; r < 50; ++r) {
    EXPECT_DOUBLE_EQ(scaled.t[r], log.t[r] * 1e-3);
    EXPECT_DOUBLE_EQ(scaled.q(r, 0), log.q(r, 0) * deg);
    EXPECT_EQ(scaled.q(r, 1), log.q(r, 1));
    EXPECT_DOUBLE_EQ(scaled.ext(r, 0), log.ext(r, 0) * deg);
    EXPECT_DOUBLE_EQ(scaled.distance[r], log.distance[r] * 1e-3);
    EXPECT_DOUBLE_EQ(scaled.position(r, 0), log.position(r, 0) * 1e-6);
    EXPECT_DOUBLE_EQ(scaled.position(r, 1), log.position(r, 1) * 1e-3);
    EXPECT_EQ(scaled.position(r, 2), log.position(r, 2));
  }
}

}  // namespace
}  // namespace hapticcal
