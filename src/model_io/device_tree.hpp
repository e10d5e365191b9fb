// Internal: a device file's format names, and a tree in a device file (format 2):
// each link's `parent` and the `tips` in place of `tool` (docs/file-formats.md,
// "Trees"); device_io.cpp reads the rest and device_write.cpp writes it.
#pragma once

#include <yaml-cpp/yaml.h>

#include <string>

#include "core/yaml_reader.hpp"
#include "hapticcal/model/model.hpp"

namespace hapticcal::detail {

// Version 1: one convention (dh, mdh) for every link, revolute joints. Version 2
// adds per-link geometry (dh, mdh, urdf origin + axis) and joint types; a model
// that version 1 can hold is written as version 1.
inline constexpr const char* kFormat = "hapticcal-device/1";
inline constexpr const char* kFormat2 = "hapticcal-device/2";

// Why a device or tip name cannot be used (it reaches reports and saved
// files), or empty (device_io.cpp); a string as a double-quoted YAML scalar
// (device_write.cpp).
std::string device_name_problem(const std::string& name);
std::string quoted(const std::string& s);

// The links' `parent` keys and `tips` of a device file into `model` (its links
// read), or InputError naming the file, line and key.
void read_tree(const YamlReader& r, const YAML::Node& root, const YAML::Node& links,
               DeviceModel& model);
// Why a tree's parents or tips cannot be written, as "key: reason", or empty
// (a chain: empty).
std::string tips_problem(const DeviceModel& model);
// Link i's `parent` line, and the `tips` section, of a tree's device file.
std::string parent_yaml(const DeviceModel& model, int i);
std::string tips_yaml(const DeviceModel& model);

}  // namespace hapticcal::detail
