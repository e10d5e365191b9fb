// libFuzzer target: measurement logs read with a --columns list. The input's
// first line is the list (as given to --columns, split by
// hapticcal::split_columns), the rest is the CSV text, all of it data.
// Bad input must end in hapticcal::InputError; any other exception, a crash, a
// sanitizer report or a hang is a finding.
#include <cstddef>
#include <cstdint>
#include <string>

#include "hapticcal/core/error.hpp"
#include "hapticcal/data_io/log.hpp"
#include "round_trip.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string input(reinterpret_cast<const char*>(data), size);
  const std::size_t eol = input.find('\n');
  const std::string list = input.substr(0, eol);
  const std::string text = eol == std::string::npos ? std::string() : input.substr(eol + 1);
  hapticcal::Log log;
  try {
    log = hapticcal::parse_log(text, "fuzz.csv", hapticcal::split_columns(list));
  } catch (const hapticcal::InputError&) {
    return 0;  // the expected outcome of bad input
  }
  expect_log_round_trip(log);
  return 0;
}
