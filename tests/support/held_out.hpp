// A simulated tracker study with poses held out: the log to fit, another of
// the same size to validate on, and the noise floor (the actual device's own
// RMS on the held-out log); a fitted parameter by name.
#pragma once

#include <cstdint>
#include <string>

#include "hapticcal/data_io/log.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/model/model.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "hapticcal/study/simulation.hpp"

namespace hapticcal::testing {

struct HeldOutStudy {
  Log cal, val;
  double floor = 0;  // [m]
};

// `poses` tracker positions of `actual` with sigma_position noise, drawn with
// `seed` to fit and seed + 1 to hold out.
inline HeldOutStudy held_out_study(const DeviceModel& actual, int poses, double sigma_position,
                                   std::uint64_t seed) {
  SimulationNoise noise;
  noise.sigma_position = sigma_position;
  HeldOutStudy s;
  s.cal = simulate_log(actual, poses, noise, seed, /*distance=*/false, /*position=*/true);
  s.val = simulate_log(actual, poses, noise, seed + 1, /*distance=*/false, /*position=*/true);
  s.floor = evaluate(actual, s.val).figure("position")->stats.rms;
  return s;
}

// The fit's estimate of the dotted parameter `name` (nullptr: none).
inline const ParameterEstimate* find_parameter(const KinematicFit& fit, const std::string& name) {
  for (const ParameterEstimate& e : fit.parameters) {
    if (e.name == name) return &e;
  }
  return nullptr;
}

}  // namespace hapticcal::testing
