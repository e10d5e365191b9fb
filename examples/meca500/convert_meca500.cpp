// Converts the Meca500 laser-tracker data set (data/real/meca500, see its
// README) into a hapticcal device file and header-carrying logs:
//   convert_meca500 SOURCE_DIR OUTPUT_DIR
// The device: modified DH from mdh_nominal.csv (mm -> m) in the robot's own base
// frame, tool point from T_tool.txt (flange <- SMR). The tracker's placement
// (T_base.txt) is the measurement set-up, not the robot: calibrate finds it by
// registration and writes it to its setup.yaml.
#include <fmt/format.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <numbers>
#include <sstream>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/model/frame.hpp"
#include "hapticcal/model_io/device.hpp"

namespace {

Eigen::Matrix4d read_matrix(const std::string& path) {
  std::istringstream in(hapticcal::read_file(path));
  Eigen::Matrix4d T;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) {
      if (!(in >> T(r, c))) throw hapticcal::InputError(path, r + 1, "", "expected 4x4 numbers");
    }
  }
  return T;
}

// Meca500 R3 joint ranges (Mecademic's published specification), degrees.
constexpr double kLimitsDeg[6][2] = {{-175, 175}, {-70, 90},   {-135, 70},
                                     {-170, 170}, {-115, 115}, {-180, 180}};

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: convert_meca500 SOURCE_DIR OUTPUT_DIR\n";
    return 2;
  }
  namespace fs = std::filesystem;
  const fs::path source = argv[1], output = argv[2];
  try {
    hapticcal::DeviceModel model;
    model.name = "meca500";
    model.base_kind = hapticcal::BaseKind::kPose;
    model.base = {0, 0, 0, 0, 0, 0};
    const Eigen::Matrix4d T_tool = read_matrix(source / "T_tool.txt");
    const Eigen::Vector3d tool_rpy = hapticcal::matrix_rpy(T_tool.topLeftCorner<3, 3>());
    model.tool = {T_tool(0, 3) / 1000, T_tool(1, 3) / 1000, T_tool(2, 3) / 1000,
                  tool_rpy[0],         tool_rpy[1],         tool_rpy[2]};

    // alpha [rad], a [mm], theta_offset [rad], d [mm], one row per joint.
    const hapticcal::Log table = hapticcal::read_log(
        source / "mdh_nominal.csv", {"q1", "q2", "q3", "q4"});  // four plain numbers per row
    if (table.rows != 6)
      throw hapticcal::InputError(source / "mdh_nominal.csv", 0, "", "expected 6 rows");
    for (int i = 0; i < 6; ++i) {
      hapticcal::Link link;
      link.name = fmt::format("j{}", i + 1);
      link.geometry = hapticcal::Geometry::kMdh;
      link.alpha = table.q(i, 0);
      link.a = table.q(i, 1) / 1000;
      link.theta = table.q(i, 2);
      link.d = table.q(i, 3) / 1000;
      link.lower = kLimitsDeg[i][0] * std::numbers::pi / 180;
      link.upper = kLimitsDeg[i][1] * std::numbers::pi / 180;
      model.links.push_back(link);
    }
    hapticcal::save_device(model, (output / "meca500.yaml").string());

    const std::string header = "q1[deg],q2[deg],q3[deg],q4[deg],q5[deg],q6[deg],x,y,z,_,_,_\n";
    for (const auto& entry : fs::directory_iterator(source)) {
      const std::string name = entry.path().filename().string();
      if (!(name.starts_with("cal-") || name.starts_with("val-"))) continue;
      hapticcal::write_file_atomically((output / name).string(),
                                       header + hapticcal::read_file(entry.path().string()));
    }
  } catch (const hapticcal::InputError& e) {
    std::cerr << "convert_meca500: " << e.what() << "\n";
    return 2;
  }
  return 0;
}
