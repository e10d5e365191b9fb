// Shared by the log fuzz targets: a log that parses writes out CSV that reads
// back to the same numbers (io.hpp); a difference, or an InputError on the way
// back, is a finding.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <string>

#include "hapticcal/data_io/log.hpp"

inline void expect_log_round_trip(const hapticcal::Log& log) {
  const std::string csv = hapticcal::log_to_csv(log);
  if (hapticcal::log_to_csv(hapticcal::parse_log(csv, "fuzz-roundtrip.csv")) != csv) {
    std::fprintf(stderr, "log_to_csv does not round-trip:\n%s\n", csv.c_str());
    std::abort();
  }
}
