// The scenario file's session and iso9283 sections (scenario_file.hpp): a
// hand-guided session on two clocks, and the ISO 9283 cube's study.
#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "hapticcal/core/error.hpp"
#include "hapticcal/study/iso9283_cube.hpp"
#include "hapticcal/study/study.hpp"
#include "study/scenario_file.hpp"

namespace hapticcal::detail {

constexpr int kMaxIsoCycles = 1000;

// session: a hand-guided session on two clocks (study/session.hpp), measured
// by a tracker's positions (measurement: position).
void read_session(const ScenarioFile& file, Scenario& sc) {
  const ScenarioReader& r = file.r;
  const YAML::Node node = file.root["session"];
  if (!node) return;
  r.check_keys(node, "session",
               {"seconds", "device_rate_hz", "tracker_rate_hz", "clock_offset", "clock_drift_ppm",
                "tracker_start", "device_jitter", "tracker_jitter", "dropout_share",
                "dropout_seconds", "max_frequency_hz", "search_range", "fit_drift"});
  if (sc.measurement != MeasurementType::kPosition) {
    r.fail(node, "session",
           "a hand-guided session is measured by a tracker's positions: give "
           "measurement: position");
  }
  if (sc.nominal.tree())
    r.fail(node, "session", "a hand-guided session study is of one chain, not a tree of tips");
  SessionOptions o;
  const auto value = [&](const char* key, double lo, double hi, double fallback) {
    if (!node[key]) return fallback;
    const std::string name = std::string("session.") + key;
    const double v = r.number(node[key], name);
    if (!(v >= lo && v <= hi))
      r.fail(node[key], name, fmt::format("expected [{:g}, {:g}]", lo, hi));
    return v;
  };
  o.seconds = value("seconds", 1, 7200, o.seconds);
  o.device_rate_hz = value("device_rate_hz", 10, 10000, o.device_rate_hz);
  o.tracker_rate_hz = value("tracker_rate_hz", 1, 10000, o.tracker_rate_hz);
  if (o.seconds * o.device_rate_hz > kMaxTrajectorySamples)
    r.fail(node, "session.seconds",
           fmt::format("more than {:g} device samples", kMaxTrajectorySamples));
  if (o.seconds * o.tracker_rate_hz > kMaxTrajectorySamples)
    r.fail(node, "session.tracker_rate_hz",
           fmt::format("more than {:g} tracker samples", kMaxTrajectorySamples));
  o.clock_offset = value("clock_offset", -1e6, 1e6, o.clock_offset);
  o.clock_drift = 1e-6 * value("clock_drift_ppm", -1e4, 1e4, 1e6 * o.clock_drift);
  o.tracker_start = value("tracker_start", -1e6, 1e6, o.tracker_start);
  o.device_jitter = value("device_jitter", 0, 1, o.device_jitter);
  o.tracker_jitter = value("tracker_jitter", 0, 1, o.tracker_jitter);
  o.dropout_share = value("dropout_share", 0, 0.5, o.dropout_share);
  o.dropout_seconds = value("dropout_seconds", 0, 60, o.dropout_seconds);
  o.max_frequency_hz = value("max_frequency_hz", 0.1, 10, o.max_frequency_hz);
  sc.session = o;
  sc.session_search_range = value("search_range", 1e-3, 3600, sc.session_search_range);
  if (node["fit_drift"]) {
    const YAML::Node f = node["fit_drift"];
    if (!f.IsScalar() || (f.Scalar() != "true" && f.Scalar() != "false"))
      r.fail(f, "session.fit_drift", "expected true or false");
    sc.session_fit_drift = f.Scalar() == "true";
  } else {
    sc.session_fit_drift = o.clock_drift != 0;
  }
}

// iso9283: {cycles, scatter, cube_size, cube_centre}: ISO 9283's test after
// each calibration, at the nominal model's test cube (planned here, so that a
// cube the limits do not allow is refused with the file's line).
void read_iso9283(const ScenarioFile& file, Scenario& sc) {
  const ScenarioReader& r = file.r;
  const YAML::Node node = file.root["iso9283"];
  if (!node) return;
  r.expect_map(node, "iso9283");
  r.check_keys(node, "iso9283", {"cycles", "scatter", "cube_size", "cube_centre"});
  if (sc.session) r.fail(node, "iso9283", "a hand-guided session study runs no ISO 9283 test");
  if (sc.nominal.tree())
    r.fail(node, "iso9283", "ISO 9283's test is of one tool: a tree of several tips runs none");
  IsoSimulation iso;
  if (node["cycles"])
    iso.cube.cycles = r.integer(node["cycles"], "iso9283.cycles", 1, kMaxIsoCycles);
  if (const YAML::Node scatter = node["scatter"]) {
    iso.scatter = r.number(scatter, "iso9283.scatter");
    if (!(iso.scatter >= 0 && iso.scatter <= kMaxSigmaLength))
      r.fail(scatter, "iso9283.scatter",
             fmt::format("{} is outside [0, {}] m", iso.scatter, kMaxSigmaLength));
  }
  if (const YAML::Node size = node["cube_size"]) {
    iso.cube.size = r.number(size, "iso9283.cube_size");
    if (!(*iso.cube.size > 0 && *iso.cube.size <= kMaxSocketCoordinate))
      r.fail(size, "iso9283.cube_size",
             fmt::format("{} is outside (0, {}] m", *iso.cube.size, kMaxSocketCoordinate));
  }
  if (const YAML::Node centre = node["cube_centre"]) {
    if (!centre.IsSequence() || centre.size() != 3)
      r.fail(centre, "iso9283.cube_centre", "expected [X, Y, Z] in metres");
    Eigen::Vector3d c;
    for (int k = 0; k < 3; ++k) {
      c[k] = r.number(centre[k], "iso9283.cube_centre");
      if (!(std::abs(c[k]) <= kMaxSocketCoordinate))
        r.fail(centre[k], "iso9283.cube_centre",
               fmt::format("{} m is beyond {} m", c[k], kMaxSocketCoordinate));
    }
    iso.cube.centre = c;
  }
  try {
    iso.plan = plan_iso_cube(sc.nominal, iso.cube);
  } catch (const InputError& e) {
    // The planner speaks of plan's options; here they are this section's keys.
    std::string why = e.message();
    for (const auto& [option, key] : {std::pair<std::string, std::string>{"--iso9283: ", ""},
                                      {"--cube-centre", "cube_centre"},
                                      {"--cube-size", "cube_size"},
                                      {"--tip", "tip"}}) {
      why = replace_all(why, option, key);
    }
    r.fail(node, "iso9283", why);
  }
  sc.iso9283 = std::move(iso);
}

}  // namespace hapticcal::detail
