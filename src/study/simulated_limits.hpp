// The joint-limit check of every simulation, shared by the scenario file's
// reader (scenario.cpp) and the study (study.cpp). Internal.
#pragma once

#include "hapticcal/study/study.hpp"

namespace hapticcal::detail {

// A simulation draws readings within the joint limits: limits of 1e308 would
// overflow its own log into inf. Throws InputError naming the device file.
void check_simulated_limits(const Scenario& sc);

}  // namespace hapticcal::detail
