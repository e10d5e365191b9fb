// libFuzzer target: fixture files (hapticcal::parse_fixture). Bad input must end
// in hapticcal::InputError; any other exception, a crash, a sanitizer report or
// a hang is a finding. A file that parses is checked against a small points
// log (fixture_labels), which must also end in an InputError or accept it.
#include <cstddef>
#include <cstdint>
#include <string>

#include "hapticcal/core/error.hpp"
#include "hapticcal/data_io/fixture.hpp"
#include "hapticcal/identification/measurement.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const hapticcal::Log log = [] {
    hapticcal::Log l;
    l.origin = "fuzz.csv";
    l.has_point = true;
    l.label = {"a", "a", "b", "b", "c", "c"};
    l.rows = static_cast<int>(l.label.size());
    return l;
  }();
  static const std::vector<int> rows = {0, 1, 2, 3, 4, 5};
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const hapticcal::Fixture fixture = hapticcal::parse_fixture(text, "fuzz.yaml");
    (void)hapticcal::fixture_labels(hapticcal::MeasurementType::kPoint, log, rows,
                                    fixture.distances, fixture.points);
  } catch (const hapticcal::InputError&) {
    // The expected outcome of bad input.
  }
  return 0;
}
