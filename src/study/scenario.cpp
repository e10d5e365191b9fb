// The scenario file (load_scenario, study.hpp): one reader a section of the
// file, called in the order the sections depend on each other (the device
// first, the measurement before its sockets, planes and noise).
#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <numbers>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/yaml_reader.hpp"
#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/core/option_ranges.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/identification/measurement.hpp"
#include "hapticcal/model_io/model_source.hpp"
#include "hapticcal/study/iso9283_cube.hpp"
#include "hapticcal/study/paper.hpp"
#include "hapticcal/study/simulation.hpp"
#include "hapticcal/study/study.hpp"
#include "study/scenario_file.hpp"
#include "study/simulated_limits.hpp"

namespace hapticcal {
namespace {

using detail::kMaxSigmaLength;
using detail::kMaxSocketCoordinate;
using detail::kMaxTrajectorySamples;
using detail::read_iso9283;
using detail::read_session;
using detail::ScenarioFile;
using detail::ScenarioReader;

// Bounds on the numbers of a scenario file (scenario_file.hpp has those the
// session's readers share).
constexpr int kMaxTrials = static_cast<int>(option_range::kTrials.hi);  // --trials's
constexpr size_t kMaxSockets = 20;
constexpr size_t kMaxPlanes = 20;
constexpr int kMaxPoses = 1000000;
constexpr double kMaxTrajectorySeconds = 1e5;
constexpr double kMaxRateHz = 1e5;
constexpr double kMaxCountsPerRev = 1e9;
constexpr double kMaxSigmaAngle = 1;                     // rad
constexpr double kMaxLengthDeviation = 1;                // m
constexpr double kMaxAngleDeviation = std::numbers::pi;  // rad

ScenarioFile parse_scenario_file(const std::string& path) {
  const std::string text = read_file(path, FileKind::kScenario);
  ScenarioFile file{path, ScenarioReader(path), {}};
  try {
    file.root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(path, e.mark.is_null() ? 0 : e.mark.line + 1, "", "YAML: " + e.msg);
  }
  const ScenarioReader& r = file.r;
  const YAML::Node& root = file.root;
  r.check_keys(root, "",
               {"format", "device", "tip", "root", "seed", "trials", "poses", "trajectory", "noise",
                "deviations", "random_deviations", "transmissions", "measurement", "calibration",
                "sockets", "socket_distances", "planes", "session", "iso9283"});
  const std::string format = r.string(r.require(root, "", "format"), "format");
  if (format != "hapticcal-scenario/1") {
    r.fail(root["format"], "format",
           fmt::format("'{}' is not 'hapticcal-scenario/1'", printable(format)));
  }
  return file;
}

// device, tip and root (else the caller's defaults): the default scenario on
// that device, which the other sections change.
Scenario scenario_device(const ScenarioFile& file, const std::string& default_device_path,
                         const std::string& default_tip, const std::string& default_root) {
  const ScenarioReader& r = file.r;
  const YAML::Node& root = file.root;
  std::string device = default_device_path;
  if (root["device"]) {
    device = r.string(root["device"], "device");
    // A relative path is the scenario folder's; a built-in device's name
    // (geomagic-touch) where that folder has no such file.
    const std::filesystem::path p(device);
    if (p.is_relative()) {
      const std::filesystem::path beside = std::filesystem::path(file.path).parent_path() / p;
      std::error_code ec;
      const std::string builtin = builtin_device_file(device);
      device = std::filesystem::exists(beside, ec) || builtin.empty() ? beside.string() : builtin;
    }
  }
  std::string tip = default_tip, chain_root = default_root;
  if (root["tip"]) tip = r.string(root["tip"], "tip");
  if (root["root"]) chain_root = r.string(root["root"], "root");
  if (!is_urdf_path(device)) {
    for (const char* key : {"tip", "root"}) {
      if (root[key])
        r.fail(root[key], key, "a tip or root link applies to a URDF device, not to a device file");
    }
  }
  return default_scenario(device, tip, chain_root);
}

// seed and trials.
void read_counts(const ScenarioFile& file, Scenario& sc) {
  const ScenarioReader& r = file.r;
  const YAML::Node& root = file.root;
  if (root["seed"])
    sc.seed = static_cast<std::uint64_t>(r.integer(root["seed"], "seed", 0, 2000000000));
  if (root["trials"]) sc.trials = r.integer(root["trials"], "trials", 1, kMaxTrials);
}

// poses.identification given as a plan file: measure at its readings.
void read_plan(const ScenarioFile& file, const YAML::Node& id, Scenario& sc) {
  const ScenarioReader& r = file.r;
  std::filesystem::path plan(id.Scalar());
  if (plan.is_relative()) plan = std::filesystem::path(file.path).parent_path() / plan;
  Log log;
  try {
    log = read_log(plan.string());
  } catch (const InputError& e) {
    r.fail(id, "poses.identification", e.what());
  }
  if (log.q.cols() != sc.nominal.dof()) {
    r.fail(id, "poses.identification",
           fmt::format("{} has {} joint readings a row, the device {} joints", plan.string(),
                       log.q.cols(), sc.nominal.dof()));
  }
  if (log.rows < 1 || log.rows > kMaxPoses)
    r.fail(id, "poses.identification", fmt::format("{} has no poses", plan.string()));
  sc.identification_readings = log.q;
  sc.identification_plan = plan.string();
  sc.identification_poses = log.rows;
}

// poses: {identification: N | PLAN.csv, validation: N}.
void read_poses(const ScenarioFile& file, Scenario& sc) {
  const ScenarioReader& r = file.r;
  const YAML::Node poses = file.root["poses"];
  if (!poses) return;
  r.check_keys(poses, "poses", {"identification", "validation"});
  const YAML::Node id = poses["identification"];
  auto is_number = [](const std::string& text) {
    char* end = nullptr;
    std::strtod(text.c_str(), &end);
    return !text.empty() && end == text.c_str() + text.size();
  };
  if (id && id.IsScalar() && id.Tag() != "!" && !is_number(id.Scalar())) {
    read_plan(file, id, sc);
  } else if (id) {
    sc.identification_poses = r.integer(id, "poses.identification", 1, kMaxPoses);
  }
  if (poses["validation"])
    sc.validation_poses = r.integer(poses["validation"], "poses.validation", 1, kMaxPoses);
}

// calibration: {keep_all, fix}.
void read_calibration(const ScenarioFile& file, Scenario& sc) {
  const ScenarioReader& r = file.r;
  const YAML::Node cal = file.root["calibration"];
  if (!cal) return;
  r.check_keys(cal, "calibration", {"keep_all", "fix"});
  if (const YAML::Node fix = cal["fix"]) {
    if (!fix.IsSequence()) r.fail(fix, "calibration.fix", "expected a list of parameter names");
    for (const YAML::Node& name : fix) sc.fix.push_back(r.string(name, "calibration.fix"));
    try {
      candidate_slots(sc.nominal, sc.fix, {});
    } catch (const InputError& e) {
      r.fail(fix, "calibration.fix", e.message());
    }
  }
  if (const YAML::Node k = cal["keep_all"]) {
    if (!k.IsScalar() || (k.Scalar() != "true" && k.Scalar() != "false"))
      r.fail(k, "calibration.keep_all", "expected true or false");
    sc.keep_all = k.Scalar() == "true";
  }
}

// measurement: distance | position | pose | point | plane.
void read_measurement(const ScenarioFile& file, Scenario& sc) {
  const ScenarioReader& r = file.r;
  const YAML::Node m = file.root["measurement"];
  if (!m) return;
  const std::string name = r.string(m, "measurement");
  const std::optional<MeasurementType> type = measurement_type_named(name);
  if (!type) {
    r.fail(m, "measurement",
           fmt::format("'{}' is not a measurement simulate produces: distance, position, pose, "
                       "point or plane",
                       printable(name)));
  }
  if (sc.nominal.tree() && *type != MeasurementType::kPosition) {
    r.fail(m, "measurement",
           fmt::format("a tree of several tips is simulated with one point a tip: position, not "
                       "{}",
                       name));
  }
  sc.measurement = *type;
}

// The fixtures a scenario simulates: sockets for fixture points, planes for
// plane contacts.
bool socket_fixture(MeasurementType type) { return traits(type).label_points; }
bool plane_fixture(MeasurementType type) { return is_fixture(type) && !traits(type).label_points; }

// sockets: {NAME: [X, Y, Z], ...} and socket_distances: known | unknown
// (measurement: point).
void read_sockets(const ScenarioFile& file, Scenario& sc) {
  const ScenarioReader& r = file.r;
  if (const YAML::Node sockets = file.root["sockets"]) {
    if (!socket_fixture(sc.measurement))
      r.fail(sockets, "sockets", "sockets are for measurement: point");
    if (!sockets.IsMap() || sockets.size() < 2 || sockets.size() > kMaxSockets) {
      r.fail(
          sockets, "sockets",
          fmt::format("expected a map of 2 to {} sockets: NAME: [X, Y, Z] (metres)", kMaxSockets));
    }
    for (const auto& entry : sockets) {
      const std::string name = r.string(entry.first, "sockets");
      const std::string key = "sockets." + name;
      const YAML::Node& xyz = entry.second;
      if (!xyz.IsSequence() || xyz.size() != 3) r.fail(xyz, key, "expected [X, Y, Z] in metres");
      Eigen::Vector3d p;
      for (int k = 0; k < 3; ++k) {
        p[k] = r.number(xyz[k], key);
        if (!(std::abs(p[k]) <= kMaxSocketCoordinate))
          r.fail(xyz[k], key, fmt::format("{} m is beyond {} m", p[k], kMaxSocketCoordinate));
      }
      sc.sockets.emplace_back(name, p);
    }
  }
  if (const YAML::Node known = file.root["socket_distances"]) {
    const std::string value = r.string(known, "socket_distances");
    if (!socket_fixture(sc.measurement))
      r.fail(known, "socket_distances", "socket distances are for measurement: point");
    if (value != "known" && value != "unknown")
      r.fail(known, "socket_distances", "expected known or unknown");
    sc.socket_distances_known = value == "known";
  }
}

// planes: {NAME: {point: [X, Y, Z], normal: [X, Y, Z]}, ...} (measurement: plane).
void read_planes(const ScenarioFile& file, Scenario& sc) {
  const ScenarioReader& r = file.r;
  const YAML::Node planes = file.root["planes"];
  if (!planes) return;
  if (!plane_fixture(sc.measurement)) r.fail(planes, "planes", "planes are for measurement: plane");
  if (!planes.IsMap() || planes.size() < 1 || planes.size() > kMaxPlanes) {
    r.fail(planes, "planes",
           fmt::format("expected a map of 1 to {} planes: NAME: {{point: [X, Y, Z], normal: [X, "
                       "Y, Z]}} (metres)",
                       kMaxPlanes));
  }
  for (const auto& entry : planes) {
    const std::string name = r.string(entry.first, "planes");
    const std::string key = "planes." + name;
    r.check_keys(entry.second, key, {"point", "normal"});
    auto vector = [&](const char* what) {
      const std::string k = key + "." + what;
      const YAML::Node xyz = r.require(entry.second, key, what);
      if (!xyz.IsSequence() || xyz.size() != 3) r.fail(xyz, k, "expected [X, Y, Z]");
      Eigen::Vector3d v;
      for (int c = 0; c < 3; ++c) {
        v[c] = r.number(xyz[c], k);
        if (!(std::abs(v[c]) <= kMaxSocketCoordinate))
          r.fail(xyz[c], k, fmt::format("{} is beyond {}", v[c], kMaxSocketCoordinate));
      }
      return std::pair{v, xyz};
    };
    const Eigen::Vector3d point = vector("point").first;
    const auto [normal, normal_node] = vector("normal");
    if (!(normal.norm() > 1e-9))
      r.fail(normal_node, key + ".normal", "a normal of zero length has no direction");
    sc.planes.push_back({name, point, normal.normalized()});
  }
}

// A fixture's default sockets or planes when the file names none, and enough
// samples a label.
void complete_fixture(const ScenarioFile& file, Scenario& sc) {
  const ScenarioReader& r = file.r;
  if (socket_fixture(sc.measurement) && sc.sockets.empty())
    sc.sockets = default_sockets(sc.nominal);
  if (plane_fixture(sc.measurement) && sc.planes.empty()) sc.planes = default_planes(sc.nominal);
  // Enough samples a label: 2 a socket (a point is 3 unknowns), 4 a plane (any
  // 3 points lie on one).
  if (!sc.sockets.empty() || !sc.planes.empty()) {
    const bool point = !sc.sockets.empty();
    const int labels = static_cast<int>(point ? sc.sockets.size() : sc.planes.size());
    const int least = point ? 2 : 4;
    if (sc.identification_poses / labels < least) {
      const YAML::Node poses = file.root["poses"];
      r.fail(poses ? poses["identification"] : file.root, "poses.identification",
             fmt::format("{} poses over {} {} are fewer than the {} {} needs: give at least {}",
                         sc.identification_poses, labels, point ? "sockets" : "planes", least,
                         point ? "a socket" : "a plane", least * labels));
    }
  }
}

// transmissions: paper | device.
void read_transmissions(const ScenarioFile& file, Scenario& sc) {
  const ScenarioReader& r = file.r;
  const YAML::Node t = file.root["transmissions"];
  if (!t) return;
  const std::string name = r.string(t, "transmissions");
  if (name == "paper") {
    if (!sc.paper_device) {
      r.fail(t, "transmissions",
             "the paper's capstans and joint-4 linkage (Table 2) are the truth of the paper's "
             "device only, not of " +
                 sc.nominal.name + ": use transmissions: device");
    }
    sc.paper_transmissions = true;
  } else if (name == "device") {
    sc.paper_transmissions = false;
  } else {
    r.fail(t, "transmissions",
           fmt::format("'{}' is neither paper (the paper's Table 2) nor device (the device "
                       "file's own)",
                       printable(name)));
  }
}

// random_deviations: {lengths, angles, seed}.
void read_random_deviations(const ScenarioFile& file, Scenario& sc) {
  const ScenarioReader& r = file.r;
  const YAML::Node rd = file.root["random_deviations"];
  if (!rd) {
    // The default deviations follow the scenario's seed.
    if (!sc.paper_device) sc.random.seed = sc.seed;
    return;
  }
  r.check_keys(rd, "random_deviations", {"lengths", "angles", "seed"});
  RandomDeviations random;
  random.seed = sc.seed;
  auto sd = [&](const char* cls, double hi, const char* unit) {
    const YAML::Node node = rd[cls];
    if (!node) return 0.0;
    const std::string key = std::string("random_deviations.") + cls;
    const double v = r.number(node, key);
    if (v < 0) r.fail(node, key, fmt::format("a standard deviation cannot be negative ({})", v));
    if (v > hi) r.fail(node, key, fmt::format("{} is more than the {} {} allowed", v, hi, unit));
    return v;
  };
  random.lengths = sd("lengths", kMaxLengthDeviation, "m");
  random.angles = sd("angles", kMaxAngleDeviation, "rad");
  if (rd["seed"])
    random.seed =
        static_cast<std::uint64_t>(r.integer(rd["seed"], "random_deviations.seed", 0, 2000000000));
  if (!random.enabled())
    r.fail(rd, "random_deviations", "give lengths and/or angles: a standard deviation above 0");
  sc.random = random;
}

// trajectory: {seconds, rate_hz}.
void read_trajectory(const ScenarioFile& file, Scenario& sc) {
  const ScenarioReader& r = file.r;
  const YAML::Node tr = file.root["trajectory"];
  if (!tr) return;
  r.check_keys(tr, "trajectory", {"seconds", "rate_hz"});
  auto bounded = [&](const YAML::Node& node, const std::string& key, double hi, const char* unit) {
    const double v = r.number(node, key);
    if (!(v > 0 && v <= hi))
      r.fail(node, key, fmt::format("{} is outside (0, {}] {}", v, hi, unit));
    return v;
  };
  if (tr["seconds"])
    sc.trajectory_seconds =
        bounded(tr["seconds"], "trajectory.seconds", kMaxTrajectorySeconds, "s");
  if (tr["rate_hz"])
    sc.trajectory_rate_hz = bounded(tr["rate_hz"], "trajectory.rate_hz", kMaxRateHz, "Hz");
  const double samples = sc.trajectory_seconds * sc.trajectory_rate_hz;
  if (samples > kMaxTrajectorySamples)
    r.fail(tr, "trajectory",
           fmt::format("seconds * rate_hz = {} samples, more than the {} allowed", samples,
                       kMaxTrajectorySamples));
}

// noise: {sigma_e, sigma_m, sigma_r, motor_counts_per_rev}; then a tracker's
// sigma_m is of each position coordinate.
void read_noise(const ScenarioFile& file, Scenario& sc) {
  const ScenarioReader& r = file.r;
  if (const YAML::Node noise = file.root["noise"]) {
    r.check_keys(noise, "noise", {"sigma_e", "sigma_m", "sigma_r", "motor_counts_per_rev"});
    // Each noise value: finite (r.number), not negative and at most `hi`.
    auto level = [&](const YAML::Node& node, const std::string& key, double hi, const char* unit) {
      const double v = r.number(node, key);
      if (!(v >= 0 && v <= hi))
        r.fail(node, key, fmt::format("{} is outside [0, {}] {}", v, hi, unit));
      return v;
    };
    if (noise["motor_counts_per_rev"]) {
      sc.noise.motor_counts_per_rev = level(
          noise["motor_counts_per_rev"], "noise.motor_counts_per_rev", kMaxCountsPerRev, "counts");
    }
    if (noise["sigma_e"])
      sc.noise.sigma_ext = level(noise["sigma_e"], "noise.sigma_e", kMaxSigmaAngle, "rad");
    // The paper's formulas are of its cable encoder: its device, distances.
    const bool paper_encoder = sc.paper_encoder();
    if (paper_encoder) sc.noise.sigma_distance = paper_sigma_m(sc.noise.sigma_ext);  // the default
    if (const YAML::Node m = noise["sigma_m"]) {
      const bool formula = m.IsScalar() && (m.Scalar() == "consistent" || m.Scalar() == "paper");
      if (formula && !paper_encoder) {
        r.fail(m, "noise.sigma_m",
               fmt::format("the {} formula is of the paper's cable encoder (its device, distance "
                           "measurements), not of {} measuring {}: give sigma_m in metres",
                           m.Scalar(), sc.nominal.name, traits(sc.measurement).plural));
      }
      if (formula && m.Scalar() == "consistent") {
        sc.sigma_m_formula = "consistent";
        sc.noise.sigma_distance = consistent_sigma_m(sc.noise.sigma_ext);
      } else if (!formula) {
        sc.sigma_m_formula = "given";
        sc.noise.sigma_distance = level(m, "noise.sigma_m", kMaxSigmaLength, "m");
      }
    }
    if (const YAML::Node sr = noise["sigma_r"]) {
      if (!traits(sc.measurement).rotation)
        r.fail(sr, "noise.sigma_r", "a rotation's noise applies to pose measurements only");
      sc.noise.sigma_orientation = level(sr, "noise.sigma_r", kMaxSigmaAngle, "rad");
    }
    if (!(sc.noise.sigma_ext > 0 && sc.noise.sigma_distance > 0 && sc.noise.sigma_orientation > 0))
      r.fail(noise, "noise", "noise levels must be positive");
  }
  if (!traits(sc.measurement).distance_column) {
    if (sc.paper_device && sc.sigma_m_formula == "paper") {
      // The paper's cable-encoder noise is no tracker's: the general default.
      sc.noise.sigma_distance = kDefaultSigmaM;
      sc.sigma_m_formula = "default";
    }
    sc.noise.sigma_position = sc.noise.sigma_distance;
  }
}

// deviations: {DOTTED_NAME: VALUE, ...}.
void read_deviations(const ScenarioFile& file, Scenario& sc) {
  const ScenarioReader& r = file.r;
  const YAML::Node dev = file.root["deviations"];
  if (!dev) return;
  r.expect_map(dev, "deviations");
  const std::vector<ParameterInfo> info = sc.nominal.parameter_info();
  for (const auto& kv : dev) {
    const std::string name = kv.first.IsScalar() ? kv.first.Scalar() : "?";
    const std::string key = "deviations." + printable(name);
    const auto it = std::find_if(info.begin(), info.end(),
                                 [&](const ParameterInfo& p) { return p.name == name; });
    if (it == info.end()) {
      std::vector<std::string> known;
      for (const ParameterInfo& p : info) known.push_back(p.name);
      r.fail(kv.first, key,
             fmt::format("not a kinematic parameter of {}{}", sc.nominal.name,
                         did_you_mean(name, known)));
    }
    const double v = r.number(kv.second, key);
    const bool angle = it->unit == ParameterUnit::kAngle;
    const double hi = angle ? kMaxAngleDeviation : kMaxLengthDeviation;
    if (!(std::abs(v) <= hi))
      r.fail(kv.second, key,
             fmt::format("|{}| is more than the {} {} a deviation may be", v, hi,
                         angle ? "rad (pi)" : "m"));
    sc.deviations[name] = v;
  }
}

}  // namespace

Scenario load_scenario(const std::string& path, const std::string& default_device_path,
                       const std::string& default_tip, const std::string& default_root) {
  const ScenarioFile file = parse_scenario_file(path);
  Scenario sc = scenario_device(file, default_device_path, default_tip, default_root);
  read_counts(file, sc);
  read_poses(file, sc);
  read_calibration(file, sc);
  read_measurement(file, sc);
  read_sockets(file, sc);
  read_planes(file, sc);
  complete_fixture(file, sc);
  read_transmissions(file, sc);
  read_random_deviations(file, sc);
  read_trajectory(file, sc);
  read_noise(file, sc);
  read_deviations(file, sc);
  read_session(file, sc);
  detail::check_simulated_limits(sc);
  read_iso9283(file, sc);  // the cube within limits a simulation can draw
  assign_truth(sc, path);
  return sc;
}

}  // namespace hapticcal
