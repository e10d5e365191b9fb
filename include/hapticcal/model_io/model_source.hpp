// Where a device model comes from: a device file (YAML) or a URDF, chosen by the
// file name, and the built-in device.
#pragma once

#include <string>

#include "hapticcal/model/model.hpp"

namespace hapticcal {

// Whether `path` names a URDF (extension .urdf, any case).
bool is_urdf_path(const std::string& path);
// Whether `path` names a device file (extension .yaml or .yml, any case).
bool is_yaml_path(const std::string& path);

// A URDF (by is_urdf_path) through load_urdf(path, tip, root), anything else
// through load_device; a tip or root with a device file is an InputError.
DeviceModel load_model(const std::string& path, const std::string& tip = "",
                       const std::string& root = "");

// The built-in 7-DOF device file: the source tree's in a build, else the one
// installed beside the executable (PREFIX/share/hapticcal/devices).
std::string builtin_device_path();

}  // namespace hapticcal
