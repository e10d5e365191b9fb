// CSV logs: headers, units, --columns, comments.
#include <gtest/gtest.h>

#include <numbers>

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

}  // namespace
}  // namespace hapticcal
