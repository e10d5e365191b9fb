// libFuzzer target: device files (hapticcal::parse_device). Bad input must end
// in hapticcal::InputError; any other exception, a crash, a sanitizer report or
// a hang is a finding.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "hapticcal/core/error.hpp"
#include "hapticcal/model_io/device.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  hapticcal::DeviceModel model;
  try {
    model = hapticcal::parse_device(text, "fuzz.yaml");
  } catch (const hapticcal::InputError&) {
    return 0;  // the expected outcome of bad input
  }
  // A model that parses writes out YAML that reads back to the same model
  // (io.hpp); an InputError here is a finding too.
  const std::string yaml = hapticcal::device_to_yaml(model);
  if (hapticcal::device_to_yaml(hapticcal::parse_device(yaml, "fuzz-roundtrip.yaml")) != yaml) {
    std::fprintf(stderr, "device_to_yaml does not round-trip:\n%s\n", yaml.c_str());
    std::abort();
  }
  return 0;
}
