// Where a device model comes from: a device file (YAML) or a URDF, chosen by the
// file name, and the built-in device.
#pragma once

#include <string>
#include <vector>

#include "hapticcal/model/model.hpp"

namespace hapticcal {

// Whether `path` names a URDF (extension .urdf, any case), or a xacro file (.xacro:
// refused by the URDF reader with the command that expands it).
bool is_urdf_path(const std::string& path);
// Whether `path` names a device file (extension .yaml or .yml, any case).
bool is_yaml_path(const std::string& path);

// The tips of a --tip value: its comma-separated names (one: a chain; none:
// the URDF's own tip). InputError for an empty name.
std::vector<std::string> tip_names(const std::string& tip);

// The one way a model is loaded: `path` with a --tip value (tip_names). One
// tip or none, a chain: a URDF (by is_urdf_path) through load_urdf(path, tip,
// root), anything else through load_device (a device file may hold a tree);
// a tip or root with a device file is an InputError. Several tips, the URDF's
// tree (tree_model of parse_tree; a device file is refused). A built-in
// device's name (builtin_devices) where no such file exists loads that
// device's file (resolve_model_path). `urdf_text`: the URDF's text already
// read (the text calibrate writes calibrated.urdf into) instead of `path`'s.
DeviceModel load_model(const std::string& path, const std::string& tip = "",
                       const std::string& root = "", const std::string* urdf_text = nullptr);
// The same with the tips already named (a tree's, in order).
DeviceModel load_model(const std::string& path, const std::vector<std::string>& tips,
                       const std::string& root, const std::string* urdf_text = nullptr);

// The built-in 7-DOF device file: the source tree's in a build, else the one
// installed beside the executable (PREFIX/share/hapticcal/devices).
std::string builtin_device_path();

// A device shipped with hapticcal (data/devices), usable by name wherever a
// model file is (`--model phantom-premium-1.5`).
struct BuiltinDevice {
  std::string name;         // e.g. "baser-7dof"
  std::string description;  // one line, with its source
  std::string path;         // its device file
};
// The built-in devices, in the folder of builtin_device_path().
std::vector<BuiltinDevice> builtin_devices();
// The file of the built-in device of that name, or empty.
std::string builtin_device_file(const std::string& name);
// `path` itself if a file of that name exists (a folder does not count where a
// built-in device has that name) or no built-in device has that name, else
// that device's file.
std::string resolve_model_path(const std::string& path);

}  // namespace hapticcal
