#include "hapticcal/model_io/model_source.hpp"

#include <algorithm>
#include <cctype>
#include <filesystem>

#include "hapticcal/core/error.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/model_io/tree_model.hpp"
#include "hapticcal/model_io/urdf.hpp"

#ifndef HAPTICCAL_DEFAULT_DEVICE
#error "HAPTICCAL_DEFAULT_DEVICE must be defined"
#endif

namespace hapticcal {
namespace {

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

}  // namespace

// A .xacro file goes the URDF's way, to be refused there with what to do.
bool is_urdf_path(const std::string& path) {
  const std::string ext = lower_extension(path);
  return ext == ".urdf" || ext == ".xacro";
}

bool is_yaml_path(const std::string& path) {
  const std::string ext = lower_extension(path);
  return ext == ".yaml" || ext == ".yml";
}

std::vector<std::string> tip_names(const std::string& tip) {
  std::vector<std::string> out;
  if (tip.empty()) return out;
  size_t from = 0;
  for (size_t comma = tip.find(','); comma != std::string::npos; comma = tip.find(',', from)) {
    out.push_back(tip.substr(from, comma - from));
    from = comma + 1;
  }
  out.push_back(tip.substr(from));
  for (const std::string& name : out) {
    if (name.empty()) throw InputError("--tip: an empty tip name in '" + tip + "'");
  }
  return out;
}

namespace {

// The file a model's path names (resolve_model_path); InputError for a xacro file.
std::string model_file(const std::string& given) {
  const std::string path = resolve_model_path(given);
  if (lower_extension(path) == ".xacro") {
    throw InputError(path, 0, "",
                     "a xacro file: hapticcal reads URDF; expand it with xacro first (xacro "
                     "robot.urdf.xacro > robot.urdf)");
  }
  return path;
}

// A chain: the URDF text given, else the file (a URDF or a device file).
DeviceModel load_chain(const std::string& given, const std::string& tip, const std::string& root,
                       const std::string* urdf_text) {
  if (urdf_text) return parse_urdf(*urdf_text, given, tip, root);
  const std::string path = model_file(given);
  if (is_urdf_path(path)) return load_urdf(path, tip, root);
  if (!tip.empty() || !root.empty()) {
    throw InputError(path, 0, tip.empty() ? "--root" : "--tip",
                     "a tip or root link applies to a URDF model (.urdf), not to a device file");
  }
  return load_device(path);
}

}  // namespace

DeviceModel load_model(const std::string& path, const std::string& tip, const std::string& root,
                       const std::string* urdf_text) {
  return load_model(path, tip_names(tip), root, urdf_text);
}

DeviceModel load_model(const std::string& path, const std::vector<std::string>& tips,
                       const std::string& root, const std::string* urdf_text) {
  if (tips.size() <= 1) return load_chain(path, tips.empty() ? "" : tips[0], root, urdf_text);
  if (urdf_text) return tree_model(parse_tree(*urdf_text, path, tips, root));
  const std::string file = model_file(path);
  if (!is_urdf_path(file)) {
    throw InputError(file, 0, "--tip",
                     "several tips apply to a URDF model (.urdf), not to a device file (which "
                     "holds its tree itself)");
  }
  return tree_model(load_tree(file, tips, root));
}

// An installed program's devices first (PREFIX/share/hapticcal/devices beside
// PREFIX/bin), so that it lists and reads what was installed with it, not the
// source tree it was built from; a program run from its build tree has none
// there and takes the source tree's.
std::string builtin_device_path() {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  const fs::path installed =
      exe.parent_path().parent_path() / "share/hapticcal/devices/baser-7dof.yaml";
  if (!ec && fs::exists(installed, ec)) return installed.string();
  return HAPTICCAL_DEFAULT_DEVICE;
}

std::vector<BuiltinDevice> builtin_devices() {
  const std::filesystem::path folder = std::filesystem::path(builtin_device_path()).parent_path();
  struct Entry {
    const char* name;
    const char* description;
  };
  // The files' own comments give each number's source.
  constexpr Entry kDevices[] = {
      {"baser-7dof",
       "the 7-DOF capstan-driven haptic device of Baser & Konukseven (2013), the paper's"},
      {"phantom-premium-1.5", "the 6-DOF PHANToM Premium 1.5 (Cavusoglu et al. 2002)"},
      {"geomagic-touch",
       "the Geomagic Touch / PHANToM Omni in its driver's frame (Ubitrack; Harders et al. 2009)"},
      {"dvrk-mtm", "the da Vinci Research Kit's master (MTM right; sawIntuitiveResearchKit)"},
  };
  std::vector<BuiltinDevice> out;
  for (const Entry& e : kDevices) {
    out.push_back({e.name, e.description, (folder / (std::string(e.name) + ".yaml")).string()});
  }
  return out;
}

std::string builtin_device_file(const std::string& name) {
  for (const BuiltinDevice& d : builtin_devices()) {
    if (d.name == name) return d.path;
  }
  return {};
}

std::string resolve_model_path(const std::string& path) {
  // A folder is no model: one named as a built-in device (--out geomagic-touch)
  // does not hide it.
  std::error_code ec;
  const std::string builtin = builtin_device_file(path);
  if (std::filesystem::exists(path, ec) &&
      (builtin.empty() || !std::filesystem::is_directory(path, ec)))
    return path;
  return builtin.empty() ? path : builtin;
}

}  // namespace hapticcal
