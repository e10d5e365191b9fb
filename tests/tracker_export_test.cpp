// Trackers' CSV exports (Motive, Vicon Nexus, a generic CSV with a column map)
// against files written by an independent writer (tests/writers/
// write_tracker_exports.py, from the trackers' documentation) together with the
// truth they were written from: every sample, the lost ones, the units; and
// damaged files: each refused by an InputError naming the file, line and column.
#include "hapticcal/recording/tracker_export.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "hapticcal/core/error.hpp"
#include "run_cli.hpp"

namespace hapticcal::recording {
namespace {

using hapticcal::testing::fresh_folder;
using hapticcal::testing::run_program;
using hapticcal::testing::slurp;

// One row of the writer's truth.csv; a lost sample has no value.
struct TruthRow {
  double t = 0;
  std::optional<std::array<double, 3>> p;
  std::optional<std::array<double, 4>> q;
  std::array<std::optional<std::array<double, 3>>, 3> markers;
};

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream in(line);
  std::string f;
  while (std::getline(in, f, ',')) out.push_back(f);
  if (!line.empty() && line.back() == ',') out.emplace_back();
  return out;
}

template <std::size_t N>
std::optional<std::array<double, N>> values(const std::vector<std::string>& f, std::size_t from) {
  if (f.at(from).empty()) return std::nullopt;
  std::array<double, N> v{};
  for (std::size_t k = 0; k < N; ++k) v[k] = std::strtod(f.at(from + k).c_str(), nullptr);
  return v;
}

class TrackerExport : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fresh_folder("tracker_export");
    const auto r = run_program(
        HAPTICCAL_DEBIAN_PYTHON,
        {std::string(HAPTICCAL_SOURCE_DIR) + "/tests/writers/write_tracker_exports.py", dir_});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    std::stringstream in(slurp(dir_ + "/truth.csv"));
    std::string line;
    std::getline(in, line);  // header
    while (std::getline(in, line)) {
      const auto f = split(line);
      TruthRow row;
      row.t = std::strtod(f.at(1).c_str(), nullptr);
      row.p = values<3>(f, 2);
      row.q = values<4>(f, 5);
      for (std::size_t k = 0; k < 3; ++k) row.markers[k] = values<3>(f, 9 + 3 * k);
      truth_.push_back(row);
    }
  }

  static std::string text(const std::string& file) { return slurp(dir_ + "/" + file); }

  // The pose stream against the truth: every sample the tracker kept, in order.
  static void expect_pose(const TrackerStream& s, double q_tolerance) {
    std::size_t i = 0, lost = 0;
    for (const TruthRow& row : truth_) {
      if (!row.p) {
        ++lost;
        continue;
      }
      ASSERT_LT(i, s.t.size());
      EXPECT_NEAR(s.t[i], row.t, 1e-12) << "sample " << i;
      for (std::size_t k = 0; k < 3; ++k) EXPECT_NEAR(s.p[i][k], (*row.p)[k], 1e-12) << i;
      // Up to sign: q and -q are one rotation.
      const double sign = s.q[i][0] * (*row.q)[0] + s.q[i][1] * (*row.q)[1] +
                                      s.q[i][2] * (*row.q)[2] + s.q[i][3] * (*row.q)[3] <
                                  0
                              ? -1
                              : 1;
      for (std::size_t k = 0; k < 4; ++k) {
        EXPECT_NEAR(sign * s.q[i][k], (*row.q)[k], q_tolerance) << "sample " << i;
      }
      ++i;
    }
    EXPECT_EQ(s.t.size(), i);
    EXPECT_EQ(s.p.size(), i);
    EXPECT_EQ(s.q.size(), i);
    EXPECT_TRUE(s.markers.empty());
    EXPECT_EQ(s.lost, lost);
    EXPECT_EQ(lost, 7u);  // the writer's occluded frames
  }

  static void expect_markers(const TrackerStream& s) {
    std::size_t i = 0, lost = 0;
    for (const TruthRow& row : truth_) {
      if (!row.markers[0] || !row.markers[1] || !row.markers[2]) {
        ++lost;
        continue;
      }
      ASSERT_LT(i, s.t.size());
      EXPECT_NEAR(s.t[i], row.t, 1e-12);
      ASSERT_EQ(s.markers[i].size(), 3u);
      for (std::size_t m = 0; m < 3; ++m) {
        for (std::size_t k = 0; k < 3; ++k) {
          EXPECT_NEAR(s.markers[i][m][k], (*row.markers[m])[k], 1e-12) << i << " " << m;
        }
      }
      ++i;
    }
    EXPECT_EQ(s.t.size(), i);
    EXPECT_EQ(s.markers.size(), i);
    EXPECT_TRUE(s.p.empty());
    EXPECT_TRUE(s.q.empty());
    EXPECT_EQ(s.lost, lost);
    EXPECT_EQ(lost, 12u);  // 7 frames without the body, 5 without marker 2
  }

  static std::string dir_;
  static std::vector<TruthRow> truth_;
};

std::string TrackerExport::dir_;
std::vector<TruthRow> TrackerExport::truth_;

TrackerExportOptions body(const std::string& name) {
  TrackerExportOptions o;
  o.body = name;
  return o;
}

// `read` fails with an InputError whose message begins with `where` ("file:line:
// column N") and holds `what`.
void expect_error(const std::function<void()>& read, const std::string& where,
                  const std::string& what) {
  try {
    read();
    ADD_FAILURE() << "no error; expected " << where << " ... " << what;
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind(where, 0), 0u) << message;
    EXPECT_NE(message.find(what), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
}

// Line `n` (1-based) of `text`, its fields.
std::vector<std::string> fields_of_line(const std::string& text, int n) {
  std::stringstream in(text);
  std::string line;
  for (int k = 0; k < n; ++k) std::getline(in, line);
  return split(line);
}

// The byte offset where line `n` (1-based) starts.
std::size_t line_start(const std::string& text, int n) {
  std::size_t pos = 0;
  for (int k = 1; k < n; ++k) pos = text.find('\n', pos) + 1;
  return pos;
}

// `text` with field `column` (0-based) of line `n` replaced by `value`.
std::string with_field(const std::string& text, int n, std::size_t column,
                       const std::string& value) {
  const std::size_t start = line_start(text, n), end = text.find('\n', start);
  auto f = split(text.substr(start, end - start));
  f.at(column) = value;
  std::string line;
  for (std::size_t k = 0; k < f.size(); ++k) line += (k ? "," : "") + f[k];
  return text.substr(0, start) + line + text.substr(end);
}

TEST_F(TrackerExport, TellsTheFormatsApart) {
  EXPECT_EQ(tracker_export_format(text("motive_quat_mm.csv")), "Motive");
  EXPECT_EQ(tracker_export_format(text("vicon_nexus.csv")), "Vicon");
  EXPECT_EQ(tracker_export_format(text("generic.csv")), "CSV");
  EXPECT_EQ(tracker_export_format(""), "CSV");
}

TEST_F(TrackerExport, MotiveQuaternionInMillimetresMatchesTheTruth) {
  const auto s = read_motive_csv(text("motive_quat_mm.csv"), "motive_quat_mm.csv", body("stylus"));
  expect_pose(s, 1e-12);
  EXPECT_NE(s.source.find("Motive CSV 1.23, rigid body 'stylus'"), std::string::npos) << s.source;
}

TEST_F(TrackerExport, MotiveInMetresGivesTheSameStream) {
  const auto m = read_motive_csv(text("motive_quat_m.csv"), "motive_quat_m.csv", body("stylus"));
  expect_pose(m, 1e-12);
  const auto mm = read_motive_csv(text("motive_quat_mm.csv"), "mm.csv", body("stylus"));
  ASSERT_EQ(m.t.size(), mm.t.size());
  for (std::size_t i = 0; i < m.t.size(); ++i) {
    EXPECT_EQ(m.t[i], mm.t[i]);
    for (std::size_t k = 0; k < 3; ++k) EXPECT_NEAR(m.p[i][k], mm.p[i][k], 1e-12);
  }
}

TEST_F(TrackerExport, MotiveEulerAnglesInEitherOrderMatchTheTruth) {
  for (const char* file : {"motive_euler_xyz.csv", "motive_euler_zyx.csv"}) {
    SCOPED_TRACE(file);
    expect_pose(read_motive_csv(text(file), file, body("stylus")), 1e-9);
  }
}

TEST_F(TrackerExport, MotiveMarkersAreTheMeasuredOnesNotTheRigidBodysExpectedOnes) {
  TrackerExportOptions o;
  o.markers = {"Marker1", "Marker2", "Marker3"};
  const auto s = read_motive_csv(text("motive_quat_mm.csv"), "m.csv", o);
  expect_markers(s);
  EXPECT_EQ(s.marker_names,
            (std::vector<std::string>{"stylus:Marker1", "stylus:Marker2", "stylus:Marker3"}));
}

TEST_F(TrackerExport, ViconSegmentAndTrajectoriesMatchTheTruth) {
  const auto pose = read_vicon_csv(text("vicon_nexus.csv"), "v.csv", body("stylus"));
  expect_pose(pose, 1e-12);
  EXPECT_NE(pose.source.find("Segments 'Subject:stylus'"), std::string::npos) << pose.source;
  TrackerExportOptions o;
  o.markers = {"Marker1", "Marker2", "Marker3"};
  expect_markers(read_vicon_csv(text("vicon_nexus.csv"), "v.csv", o));
}

TEST_F(TrackerExport, MotiveAndViconGiveTheSameStream) {
  const auto motive = read_motive_csv(text("motive_quat_mm.csv"), "m.csv", body("stylus"));
  const auto vicon = read_vicon_csv(text("vicon_nexus.csv"), "v.csv", body("Subject:stylus"));
  ASSERT_EQ(motive.t.size(), vicon.t.size());
  EXPECT_EQ(motive.lost, vicon.lost);
  for (std::size_t i = 0; i < motive.t.size(); ++i) {
    EXPECT_EQ(motive.t[i], vicon.t[i]);  // both frame / 120 Hz, the one as printed
    for (std::size_t k = 0; k < 3; ++k) EXPECT_NEAR(motive.p[i][k], vicon.p[i][k], 1e-12);
    double dot = 0;
    for (std::size_t k = 0; k < 4; ++k) dot += motive.q[i][k] * vicon.q[i][k];
    EXPECT_NEAR(std::abs(dot), 1, 1e-12);
  }
}

TEST_F(TrackerExport, GenericCsvTakesItsUnitsFromTheHeader) {
  TrackerExportOptions o;
  o.column_map = "t=Time,x=PosX,y=PosY,z=PosZ,qw=QW,qx=QX,qy=QY,qz=QZ";
  expect_pose(read_generic_csv(text("generic.csv"), "g.csv", o), 1e-12);
  o.column_map = "t=Time,x1=M1X,y1=M1Y,z1=M1Z,x2=M2X,y2=M2Y,z2=M2Z,x3=M3X,y3=M3Y,z3=M3Z";
  const auto s = read_generic_csv(text("generic.csv"), "g.csv", o);
  expect_markers(s);
  EXPECT_EQ(s.marker_names, (std::vector<std::string>{"M1X", "M2X", "M3X"}));
}

TEST_F(TrackerExport, GenericCsvWithoutUnitsNeedsThemGiven) {
  TrackerExportOptions o;
  o.column_map = "t=time,x=px,y=py,z=pz,rx[rad]=rx,ry[rad]=ry,rz[rad]=rz";
  expect_error([&] { read_generic_csv(text("generic_plain.csv"), "p.csv", o); },
               "p.csv:2: column 2: ", "states no time unit: give --time-unit");
  o.time_unit = "s";
  expect_error([&] { read_generic_csv(text("generic_plain.csv"), "p.csv", o); },
               "p.csv:2: column 3: ", "states no length unit: give --length-unit");
  o.length_unit = "m";
  expect_pose(read_generic_csv(text("generic_plain.csv"), "p.csv", o), 1e-12);
  o.column_map = "t=time,x=px,y=py,z=pz,rx=rx,ry=ry,rz=rz";  // no angle unit anywhere
  expect_error([&] { read_generic_csv(text("generic_plain.csv"), "p.csv", o); },
               "p.csv:2: column 6: ", "states no angle unit");
}

TEST_F(TrackerExport, ReadsFilesByTheirFormat) {
  const auto s = read_tracker_export(dir_ + "/motive_quat_m.csv", body("stylus"));
  expect_pose(s, 1e-12);
  expect_error([&] { read_tracker_export(dir_ + "/generic.csv", {}); }, dir_ + "/generic.csv:1",
               "give --column-map");
  TrackerExportOptions o = body("stylus");
  o.column_map = "t=Time";
  expect_error([&] { read_tracker_export(dir_ + "/vicon_nexus.csv", o); },
               dir_ + "/vicon_nexus.csv: --column-map", "a Vicon export");
}

TEST_F(TrackerExport, UnknownAndConflictingUnitsAreRefused) {
  const std::string mm = text("motive_quat_mm.csv");
  const auto info = fields_of_line(mm, 1);
  const std::size_t units =
      std::find(info.begin(), info.end(), "Length Units") - info.begin() + 2;  // its value, 1-based
  ASSERT_EQ(info.at(units - 1), "Millimeters");
  std::string furlongs = mm;
  furlongs.replace(furlongs.find("Millimeters"), 11, "Furlongs");
  expect_error([&] { read_motive_csv(furlongs, "m.csv", body("stylus")); },
               "m.csv:1: column " + std::to_string(units) + ": ", "unknown length unit 'Furlongs'");
  TrackerExportOptions o = body("stylus");
  o.length_unit = "m";
  expect_error([&] { read_motive_csv(mm, "m.csv", o); },
               "m.csv:1: column " + std::to_string(units) + ": ",
               "the file's length unit is 'Millimeters', --length-unit m disagrees");
  o.length_unit = "mm";  // agreeing is fine
  expect_pose(read_motive_csv(mm, "m.csv", o), 1e-12);
  // Vicon: the units row (line 211) of the Segments section.
  const std::string vicon = text("vicon_nexus.csv");
  ASSERT_EQ(fields_of_line(vicon, 211).at(11), "mm");
  expect_error([&] { read_vicon_csv(with_field(vicon, 211, 11, "yd"), "v.csv", body("stylus")); },
               "v.csv:211: column 12: ", "unknown length unit 'yd'");
  TrackerExportOptions g;
  g.column_map = "t=Time,x=PosX,y=PosY,z=PosZ";
  g.time_unit = "s";
  expect_error([&] { read_generic_csv(text("generic.csv"), "g.csv", g); },
               "g.csv:2: column 2: ", "the file's time unit is 'ms', --time-unit s disagrees");
}

TEST_F(TrackerExport, MissingColumnsAreNamed) {
  TrackerExportOptions o;
  o.column_map = "t=Time,x=PosX,y=PosY,z=PosW";
  expect_error([&] { read_generic_csv(text("generic.csv"), "g.csv", o); },
               "g.csv:2: column 'PosW': ",
               "no such column in the header (z= of --column-map) "
               "(did you mean 'PosX'?)");
  // A Motive rigid body without its Position Z column.
  const std::string mm = text("motive_quat_mm.csv");
  expect_error([&] { read_motive_csv(with_field(mm, 7, 16, "Q"), "m.csv", body("stylus")); },
               "m.csv:7: column 'Position Z': ", "rigid body 'stylus' has no Position Z column");
  expect_error([&] { read_motive_csv(mm, "m.csv", body("wand")); }, "m.csv:7: rigid body 'wand'",
               "no such rigid body (the file has 'base', 'stylus')");
}

TEST_F(TrackerExport, NonNumericFieldsNameTheirLineAndColumn) {
  const std::string mm = text("motive_quat_mm.csv");
  expect_error([&] { read_motive_csv(with_field(mm, 40, 14, "1.5e"), "m.csv", body("stylus")); },
               "m.csv:40: column 15: ", "value '1.5e' is not a number");
  const std::string vicon = text("vicon_nexus.csv");
  ASSERT_EQ(fields_of_line(vicon, 220).at(0), "9");
  expect_error([&] { read_vicon_csv(with_field(vicon, 220, 0, "9x"), "v.csv", body("stylus")); },
               "v.csv:220: column 1: ", "frame '9x' is not a number");
  expect_error([&] { read_vicon_csv(with_field(vicon, 220, 1, "3"), "v.csv", body("stylus")); },
               "v.csv:220: column 2: ", "sub frame 3");
}

TEST_F(TrackerExport, TimeMustIncrease) {
  const std::string g = text("generic.csv");
  TrackerExportOptions o;
  o.column_map = "t=Time,x=PosX,y=PosY,z=PosZ";
  const std::string earlier = fields_of_line(g, 20).at(1);
  expect_error([&] { read_generic_csv(with_field(g, 21, 1, earlier), "g.csv", o); },
               "g.csv:21: column 2: ", "is not after the previous sample's");
  expect_error([&] { read_generic_csv(with_field(g, 30, 1, "1.0"), "g.csv", o); },
               "g.csv:30: column 2: ", "(line 29)");
  const std::string mm = text("motive_quat_mm.csv");
  expect_error([&] { read_motive_csv(with_field(mm, 9, 1, "0"), "m.csv", body("stylus")); },
               "m.csv:9: column 2: ", "time 0 s is not after");
}

TEST_F(TrackerExport, SeveralBodiesAndNoneChosenAreListed) {
  expect_error([&] { read_motive_csv(text("motive_quat_mm.csv"), "m.csv", {}); },
               "m.csv:7: column 1: ", "2 rigid bodies: 'base', 'stylus': give --body NAME");
  expect_error(
      [&] { read_vicon_csv(text("vicon_nexus.csv"), "v.csv", {}); },
      "v.csv:207: column 1: ", "2 segments: 'Subject:base', 'Subject:stylus': give --body NAME");
}

TEST_F(TrackerExport, PartlyFilledSamplesAreLost) {
  const std::string g = text("generic.csv");
  TrackerExportOptions o;
  o.column_map = "t=Time,x=PosX,y=PosY,z=PosZ,qw=QW,qx=QX,qy=QY,qz=QZ";
  const auto whole = read_generic_csv(g, "g.csv", o);
  ASSERT_FALSE(fields_of_line(g, 50).at(3).empty());
  const auto cut = read_generic_csv(with_field(g, 50, 3, ""), "g.csv", o);
  EXPECT_EQ(cut.lost, whole.lost + 1);
  EXPECT_EQ(cut.t.size(), whole.t.size() - 1);
  const double t = std::strtod(fields_of_line(g, 50).at(1).c_str(), nullptr) / 1000;
  EXPECT_EQ(
      std::count_if(cut.t.begin(), cut.t.end(), [&](double v) { return std::abs(v - t) < 1e-9; }),
      0);
}

TEST_F(TrackerExport, QuaternionsFarFromUnitAreRefused) {
  const std::string mm = text("motive_quat_mm.csv");
  ASSERT_EQ(fields_of_line(mm, 7).at(13), "W");
  expect_error([&] { read_motive_csv(with_field(mm, 12, 13, "0.5"), "m.csv", body("stylus")); },
               "m.csv:12: column 11: ", "a quaternion of norm");
  std::string matrix = mm;
  matrix.replace(matrix.find("Quaternion"), 10, "Matrix");
  expect_error([&] { read_motive_csv(matrix, "m.csv", body("stylus")); },
               "m.csv:1: column 20: ", "Rotation Type 'Matrix' is not read");
}

TEST_F(TrackerExport, TruncatedFilesAreRefusedWhereTheyEnd) {
  const std::string mm = text("motive_quat_mm.csv");
  // Inside the header's Name row (line 4): no "Frame" row follows.
  for (const std::size_t into : {std::size_t{1}, std::size_t{30}, std::size_t{200}}) {
    expect_error([&] { read_motive_csv(mm.substr(0, line_start(mm, 4) + into), "m.csv", {}); },
                 "m.csv:5: column 1: ", "the file ends in its header");
  }
  // Inside a data row: fewer fields than the header.
  const std::size_t row = line_start(mm, 60), width = fields_of_line(mm, 7).size();
  for (const std::size_t into :
       {std::size_t{1}, std::size_t{3}, std::size_t{57}, std::size_t{400}}) {
    const std::string cut = mm.substr(0, row + into);
    const std::size_t n = split(cut.substr(row)).size();
    ASSERT_LT(n, width);
    expect_error([&] { read_motive_csv(cut, "m.csv", body("stylus")); },
                 "m.csv:60: column " + std::to_string(n + 1) + ": ", "a row cut short");
  }
  // Vicon: inside the Segments section's labels row (line 210) and one of its rows.
  const std::string vicon = text("vicon_nexus.csv");
  expect_error([&] { read_vicon_csv(vicon.substr(0, line_start(vicon, 210) + 12), "v.csv", {}); },
               "v.csv:210: column 2: ", "not the row \"Frame,Sub Frame,...\"");
  expect_error([&] { read_vicon_csv(vicon.substr(0, line_start(vicon, 209) + 5), "v.csv", {}); },
               "v.csv:210: column 1: ", "the file ends in the header of section 'Segments'");
  const std::string cut = vicon.substr(0, line_start(vicon, 250) + 20);
  expect_error(
      [&] { read_vicon_csv(cut, "v.csv", body("stylus")); },
      "v.csv:250: column " + std::to_string(split(cut.substr(line_start(vicon, 250))).size() + 1),
      "a row cut short");
}

// A header that says two things: the last word must not win silently.
TEST_F(TrackerExport, MotiveHeaderContradictingItselfIsRefused) {
  const std::string mm = text("motive_quat_mm.csv");
  const std::size_t eol = mm.find('\n');
  ASSERT_EQ(fields_of_line(mm, 1).size(), 24u);
  // Length Units twice (Millimeters in column 22): the data are not 1000 times larger.
  const std::string twice = mm.substr(0, eol) + ",Length Units,Meters" + mm.substr(eol);
  expect_error([&] { read_motive_csv(twice, "m.csv", body("stylus")); }, "m.csv:1: column 26: ",
               "'Length Units' is given twice: 'Millimeters' (column 22) and 'Meters'");
  // The same value twice says one thing.
  const std::string agreeing = mm.substr(0, eol) + ",Length Units,Millimeters" + mm.substr(eol);
  expect_pose(read_motive_csv(agreeing, "m.csv", body("stylus")), 1e-12);
  // A second Name row that names other bodies.
  const std::size_t name_row = line_start(mm, 4), id_row = line_start(mm, 5);
  std::string names = mm.substr(name_row, id_row - name_row);
  names.replace(names.find("stylus"), 6, "wand00");
  const std::string rows = mm.substr(0, id_row) + names + mm.substr(id_row);
  expect_error([&] { read_motive_csv(rows, "m.csv", body("stylus")); },
               "m.csv:5: column 1: ", "a second \"Name\" header row, unlike line 4's");
}

// Euler angles stated above a quaternion's columns: X, Y, Z are not angles.
TEST_F(TrackerExport, MotiveRotationTypeMustMatchTheColumns) {
  std::string euler = text("motive_quat_mm.csv");
  euler.replace(euler.find("Quaternion"), 10, "XYZ");
  ASSERT_EQ(fields_of_line(euler, 7).at(13), "W");
  expect_error([&] { read_motive_csv(euler, "m.csv", body("stylus")); }, "m.csv:7: column 14: ",
               "rigid body 'stylus' has a Rotation W column, a quaternion's, but the first line "
               "states Rotation Type 'XYZ'");
  // A quaternion stated above Euler angles' columns: no W.
  std::string quaternion = text("motive_euler_xyz.csv");
  quaternion.replace(quaternion.find(",XYZ,"), 5, ",Quaternion,");
  expect_error([&] { read_motive_csv(quaternion, "m.csv", body("stylus")); },
               "m.csv:7: column 'Rotation W': ", "rigid body 'stylus' has no Rotation W column");
}

TEST_F(TrackerExport, EverySampleLostIsRefusedSayingWhy) {
  TrackerExportOptions o;
  o.column_map = "t=t,x=x,y=y,z=z";
  const std::string never_seen = "t [s],x [m],y [m],z [m]\n0.00,,,\n0.01,0.1,,0.2\n0.02,,,\n";
  expect_error([&] { read_generic_csv(never_seen, "g.csv", o); }, "g.csv:2: column 2: ",
               "all 3 samples lost: every row has an empty field among the columns read");
  // On the command line: exit 2, one line, and no empty tracker.csv written.
  const std::string dir = fresh_folder("tracker_export_lost");
  std::ofstream(dir + "/lost.csv") << never_seen;
  const auto c = hapticcal::testing::run_cli({"import", "--tracker-export", dir + "/lost.csv",
                                              "--column-map", o.column_map, "--out", dir + "/out"});
  EXPECT_EQ(c.exit_code, 2);
  EXPECT_NE(c.err.find("lost.csv:2: column 2: all 3 samples lost"), std::string::npos) << c.err;
  EXPECT_FALSE(std::filesystem::exists(dir + "/out"));
  // Motive: a marker the tracker never saw (its columns blank in every frame).
  std::string mm = text("motive_quat_mm.csv");
  const std::vector<std::string> comps = fields_of_line(mm, 7);
  std::string cut;
  std::stringstream in(mm);
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (n > 7 && !line.empty()) {
      auto f = split(line);
      for (std::size_t c = comps.size() - 3; c < comps.size(); ++c) f.at(c).clear();
      line.clear();
      for (std::size_t k = 0; k < f.size(); ++k) line += (k ? "," : "") + f[k];
    }
    cut += line + "\n";
  }
  TrackerExportOptions m;
  m.markers = {"Marker3"};
  expect_error([&] { read_motive_csv(cut, "m.csv", m); },
               "m.csv:8: column " + std::to_string(comps.size() - 2) + ": ",
               "all 300 samples lost");
}

TEST_F(TrackerExport, AMarkerNamedTwiceIsRefused) {
  TrackerExportOptions o;
  o.markers = {"Marker1", "Marker2", "Marker1"};
  expect_error([&] { read_motive_csv(text("motive_quat_mm.csv"), "m.csv", o); },
               "m.csv: --markers: ", "'Marker1' is named twice");
  expect_error([&] { read_vicon_csv(text("vicon_nexus.csv"), "v.csv", o); },
               "v.csv: --markers: ", "'Marker1' is named twice");
  o.markers = {"Marker1", "stylus:Marker1"};
  expect_error(
      [&] { read_motive_csv(text("motive_quat_mm.csv"), "m.csv", o); },
      "m.csv: --markers: ", "'Marker1' and 'stylus:Marker1' are one marker, 'stylus:Marker1'");
  TrackerExportOptions g;
  g.column_map = "t=Time,x1=M1X,y1=M1Y,z1=M1Z,x2=M1X,y2=M2Y,z2=M2Z";
  expect_error([&] { read_generic_csv(text("generic.csv"), "g.csv", g); },
               "g.csv: --column-map: ", "column 'M1X' given for both x1 and x2");
}

TEST_F(TrackerExport, ViconFrameRateOutsideATrackersIsRefused) {
  const std::string vicon = text("vicon_nexus.csv");
  ASSERT_EQ(fields_of_line(vicon, 207).at(0), "Segments");
  ASSERT_EQ(fields_of_line(vicon, 208).at(0), "120");
  for (const char* rate : {"1e-300", "0.1", "0", "-120", "100001"}) {
    SCOPED_TRACE(rate);
    expect_error([&] { read_vicon_csv(with_field(vicon, 208, 0, rate), "v.csv", body("stylus")); },
                 "v.csv:208: column 1: ", "a tracker's lies in (0.1, 100000] Hz");
  }
  // The bounds' insides are read: 100 kHz is a rate, if an unusual one.
  const auto fast = read_vicon_csv(with_field(vicon, 208, 0, "100000"), "v.csv", body("stylus"));
  const auto usual = read_vicon_csv(vicon, "v.csv", body("stylus"));
  ASSERT_EQ(fast.t.size(), usual.t.size());
  for (std::size_t i = 0; i < fast.t.size(); ++i)
    EXPECT_NEAR(fast.t[i], usual.t[i] * 120 / 1e5, 1e-15);
}

// Exports saved with old Mac line endings (a lone CR) or Windows' (CR LF).
TEST_F(TrackerExport, LineEndingsOfEverySystemAreRead) {
  const std::string mm = text("motive_quat_mm.csv");
  std::string cr = mm, crlf;
  std::replace(cr.begin(), cr.end(), '\n', '\r');
  for (const char c : mm) crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
  EXPECT_EQ(tracker_export_format(cr), "Motive");
  expect_pose(read_motive_csv(cr, "cr.csv", body("stylus")), 1e-12);
  expect_pose(read_motive_csv(crlf, "crlf.csv", body("stylus")), 1e-12);
  // Lines are counted as their endings say.
  expect_error([&] { read_motive_csv(with_field(mm, 40, 14, "1.5e"), "m.csv", body("stylus")); },
               "m.csv:40: column 15: ", "is not a number");
  std::string bad = with_field(mm, 40, 14, "1.5e");
  std::replace(bad.begin(), bad.end(), '\n', '\r');
  expect_error([&] { read_motive_csv(bad, "cr.csv", body("stylus")); },
               "cr.csv:40: column 15: ", "is not a number");
  std::string vicon = text("vicon_nexus.csv");
  std::replace(vicon.begin(), vicon.end(), '\n', '\r');
  expect_pose(read_vicon_csv(vicon, "v.csv", body("stylus")), 1e-12);
}

TEST(TrackerExportBounds, LongLinesAndWideRowsAreRefused) {
  TrackerExportOptions o;
  o.column_map = "t=t,x=x,y=y,z=z";
  o.length_unit = "m";
  o.time_unit = "s";
  const std::string wide = "t,x,y,z" + std::string(5000, ',') + "\n";
  expect_error([&] { read_generic_csv(wide, "w.csv", o); },
               "w.csv:1: column 4097: ", "5004 fields: an export has at most 4096 columns");
  const std::string longline = "t,x,y,z\n1,2,3," + std::string(std::size_t{1} << 20, '4') + "\n";
  expect_error([&] { read_generic_csv(longline, "l.csv", o); },
               "l.csv:2: column 1: ", "at most 1048576 (1 MiB)");
  expect_error([&] { read_generic_csv("t,x,y,z\n", "e.csv", o); },
               "e.csv:2: column 1: ", "no data rows");
}

}  // namespace
}  // namespace hapticcal::recording
