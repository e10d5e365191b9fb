#include "hapticcal/recording/recording.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <vector>

#include "hapticcal/core/error.hpp"

namespace hapticcal::recording {
namespace {

// A rosbag2 folder (metadata.yaml beside its storage files): its one .db3 or
// .mcap file. A split bag (several) is refused naming them.
std::string storage_file(const std::string& folder) {
  std::vector<std::string> found;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(folder, ec)) {
    const std::string ext = entry.path().extension().string();
    if (entry.is_regular_file() && (ext == ".db3" || ext == ".mcap" || ext == ".bag"))
      found.push_back(entry.path().string());
  }
  if (ec) throw InputError(folder, 0, "", "cannot list the folder: " + ec.message());
  std::sort(found.begin(), found.end());
  if (found.empty()) throw InputError(folder, 0, "", "a folder without a .db3, .mcap or .bag file");
  if (found.size() > 1)
    throw InputError(folder, 0, "",
                     fmt::format("a bag split into {} files ({}, ...): give one file", found.size(),
                                 printable(found[0], 200)));
  return found[0];
}

std::string resolved(const std::string& path) {
  std::error_code ec;
  return std::filesystem::is_directory(path, ec) ? storage_file(path) : path;
}

std::string format_of(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, "", "cannot open the file");
  char head[16] = {};
  in.read(head, sizeof head);
  const std::string_view start(head, static_cast<std::size_t>(in.gcount()));
  if (start.starts_with("#ROSBAG V2.0\n")) return "ROS 1 bag";
  if (start.starts_with("#ROSBAG V"))
    throw InputError(path, 0, "", "a ROS 1 bag of a format other than 2.0");
  if (start.starts_with("\x89MCAP0\r\n")) return "MCAP";
  if (start.starts_with(std::string_view("SQLite format 3\0", 16))) return "rosbag2 sqlite3";
  throw InputError(
      path, 0, "",
      "not a recording hapticcal reads (a ROS 1 bag 2.0, an MCAP file or a rosbag2 .db3; "
      "a tracker's CSV export is read by `import --tracker-export`)");
}

}  // namespace

std::string recording_format(const std::string& path) { return format_of(resolved(path)); }

void read_recording(const std::string& path, RecordingVisitor& visitor,
                    const RecordingLimits& limits) {
  const std::string file = resolved(path);
  const std::string format = format_of(file);
  if (format == "ROS 1 bag") return read_ros1_bag(file, visitor, limits);
  if (format == "MCAP") return read_mcap(file, visitor, limits);
  read_rosbag2_db3(file, visitor, limits);
}

}  // namespace hapticcal::recording
