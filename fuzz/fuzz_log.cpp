// libFuzzer target: measurement logs with a header row (hapticcal::parse_log
// without a columns list). Bad input must end in hapticcal::InputError; any
// other exception, a crash, a sanitizer report or a hang is a finding.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "hapticcal/error.hpp"
#include "hapticcal/io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  hapticcal::Log log;
  try {
    log = hapticcal::parse_log(text, "fuzz.csv");
  } catch (const hapticcal::InputError&) {
    return 0;  // the expected outcome of bad input
  }
  // A log that parses writes out CSV that reads back to the same numbers
  // (io.hpp); an InputError here is a finding too.
  const std::string csv = hapticcal::log_to_csv(log);
  if (hapticcal::log_to_csv(hapticcal::parse_log(csv, "fuzz-roundtrip.csv")) != csv) {
    std::fprintf(stderr, "log_to_csv does not round-trip:\n%s\n", csv.c_str());
    std::abort();
  }
  return 0;
}
