// Device files (YAML, `format: hapticcal-device/1`). Every
// problem with a file is an InputError naming the file, the line and the key.
#pragma once

#include <string>

#include "hapticcal/model/model.hpp"

namespace hapticcal {

// Device files: `format: hapticcal-device/1`.
DeviceModel load_device(const std::string& path);
// origin names the text in error messages (a file name).
DeviceModel parse_device(const std::string& yaml_text, const std::string& origin);
// YAML text that parse_device reads back to a bit-identical model.
std::string device_to_yaml(const DeviceModel& model);
// Written atomically: the file is either the old one or the complete new one.
void save_device(const DeviceModel& model, const std::string& path);
// Empty if the model is usable, else "key: reason" (e.g. "links[3].limits: lower >= upper").
std::string check_device(const DeviceModel& model);

}  // namespace hapticcal
