// libFuzzer target: measurement logs with a header row (hapticcal::parse_log
// without a columns list). Bad input must end in hapticcal::InputError; any
// other exception, a crash, a sanitizer report or a hang is a finding.
#include <cstddef>
#include <cstdint>
#include <string>

#include "hapticcal/core/error.hpp"
#include "hapticcal/data_io/log.hpp"
#include "round_trip.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  hapticcal::Log log;
  try {
    log = hapticcal::parse_log(text, "fuzz.csv");
  } catch (const hapticcal::InputError&) {
    return 0;  // the expected outcome of bad input
  }
  expect_log_round_trip(log);
  return 0;
}
