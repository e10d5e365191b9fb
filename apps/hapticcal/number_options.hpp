// Validators of the command line's numeric options. Their ranges read as a
// person writes them ("[1, 100000]", "at least 0"), never as the largest
// double, and their errors quote the value given.
#pragma once

#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <charconv>
#include <cmath>
#include <limits>
#include <string>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/option_ranges.hpp"

namespace hapticcal::cli {

// "1" rather than "1.000000"; "1e-12" as written; a unit after a blank.
inline std::string range_text(double lo, double hi, const std::string& unit) {
  return hapticcal::range_text(OptionRange{lo, hi, unit.c_str()});
}

// A real number in [lo, hi] (a unit for the message); also refuses nan and
// inf, which CLI11's Range lets through.
inline CLI::Validator within(double lo, double hi, const std::string& unit = "") {
  const std::string range = range_text(lo, hi, unit);
  return CLI::Validator(
      [lo, hi, range](std::string& text) -> std::string {
        double v = 0;
        try {
          size_t used = 0;
          v = std::stod(text, &used);
          if (used != text.size()) return fmt::format("'{}' is not a number", printable(text));
        } catch (const std::out_of_range&) {
          return fmt::format("{} is outside {}", printable(text), range);
        } catch (const std::exception&) {
          return fmt::format("'{}' is not a number", printable(text));
        }
        if (!(v >= lo && v <= hi)) return fmt::format("{} is outside {}", printable(text), range);
        return {};
      },
      "in " + range);
}

// No upper limit of whole_number but the type's own.
constexpr long long kNoUpperLimit = std::numeric_limits<long long>::max();

// A whole number (a count, an index, a seed) in [lo, hi]; with hi =
// kNoUpperLimit the range reads "at least lo".
inline CLI::Validator whole_number(long long lo, long long hi = kNoUpperLimit) {
  const std::string range =
      hi == kNoUpperLimit ? fmt::format("at least {}", lo) : fmt::format("[{}, {}]", lo, hi);
  return CLI::Validator(
      [lo, hi, range](std::string& text) -> std::string {
        const char* begin = text.data();
        const char* end = text.data() + text.size();
        if (begin != end && *begin == '+') ++begin;
        long long v = 0;
        const auto [ptr, ec] = std::from_chars(begin, end, v);
        if (ec == std::errc::result_out_of_range && ptr == end) {
          return hi == kNoUpperLimit && text[0] != '-'
                     ? fmt::format("{} is too large (at most {})", printable(text), hi)
                     : fmt::format("{} is outside {}", printable(text), range);
        }
        if (ec != std::errc() || ptr != end || begin == end) {
          return fmt::format("'{}' is not a whole number", printable(text));
        }
        if (v < lo || v > hi) {
          return hi == kNoUpperLimit ? fmt::format("{} is less than {}", v, lo)
                                     : fmt::format("{} is outside {}", v, range);
        }
        return {};
      },
      hi == kNoUpperLimit ? range : "in " + range);
}

// The shared ranges (hapticcal/core/option_ranges.hpp).
inline CLI::Validator within(const OptionRange& r) { return within(r.lo, r.hi, r.unit); }
inline CLI::Validator whole_number(const OptionRange& r) {
  return whole_number(static_cast<long long>(r.lo), static_cast<long long>(r.hi));
}

}  // namespace hapticcal::cli
