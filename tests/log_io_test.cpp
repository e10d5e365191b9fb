// CSV logs: headers, units, --columns, comments.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "hapticcal/core/error.hpp"
#include "hapticcal/data_io/log.hpp"

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

// dir<i> (issue 25, backlash): the side joint i approached the pose from, -1, 0
// or +1, no unit, of a joint the log has; anything else names line and column.
TEST(LogIo, DirectionColumnsHoldTheApproachSide) {
  const Log log = parse_log("q1,q2,dir2,x,y,z\n0,0,1,0,0,0\n0,1,-1,0,0,0\n0,2,0,0,0,0\n", "d.csv");
  EXPECT_TRUE(log.directed(1));
  EXPECT_FALSE(log.directed(0));
  EXPECT_EQ(log.direction.col(1), Eigen::Vector3d(1, -1, 0));
  EXPECT_EQ(log.direction.col(0), Eigen::Vector3d::Zero());
  EXPECT_EQ(parse_log(log_to_csv(log), "again.csv").direction, log.direction);
  const auto message = [](const std::string& text) {
    try {
      parse_log(text, "bad.csv");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message("q1,dir1,distance\n0,1,1\n0,0.5,1\n"),
            "bad.csv:3: dir1: 0.5: a direction is -1, 0 or +1 (the side the joint approached "
            "the pose from)");
  EXPECT_EQ(message("q1,dir1,distance\n0,nan,1\n").rfind("bad.csv:2: dir1: ", 0), 0u);
  EXPECT_EQ(message("q1,dir1[deg],distance\n0,1,1\n").rfind("bad.csv:1: dir1[deg]: unit", 0), 0u);
  EXPECT_EQ(message("q1,dir2,distance\n0,1,1\n"),
            "bad.csv:1: dir2: no joint 2 (the log has q1..q1)");
  EXPECT_EQ(message("q1,dir,distance\n0,1,1\n").rfind("bad.csv:1: dir: unknown column", 0), 0u);
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

// Bit for bit (distinguishes -0 from 0).
bool same_bits(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  if (a.rows() != b.rows() || a.cols() != b.cols()) return false;
  for (Eigen::Index i = 0; i < a.size(); ++i) {
    if (std::bit_cast<std::uint64_t>(a.data()[i]) != std::bit_cast<std::uint64_t>(b.data()[i]))
      return false;
  }
  return true;
}

// The message of the InputError that parse_log throws ("" if none).
std::string log_error(const std::string& text, const std::vector<std::string>& columns = {}) {
  try {
    parse_log(text, "pose.csv", columns);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// qw, qx, qy, qz: a unit quaternion is kept bit for bit, one whose norm is within 1e-3 of 1 is
// normalised (same direction), the sign is the log's.
TEST(LogIo, ReadsQuaternionColumnsAndNormalisesThem) {
  const Log log = parse_log(
      "q1, x[mm], y, z, qw, qx, qy, qz\n"
      "0, 1, 2, 3, 1, 0, 0, -0\n"
      "0, 1, 2, 3, 0.5, -0.5, 0.5, -0.5\n"
      "0, 1, 2, 3, 0.6, 0, 0.8004, 0\n"
      "0, 1, 2, 3, -0.9995, 0, 0, 0\n",
      "pose.csv");
  ASSERT_TRUE(log.has_orientation);
  ASSERT_TRUE(log.has_position);
  ASSERT_EQ(log.orientation.rows(), 4);
  ASSERT_EQ(log.orientation.cols(), 4);
  EXPECT_EQ(log.position(0, 0), 1e-3);
  EXPECT_TRUE(same_bits(log.orientation.row(0), Eigen::RowVector4d(1, 0, 0, -0.0)));
  EXPECT_TRUE(same_bits(log.orientation.row(1), Eigen::RowVector4d(0.5, -0.5, 0.5, -0.5)));
  const Eigen::RowVector4d off(0.6, 0, 0.8004, 0);
  EXPECT_NEAR(log.orientation.row(2).norm(), 1, 1e-15);
  EXPECT_LT((log.orientation.row(2) - off / off.norm()).norm(), 1e-15);
  EXPECT_TRUE(same_bits(log.orientation.row(3), Eigen::RowVector4d(-1, 0, 0, 0)));
  // Without orientation columns there is no orientation.
  EXPECT_FALSE(parse_log("q1,x,y,z\n0,1,2,3\n", "plain.csv").has_orientation);
}

// R of a rotation vector r = angle * axis by Rodrigues' formula, I + sin(a) K + (1 - cos(a)) K^2
// with K = [axis]x: independent of Eigen's AngleAxis and Quaternion.
Eigen::Matrix3d rodrigues(const Eigen::Vector3d& r) {
  const double angle = r.norm();
  if (angle == 0) return Eigen::Matrix3d::Identity();
  const Eigen::Vector3d u = r / angle;
  Eigen::Matrix3d K;
  K << 0, -u.z(), u.y(), u.z(), 0, -u.x(), -u.y(), u.x(), 0;
  return Eigen::Matrix3d::Identity() + std::sin(angle) * K + (1 - std::cos(angle)) * K * K;
}

// rx, ry, rz in [rad] and [deg]: the unit quaternion of the same rotation (Rodrigues), w >= 0 for
// angles up to pi; the zero vector is the identity.
TEST(LogIo, RotationVectorColumnsBecomeUnitQuaternionsOfTheSameRotation) {
  std::mt19937_64 rng(19);
  std::normal_distribution<double> n;
  std::string rad = "q1,x,y,z,rx,ry[rad],rz\n", deg = "q1,x,y,z,rx[deg],ry[deg],rz[deg]\n";
  std::vector<Eigen::Vector3d> vectors = {Eigen::Vector3d::Zero(), Eigen::Vector3d(1e-9, 0, 0),
                                          Eigen::Vector3d(0, 0, std::numbers::pi),
                                          Eigen::Vector3d(4, -3, 2)};
  for (int k = 0; k < 50; ++k) vectors.emplace_back(n(rng), n(rng), n(rng));
  for (const Eigen::Vector3d& r : vectors) {
    rad += fmt::format("0,0,0,0,{},{},{}\n", r.x(), r.y(), r.z());
    const Eigen::Vector3d r_deg = r * 180 / std::numbers::pi;
    deg += fmt::format("0,0,0,0,{},{},{}\n", r_deg.x(), r_deg.y(), r_deg.z());
  }
  const Log from_rad = parse_log(rad, "rad.csv"), from_deg = parse_log(deg, "deg.csv");
  ASSERT_TRUE(from_rad.has_orientation);
  for (size_t i = 0; i < vectors.size(); ++i) {
    SCOPED_TRACE(i);
    const Eigen::RowVector4d q = from_rad.orientation.row(i);
    EXPECT_NEAR(q.norm(), 1, 4 * std::numeric_limits<double>::epsilon());
    const Eigen::Quaterniond quaternion(q[0], q[1], q[2], q[3]);
    EXPECT_LT((quaternion.toRotationMatrix() - rodrigues(vectors[i])).norm(), 1e-14);
    if (vectors[i].norm() <= std::numbers::pi) {
      EXPECT_GE(q[0], 0);
    }
    EXPECT_LT((from_deg.orientation.row(i) - q).norm(), 1e-14);
  }
  EXPECT_TRUE(same_bits(from_rad.orientation.row(0), Eigen::RowVector4d(1, 0, 0, 0)));
}

// Header errors name the file, line 1 and the field, like an unknown column.
TEST(LogIo, IncompleteOrConflictingOrientationColumnsAreHeaderErrors) {
  const std::string row = "\n0,0,0,0,1,0,0,0\n";
  struct Bad {
    std::string header, key, message;
  };
  const std::vector<Bad> all = {
      {"q1,x,y,z,qw,qx,qy", "qz", "missing: quaternions need all of qw, qx, qy, qz"},
      {"q1,x,y,z,qx,qy,qz", "qw", "missing: quaternions need all of qw, qx, qy, qz"},
      {"q1,x,y,z,rx,ry", "rz", "missing: rotation vectors need all of rx, ry, rz"},
      {"q1,x,y,z,ry,rz", "rx", "missing: rotation vectors need all of rx, ry, rz"},
      {"q1,x,y,z,qw,qx,qy,qz,rx,ry,rz", "rx",
       "an orientation is either qw, qx, qy, qz or rx, ry, rz, not both"},
      {"q1,x,y,z,ry,qw,qx,qy,qz,rx,rz", "qw",
       "an orientation is either qw, qx, qy, qz or rx, ry, rz, not both"},
      {"q1,x,y,z,qw,qx,qy,qz,qx", "qx", "column appears twice"},
      {"q1,x,y,z,rx,ry,rz[deg],rz", "rz", "column appears twice"},
      {"q1,x,y,z,qw[rad],qx,qy,qz", "qw[rad]", "unit 'rad': a quaternion component has no unit"},
      {"q1,x,y,z,qw,qx,qy,qz[m]", "qz[m]", "unit 'm': a quaternion component has no unit"},
      {"q1,x,y,z,rx[mm],ry,rz", "rx[mm]", "unit 'mm' does not fit"},
      {"q1,distance,qw,qx,qy,qz", "x",
       "missing: an orientation needs the position x, y, z (a pose is both)"},
      {"q1,rx,ry,rz", "x", "missing: an orientation needs the position x, y, z (a pose is both)"},
      {"q1,x,y,z,qv", "qv", "unknown column"},
      {"q1,x,y,z,q_w", "q_w", "unknown column"},
      {"q1,x,y,z,rw", "rw", "unknown column"},
  };
  for (const Bad& b : all) {
    SCOPED_TRACE(b.header);
    try {
      parse_log(b.header + row, "pose.csv");
      ADD_FAILURE() << "no error";
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), "pose.csv");
      EXPECT_EQ(e.line(), 1);
      EXPECT_EQ(e.key(), b.key);
      EXPECT_EQ(e.message().substr(0, b.message.size()), b.message) << e.what();
      EXPECT_EQ(std::string(e.what()).rfind("pose.csv:1: " + b.key + ": ", 0), 0u) << e.what();
    }
  }
  // The same rules for a --columns list.
  EXPECT_EQ(log_error("0,0,0,0,1,0,0\n", split_columns("q1,x,y,z,qw,qx,qy")),
            "--columns: qz: missing: quaternions need all of qw, qx, qy, qz");
}

// A quaternion further than 1e-3 from norm 1 is an error naming the file, its line and the
// columns; within 1e-3 it is accepted.
TEST(LogIo, NonUnitQuaternionRowIsAnError) {
  const std::string header = "q1,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n";
  try {
    parse_log(header + "# a comment\n0,0,0,0,0.6,0.8,0,0.065\n", "pose.csv");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 4);
    EXPECT_EQ(e.key(), "qw..qz");
    EXPECT_EQ(std::string(e.what()).rfind("pose.csv:4: qw..qz: not a unit quaternion: norm ", 0),
              0u)
        << e.what();
  }
  EXPECT_NE(log_error(header + "0,0,0,0,0,0,0,0\n").find(":3: qw..qz: not a unit quaternion"),
            std::string::npos);
  EXPECT_NE(log_error(header + "0,0,0,0,1e200,1e200,0,0\n").find(":3: qw..qz: not a unit"),
            std::string::npos);
  EXPECT_NE(log_error(header + "0,0,0,0,0.9989,0,0,0\n").find(":3: qw..qz: not a unit"),
            std::string::npos);
  EXPECT_EQ(log_error(header + "0,0,0,0,0.9991,0,0,0\n"), "");
  EXPECT_EQ(log_error(header + "0,0,0,0,0,0,0,1.0009\n"), "");
  EXPECT_EQ(log_error(header + "0,0,0,0,nan,0,0,0\n"), "pose.csv:3: qw: 'nan' is not finite");
  EXPECT_EQ(log_error("q1,x,y,z,rx,ry,rz\n0,0,0,0,1.5e308,1.5e308,1.5e308\n"),
            "pose.csv:2: rx..rz: the rotation vector is too long to measure");
}

// log_to_csv writes orientation as qw, qx, qy, qz and parse_log reads every number back bit for
// bit: random unit quaternions (normalised in double, so off unit by rounding), exact ones with
// -0, and the quaternions read from rotation vectors and from off-unit columns. A log read from
// any text writes CSV that reads back to the same CSV (what the fuzz targets check).
TEST(LogIo, OrientationRoundTripsBitForBit) {
  std::mt19937_64 rng(20);
  std::normal_distribution<double> n;
  std::uniform_real_distribution<double> off(-1e-3, 1e-3);
  const int rows = 2000;
  Log log;
  log.origin = "written";
  log.rows = rows;
  log.has_position = log.has_orientation = true;
  log.has_ext = {false};
  log.q.setZero(rows, 1);
  log.ext.setZero(rows, 1);
  log.position.resize(rows, 3);
  log.orientation.resize(rows, 4);
  for (int r = 0; r < rows; ++r) {
    log.position.row(r) = Eigen::RowVector3d(n(rng), n(rng), n(rng));
    const Eigen::RowVector4d q(n(rng), n(rng), n(rng), n(rng));
    log.orientation.row(r) = q / q.norm();
  }
  log.orientation.row(0) << -0.0, 1, 0, -0.0;
  log.orientation.row(1) << 0.5, 0.5, -0.5, 0.5;
  const std::string csv = log_to_csv(log);
  EXPECT_EQ(csv.substr(0, csv.find('\n')), "q1,x,y,z,qw,qx,qy,qz");
  const Log back = parse_log(csv, "round-trip.csv");
  ASSERT_TRUE(back.has_orientation);
  EXPECT_TRUE(same_bits(back.orientation, log.orientation));
  EXPECT_TRUE(same_bits(back.position, log.position));

  // Quaternions off unit by up to 1e-3, and rotation vectors: parse -> write -> parse -> write
  // gives the same text both times.
  std::string quaternions = "q1,x,y,z,qw,qx,qy,qz\n", rotations = "q1,x,y,z,rx,ry,rz[deg]\n";
  for (int r = 0; r < rows; ++r) {
    const Eigen::Vector4d q = Eigen::Vector4d(n(rng), n(rng), n(rng), n(rng)).normalized();
    const Eigen::Vector4d q_off = q * (1 + off(rng));
    quaternions += fmt::format("0,0,0,0,{},{},{},{}\n", q_off[0], q_off[1], q_off[2], q_off[3]);
    rotations += fmt::format("0,0,0,0,{},{},{}\n", 3 * n(rng), 3 * n(rng), 200 * n(rng));
  }
  for (const std::string& text : {quaternions, rotations}) {
    const std::string once = log_to_csv(parse_log(text, "text.csv"));
    EXPECT_EQ(log_to_csv(parse_log(once, "once.csv")), once);
  }
}

// A prismatic joint's readings are lengths: q2[mm] is read in metres, and
// check_log_fits refuses an angle unit on a prismatic joint and a length unit on
// a turning one, naming the column (issue 11).
TEST(LogIo, PrismaticReadingsAreLengthsMatchedToTheModel) {
  DeviceModel m;
  m.name = "slider";
  for (int i = 0; i < 2; ++i) {
    Link l;
    l.name = i == 0 ? "turn" : "slide";
    l.type = i == 0 ? JointType::kRevolute : JointType::kPrismatic;
    l.lower = -1;
    l.upper = 1;
    m.links.push_back(l);
  }
  const Log good = parse_log("q1[deg],q2[mm],x,y,z\n90,250,0,0,0\n", "good.csv");
  EXPECT_NEAR(good.q(0, 0), M_PI / 2, 1e-15);
  EXPECT_DOUBLE_EQ(good.q(0, 1), 0.25);
  EXPECT_NO_THROW(check_log_fits(good, m));
  EXPECT_NO_THROW(check_log_fits(parse_log("q1,q2,x,y,z\n0,0.2,0,0,0\n", "si.csv"), m));
  const auto message = [&](const std::string& text) {
    try {
      check_log_fits(parse_log(text, "bad.csv"), m);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message("q1,q2[deg],x,y,z\n0,1,0,0,0\n"),
            "bad.csv:1: q2[deg]: slide is prismatic: its readings are lengths (m, mm, um)");
  EXPECT_EQ(message("q1[m],q2,x,y,z\n0,1,0,0,0\n"),
            "bad.csv:1: q1[m]: turn is a turning joint: its readings are angles (rad, deg)");
  // External encoders too.
  EXPECT_EQ(message("q1,ext1[mm],q2,x,y,z\n0,1,0,0,0,0\n"),
            "bad.csv:1: ext1[mm]: turn is a turning joint: its readings are angles (rad, deg)");
  EXPECT_EQ(message("q1,q2,ext2[deg],x,y,z\n0,0,1,0,0,0\n"),
            "bad.csv:1: ext2[deg]: slide is prismatic: its readings are lengths (m, mm, um)");
}

}  // namespace
}  // namespace hapticcal

namespace hapticcal {
namespace {

// A tree's fixture log names a label a tip (point1 .. pointK): kept tip by
// tip, written back as it was read; numbers that are not 1 .. K, or a label
// beside numbered ones, are refused naming the column.
TEST(LogIo, TreeFixtureLabelsAreNumberedATip) {
  const Log log = parse_log("q1,q2,point2,point1\n0.1,0.2,R1,L1\n0.3,0.4,R2,L1\n", "hands.csv");
  ASSERT_TRUE(log.has_point);
  EXPECT_EQ(log.label, (std::vector<std::string>{"L1,R1", "L1,R2"}));
  const Log back = parse_log(log_to_csv(log), "back.csv");
  EXPECT_EQ(back.label, log.label);
  EXPECT_NE(log_to_csv(log).find("point1,point2"), std::string::npos);
  auto refused = [](const std::string& header, const std::string& why) {
    try {
      parse_log(header + "\n0.1,0.2,A,B\n", "hands.csv");
      ADD_FAILURE() << "accepted: " << header;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
    }
  };
  refused("q1,q2,point1,point3",
          "2 label columns: a chain's is 'point', a tree's point1 .. point2");
  refused("q1,q2,point,point1", "a tree's point1 .. point2");
  refused("q1,q2,point0,point1", "tip numbers start at 1");
  refused("q1,q2,point2,_", "1 label columns: a chain's is 'point'");
  refused("q1,q2,point1,plane2", "fixture points or plane contacts, not both");
}

}  // namespace
}  // namespace hapticcal
