// The ranges of the numeric options that the command line and the Python
// module share: the command line's validators (apps/hapticcal/number_options.hpp)
// and the module's checks read them from here, so that a value one refuses the
// other refuses with the same range.
#pragma once

#include <fmt/format.h>

#include <cmath>
#include <string>

#include "hapticcal/core/error.hpp"

namespace hapticcal {

struct OptionRange {
  double lo, hi;
  const char* unit = "";
};

namespace option_range {
inline constexpr OptionRange kClockSearch{1e-3, 3600, "s"};
inline constexpr OptionRange kSigma{1e-12, 1, "m"};    // a measurement's sd
inline constexpr OptionRange kAngle{1e-12, 1, "rad"};  // an encoder's sd or count
inline constexpr OptionRange kPriorScale{1e-6, 1e6};
inline constexpr OptionRange kDependencyTolerance{1e-12, 0.5};
inline constexpr OptionRange kSamples{0, 1e8};
inline constexpr OptionRange kPolynomialOrder{1, 30};
inline constexpr OptionRange kFolds{0, 1000};
inline constexpr OptionRange kPlanPoses{1, 1e5};
inline constexpr OptionRange kPool{1, 1e7};
inline constexpr OptionRange kRefinePasses{0, 1000};
inline constexpr OptionRange kTrials{1, 1e5};
inline constexpr OptionRange kThreads{1, 256};
inline constexpr OptionRange kForceGain{-100, 100};
inline constexpr OptionRange kForceNoise{0, 1000, "N"};
inline constexpr OptionRange kWallStiffness{1e-3, 1e6, "N/m"};
inline constexpr OptionRange kWallTravel{-1, 1, "m"};
inline constexpr OptionRange kWallSeconds{0, 600, "s"};
inline constexpr OptionRange kLockedJoint{0, 1000};
}  // namespace option_range

// "[1, 100000]" or "[1e-12, 1] m": as a person writes the range.
inline std::string range_text(const OptionRange& r) {
  const auto number = [](double v) {
    return v == std::floor(v) && std::abs(v) < 1e15 ? fmt::format("{}", static_cast<long long>(v))
                                                    : fmt::format("{}", v);
  };
  const std::string unit = r.unit;
  return fmt::format("[{}, {}]{}{}", number(r.lo), number(r.hi), unit.empty() ? "" : " ", unit);
}

// Throws InputError "<name> <value>: not in <range>" (nan and inf too), the
// name the command line's option (--clock-search); `whole` also refuses a fraction.
inline void check_option(const std::string& name, double value, const OptionRange& r,
                         bool whole = false) {
  if (!(value >= r.lo && value <= r.hi))
    throw InputError(fmt::format("{} {}: not in {}", name, value, range_text(r)));
  if (whole && value != std::floor(value))
    throw InputError(fmt::format("{} {}: not a whole number", name, value));
}

}  // namespace hapticcal
