#include "hapticcal/study/study.hpp"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <mutex>
#include <nlohmann/json.hpp>
#include <numbers>
#include <random>
#include <thread>

#include "hapticcal/design/plan.hpp"
#include "hapticcal/identification/information.hpp"
#include "hapticcal/identification/two_step.hpp"
#include "hapticcal/io/error.hpp"
#include "hapticcal/io/model_source.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "io/yaml_reader.hpp"

namespace hapticcal {
namespace {

double rms(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x * x;
  return v.empty() ? 0 : std::sqrt(s / v.size());
}

// Distance errors of a model on a log with distances.
double distance_rms(const DeviceModel& model, const Log& log) {
  return evaluate(model, log).distance->rms;
}

Eigen::VectorXd readings(const Log& log, int r) { return log.q.row(r).transpose(); }

// Cramer-Rao variances at the truth for the two-step procedure. Step 1: each
// fitted transmission's parameters (and c) from its external encoder, Fisher
// information J^T J / sigma_e^2. Step 2: the kinematic parameters from the
// distances, J_k^T J_k / sigma_m^2, plus the step-1 bounds carried in through the
// compensated angles: d kin = G d trans with G = -(J_k^T J_k)^-1 J_k^T J_t, J_t
// the distances' sensitivity to the transmission parameters.
std::map<std::string, double> crlb(const Scenario& sc, const Log& ident,
                                   const CalibrationResult& full) {
  if (is_fixture(sc.measurement)) return {};  // not derived for fixtures (tests/fixture_test)
  std::vector<int> slots;
  std::vector<std::string> names;
  for (const ParameterEstimate& e : full.kinematics.parameters) {
    if (!e.identifiable) continue;
    if (e.name == "instrument.zero") continue;  // the study's instruments have none
    slots.push_back(e.slot);
    names.push_back(e.name);
  }
  // The step-1 models as fitted (a polynomial in its basis), at the truth's readings.
  std::vector<StepOneModel> step_one;
  for (const TransmissionFit& t : full.transmissions) {
    const Transmission& model = full.calibrated.links[t.joint].transmission;
    step_one.push_back(
        {t.joint, model,
         std::vector<std::string>(t.names.begin(), t.names.begin() + model.num_parameters())});
  }
  // Every residual row with the sd sigma_m: a pose's rotation rows scaled by
  // sigma_m / sigma_r.
  const double sigma_m = measurement_sigma(sc);
  const double rotation_scale =
      sc.measurement == MeasurementType::kPose ? sigma_m / sc.noise.sigma_orientation : 1.0;
  const TwoStepJacobians J =
      two_step_jacobians(sc.actual, sc.measurement, rotation_scale, slots, step_one, ident.q);
  const TwoStepBound bound =
      two_step_crlb(J.kinematic, names, sigma_m, J.step_one, sc.noise.sigma_ext);
  std::map<std::string, double> out;
  for (size_t c = 0; c < bound.names.size(); ++c) out[bound.names[c]] = bound.variance[c];
  return out;
}

double rotation_angle(const Eigen::Matrix3d& R) { return Eigen::AngleAxisd(R).angle(); }

}  // namespace

double measurement_sigma(const Scenario& sc) {
  return sc.measurement == MeasurementType::kDistance ? sc.noise.sigma_distance
                                                      : sc.noise.sigma_position;
}

double improvement_pct(double assigned, double nominal, double identified) {
  return (1 - std::abs(assigned - identified) / std::abs(assigned - nominal)) * 100;
}

namespace {

// Eq. (8), undefined (NaN) for a parameter whose truth is its nominal value.
double improvement_or_nan(double assigned, double nominal, double identified) {
  return assigned == nominal ? std::numeric_limits<double>::quiet_NaN()
                             : improvement_pct(assigned, nominal, identified);
}

}  // namespace

std::vector<StudyRow> study_rows(const Scenario& sc, const CalibrationResult& full) {
  std::vector<StudyRow> rows;
  for (const TransmissionFit& t : full.transmissions) {
    const Transmission& truth = sc.actual.links[t.joint].transmission;
    if (t.type != "capstan" || !std::holds_alternative<Capstan>(truth.model())) continue;
    const Eigen::VectorXd tv = truth.parameters();
    for (int c = 0; c < 5; ++c) {
      const DisplayUnit u = display_unit(t, c);
      rows.push_back({t.names[c], true, tv[c], t.nominal[c], t.value[c],
                      improvement_or_nan(tv[c], t.nominal[c], t.value[c]), "", u.scale, u.unit});
    }
  }
  const Eigen::VectorXd truth = sc.actual.kinematic_parameters();
  for (const ParameterEstimate& e : full.kinematics.parameters) {
    if (e.slot >= truth.size()) continue;  // the instrument's zero: not the device's
    const double assigned = truth[e.slot];
    if (!e.identifiable && assigned == e.nominal) continue;
    const DisplayUnit u = display_unit(e.unit);
    rows.push_back({e.name, false, assigned, e.nominal, e.value,
                    e.identifiable ? improvement_or_nan(assigned, e.nominal, e.value) : 0.0,
                    e.identifiable ? "" : e.reason, u.scale, u.unit});
  }
  return rows;
}

bool is_paper_device(const DeviceModel& model) {
  DeviceModel paper;
  try {
    paper = load_device(builtin_device_path());
  } catch (const std::exception&) {
    return false;  // no built-in device here: nothing can be the paper's
  }
  return model.name == paper.name && model.dof() == paper.dof() &&
         model.base_kind == paper.base_kind &&
         model.kinematic_parameters() == paper.kinematic_parameters();
}

namespace {

void check_simulated_limits(const Scenario& sc);

// Every pair of sockets' distance, as --point-distance gives it.
std::vector<PointDistance> socket_distances(
    const std::vector<std::pair<std::string, Eigen::Vector3d>>& sockets) {
  std::vector<PointDistance> out;
  for (size_t a = 0; a < sockets.size(); ++a) {
    for (size_t b = a + 1; b < sockets.size(); ++b) {
      out.push_back(
          {sockets[a].first, sockets[b].first, (sockets[a].second - sockets[b].second).norm()});
    }
  }
  return out;
}

// The kinematic parameters `type` identifies on `nominal` (calibrate's
// candidates and priority order, its rank test on exact synthetic measurements
// over the joint limits): those random deviations move, so that the truth is
// one a calibration can recover.
std::vector<int> identifiable_slots(const DeviceModel& nominal, const Scenario& sc) {
  const MeasurementType type = sc.measurement;
  const std::vector<std::string>& fix = sc.fix;
  const auto& sockets = sc.sockets;
  const bool known = sc.socket_distances_known;
  constexpr int kPoses = 200;
  constexpr std::uint64_t kSeed = 20130101;
  SimulationNoise exact;
  exact.sigma_ext = exact.sigma_distance = exact.sigma_position = exact.sigma_orientation = 0;
  CalibrationOptions options;
  options.fix = fix;
  const Log log = type == MeasurementType::kPoint
                      ? simulate_fixture_log(nominal, sockets,
                                             kPoses / static_cast<int>(sockets.size()), 0, kSeed)
                  : type == MeasurementType::kPlane
                      ? simulate_plane_log(nominal, sc.planes,
                                           kPoses / static_cast<int>(sc.planes.size()), 0, kSeed)
                      : simulate_measurement_log(nominal, type, kPoses, {}, exact, kSeed);
  if (type == MeasurementType::kPoint && known) options.point_distances = socket_distances(sockets);
  const KinematicProblem problem = kinematic_problem(nominal, log, {}, options);
  std::vector<int> slots =
      analyze_identifiability(problem, candidate_slots(nominal, fix, {})).identified;
  std::sort(slots.begin(), slots.end());
  return slots;
}

}  // namespace

void assign_truth(Scenario& sc, const std::string& source) {
  if (sc.paper_transmissions && !sc.paper_device) {
    throw InputError(source, 0, "transmissions",
                     "the paper's capstans and joint-4 linkage (Table 2) are the truth of the "
                     "paper's device only: this device's own transmissions are its truth "
                     "(transmissions: device)");
  }
  if (sc.paper_transmissions && !sc.random.enabled()) {
    sc.actual = paper_actual_device(sc.nominal);  // SPEC section 3, as it always was
  } else {
    sc.actual = sc.nominal;
    if (sc.paper_transmissions) {
      const DeviceModel paper = paper_actual_device(sc.nominal);
      for (int j = 0; j < sc.nominal.dof(); ++j)
        sc.actual.links[j].transmission = paper.links[j].transmission;
    } else if (sc.paper_device && !sc.random.enabled()) {
      sc.actual.set_kinematic_parameters(paper_actual_device(sc.nominal).kinematic_parameters());
    }
  }
  const Eigen::VectorXd nominal = sc.nominal.kinematic_parameters();
  Eigen::VectorXd truth = sc.actual.kinematic_parameters();
  const std::vector<ParameterInfo> info = sc.nominal.parameter_info();
  if (sc.random.enabled()) {
    std::mt19937_64 rng(sc.random.seed);
    std::normal_distribution<double> gauss(0.0, 1.0);
    for (int slot : identifiable_slots(sc.nominal, sc)) {
      const bool angle = info[slot].unit == ParameterUnit::kAngle;
      truth[slot] = nominal[slot] + (angle ? sc.random.angles : sc.random.lengths) * gauss(rng);
    }
  }
  for (const auto& [dotted, value] : sc.deviations) {
    const std::string& name =
        dotted;  // (a structured binding is not captured before C++20's P1091)
    const auto it = std::find_if(info.begin(), info.end(),
                                 [&](const ParameterInfo& p) { return p.name == name; });
    if (it == info.end())
      throw InputError(source, 0, "deviations." + name, "not a kinematic parameter of the device");
    truth[it->slot] = nominal[it->slot] + value;
  }
  if (sc.random.enabled() || !sc.deviations.empty()) sc.actual.set_kinematic_parameters(truth);
}

Scenario default_scenario(const std::string& device_path, const std::string& tip,
                          const std::string& root) {
  Scenario sc;
  sc.device_path = device_path;
  sc.tip = tip;
  sc.root = root;
  sc.nominal = load_model(device_path, tip, root);
  sc.paper_device = is_paper_device(sc.nominal);
  sc.noise.sigma_orientation = kDefaultSigmaR;  // a pose's, if one is measured
  if (sc.paper_device) {
    sc.actual = paper_actual_device(sc.nominal);
    return sc;
  }
  sc.paper_transmissions = false;
  sc.random = {kDefaultLengthDeviationSd, kDefaultAngleDeviationSd, sc.seed};
  sc.noise.sigma_distance = sc.noise.sigma_position = kDefaultSigmaM;
  sc.sigma_m_formula = "default";
  check_simulated_limits(sc);
  assign_truth(sc, device_path);
  return sc;
}

namespace {

// Bounds on the numbers of a scenario file: a typo must not ask for terabytes
// of samples or a deviation that no device has.
constexpr int kMaxTrials = 100000;
constexpr size_t kMaxSockets = 20;
constexpr size_t kMaxPlanes = 20;
constexpr double kMaxSocketCoordinate = 100;  // m
constexpr int kMaxPoses = 1000000;
constexpr double kMaxTrajectorySeconds = 1e5;
constexpr double kMaxRateHz = 1e5;
constexpr double kMaxTrajectorySamples = 1e7;  // seconds * rate_hz
constexpr double kMaxCountsPerRev = 1e9;
constexpr double kMaxSigmaAngle = 1;                     // rad
constexpr double kMaxSigmaLength = 1;                    // m
constexpr double kMaxLengthDeviation = 1;                // m
constexpr double kMaxAngleDeviation = std::numbers::pi;  // rad

}  // namespace

Scenario load_scenario(const std::string& path, const std::string& default_device_path,
                       const std::string& default_tip, const std::string& default_root) {
  const std::string text = read_file(path, FileKind::kScenario);
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(path, e.mark.is_null() ? 0 : e.mark.line + 1, "", "YAML: " + e.msg);
  }
  const detail::YamlReader r(path);
  r.check_keys(root, "",
               {"format", "device", "tip", "root", "seed", "trials", "poses", "trajectory", "noise",
                "deviations", "random_deviations", "transmissions", "measurement", "calibration",
                "sockets", "socket_distances", "planes"});
  const std::string format = r.string(r.require(root, "", "format"), "format");
  if (format != "hapticcal-scenario/1") {
    r.fail(root["format"], "format",
           fmt::format("'{}' is not 'hapticcal-scenario/1'", printable(format)));
  }
  std::string device = default_device_path;
  if (root["device"]) {
    device = r.string(root["device"], "device");
    const std::filesystem::path p(device);
    if (p.is_relative()) device = (std::filesystem::path(path).parent_path() / p).string();
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
  Scenario sc = default_scenario(device, tip, chain_root);
  auto positive_int = [&](const YAML::Node& node, const std::string& key, int lo, int hi) {
    const double v = r.number(node, key);
    if (v != std::floor(v) || v < lo || v > hi)
      r.fail(node, key, fmt::format("expected an integer in [{}, {}]", lo, hi));
    return static_cast<int>(v);
  };
  if (root["seed"])
    sc.seed = static_cast<std::uint64_t>(positive_int(root["seed"], "seed", 0, 2000000000));
  if (root["trials"]) sc.trials = positive_int(root["trials"], "trials", 1, kMaxTrials);
  if (const YAML::Node poses = root["poses"]) {
    r.check_keys(poses, "poses", {"identification", "validation"});
    const YAML::Node id = poses["identification"];
    auto is_number = [](const std::string& text) {
      char* end = nullptr;
      std::strtod(text.c_str(), &end);
      return !text.empty() && end == text.c_str() + text.size();
    };
    if (id && id.IsScalar() && id.Tag() != "!" && !is_number(id.Scalar())) {
      // A plan: measure at its readings.
      std::filesystem::path plan(id.Scalar());
      if (plan.is_relative()) plan = std::filesystem::path(path).parent_path() / plan;
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
    } else if (id) {
      sc.identification_poses = positive_int(id, "poses.identification", 1, kMaxPoses);
    }
    if (poses["validation"])
      sc.validation_poses = positive_int(poses["validation"], "poses.validation", 1, kMaxPoses);
  }
  if (const YAML::Node cal = root["calibration"]) {
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
  if (const YAML::Node m = root["measurement"]) {
    const std::string name = r.string(m, "measurement");
    std::optional<MeasurementType> type = measurement_kind(name);
    if (name == "point") type = MeasurementType::kPoint;
    if (name == "plane") type = MeasurementType::kPlane;
    if (!type) {
      r.fail(m, "measurement",
             fmt::format("'{}' is not a measurement simulate produces: distance, position, pose, "
                         "point or plane",
                         printable(name)));
    }
    sc.measurement = *type;
  }
  if (const YAML::Node sockets = root["sockets"]) {
    if (sc.measurement != MeasurementType::kPoint)
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
  if (const YAML::Node known = root["socket_distances"]) {
    const std::string value = r.string(known, "socket_distances");
    if (sc.measurement != MeasurementType::kPoint)
      r.fail(known, "socket_distances", "socket distances are for measurement: point");
    if (value != "known" && value != "unknown")
      r.fail(known, "socket_distances", "expected known or unknown");
    sc.socket_distances_known = value == "known";
  }
  if (const YAML::Node planes = root["planes"]) {
    if (sc.measurement != MeasurementType::kPlane)
      r.fail(planes, "planes", "planes are for measurement: plane");
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
  if (sc.measurement == MeasurementType::kPoint && sc.sockets.empty())
    sc.sockets = default_sockets(sc.nominal);
  if (sc.measurement == MeasurementType::kPlane && sc.planes.empty())
    sc.planes = default_planes(sc.nominal);
  // Enough samples a label: 2 a socket (a point is 3 unknowns), 4 a plane (any
  // 3 points lie on one).
  if (is_fixture(sc.measurement)) {
    const bool point = sc.measurement == MeasurementType::kPoint;
    const int labels = static_cast<int>(point ? sc.sockets.size() : sc.planes.size());
    const int least = point ? 2 : 4;
    if (sc.identification_poses / labels < least) {
      const YAML::Node poses = root["poses"];
      r.fail(poses ? poses["identification"] : root, "poses.identification",
             fmt::format("{} poses over {} {} are fewer than the {} {} needs: give at least {}",
                         sc.identification_poses, labels, point ? "sockets" : "planes", least,
                         point ? "a socket" : "a plane", least * labels));
    }
  }
  if (const YAML::Node t = root["transmissions"]) {
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
  if (const YAML::Node rd = root["random_deviations"]) {
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
      random.seed = static_cast<std::uint64_t>(
          positive_int(rd["seed"], "random_deviations.seed", 0, 2000000000));
    if (!random.enabled())
      r.fail(rd, "random_deviations", "give lengths and/or angles: a standard deviation above 0");
    sc.random = random;
  } else if (!sc.paper_device) {
    sc.random.seed = sc.seed;  // the default deviations follow the scenario's seed
  }
  if (const YAML::Node tr = root["trajectory"]) {
    r.check_keys(tr, "trajectory", {"seconds", "rate_hz"});
    auto bounded = [&](const YAML::Node& node, const std::string& key, double hi,
                       const char* unit) {
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
  if (const YAML::Node noise = root["noise"]) {
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
    const bool paper_encoder = sc.paper_device && sc.measurement == MeasurementType::kDistance;
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
      if (sc.measurement != MeasurementType::kPose)
        r.fail(sr, "noise.sigma_r", "a rotation's noise applies to pose measurements only");
      sc.noise.sigma_orientation = level(sr, "noise.sigma_r", kMaxSigmaAngle, "rad");
    }
    if (!(sc.noise.sigma_ext > 0 && sc.noise.sigma_distance > 0 && sc.noise.sigma_orientation > 0))
      r.fail(noise, "noise", "noise levels must be positive");
  }
  if (sc.measurement != MeasurementType::kDistance) {
    if (sc.paper_device && sc.sigma_m_formula == "paper") {
      // The paper's cable-encoder noise is no tracker's: the general default.
      sc.noise.sigma_distance = kDefaultSigmaM;
      sc.sigma_m_formula = "default";
    }
    sc.noise.sigma_position = sc.noise.sigma_distance;
  }
  if (const YAML::Node dev = root["deviations"]) {
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
  check_simulated_limits(sc);
  assign_truth(sc, path);
  return sc;
}

std::uint64_t trial_seed(std::uint64_t study_seed, int trial) {
  std::uint64_t z = study_seed + 0x9E3779B97F4A7C15ull * static_cast<std::uint64_t>(trial + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

TrialResult run_trial(const Scenario& sc, std::uint64_t seed, const std::string& out) {
  TrialResult t;
  t.seed = seed;
  Log ident =
      sc.measurement == MeasurementType::kPoint
          ? simulate_fixture_log(sc.actual, sc.sockets,
                                 sc.identification_poses / static_cast<int>(sc.sockets.size()),
                                 sc.noise.sigma_position, trial_seed(seed, 0))
      : sc.measurement == MeasurementType::kPlane
          ? simulate_plane_log(sc.actual, sc.planes,
                               sc.identification_poses / static_cast<int>(sc.planes.size()),
                               sc.noise.sigma_position, trial_seed(seed, 0))
          : simulate_measurement_log(sc.actual, sc.measurement, sc.identification_poses,
                                     sc.identification_readings, sc.noise, trial_seed(seed, 0));
  SimulationNoise exact = sc.noise;
  exact.sigma_position = 0;  // a perfect tracker: validation scores against the truth
  Log val = simulate_log(sc.actual, sc.validation_poses, exact, trial_seed(seed, 1), true, true);
  const bool files = !out.empty();
  if (files) {
    // The honest pipeline: what calibration sees comes from the files a real
    // experiment would produce.
    save_device(sc.nominal, out + "/nominal.yaml");
    save_device(sc.actual, out + "/actual.yaml");
    write_file_atomically(out + "/identification.csv", log_to_csv(ident));
    write_file_atomically(out + "/validation.csv", log_to_csv(val));
    ident = read_log(out + "/identification.csv");
    val = read_log(out + "/validation.csv");
  }
  CalibrationOptions options;
  options.keep_all = sc.keep_all;
  options.fix = sc.fix;
  // The simulated instruments read without a zero error: the study is of the
  // device's parameters (and their Cramer-Rao bound), as the paper's.
  options.instrument_zero = false;
  if (sc.measurement == MeasurementType::kPoint && sc.socket_distances_known)
    options.point_distances = socket_distances(sc.sockets);
  t.full = calibrate(sc.nominal, ident, options);
  CalibrationOptions kin = options;
  kin.transmissions = false;
  t.kinematic_only = calibrate(sc.nominal, ident, kin);

  // Fig. 8: validation poses against the truth.
  const PreparedModel truth(sc.actual), before(sc.nominal), after(t.full.calibrated);
  std::vector<double> position_before, position_after, orientation_before, orientation_after;
  for (int r = 0; r < val.rows; ++r) {
    const Eigen::VectorXd q = readings(val, r);
    const Frame<double> Ta = truth.forward(q.data()), Tb = before.forward(q.data()),
                        Tc = after.forward(q.data());
    position_before.push_back((Tb.p - Ta.p).norm());
    position_after.push_back((Tc.p - Ta.p).norm());
    orientation_before.push_back(rotation_angle(Ta.R.transpose() * Tb.R));
    orientation_after.push_back(rotation_angle(Ta.R.transpose() * Tc.R));
  }
  t.position_rms_before = rms(position_before);
  t.position_rms_after = rms(position_after);
  t.orientation_rms_before = rms(orientation_before);
  t.orientation_rms_after = rms(orientation_after);
  t.distance_rms_before = distance_rms(sc.nominal, val);
  t.distance_rms_after = distance_rms(t.full.calibrated, val);
  t.crlb_variance = crlb(sc, ident, t.full);
  if (!files) return t;

  // Fig. 10: the continuous motion, and the series for the figures.
  Log traj = simulate_trajectory(sc.actual, sc.trajectory_seconds, sc.trajectory_rate_hz, sc.noise,
                                 trial_seed(seed, 2));
  write_file_atomically(out + "/trajectory.csv", log_to_csv(traj));
  traj = read_log(out + "/trajectory.csv");
  const Evaluation eb = evaluate(sc.nominal, traj), ef = evaluate(t.full.calibrated, traj),
                   ek = evaluate(t.kinematic_only.calibrated, traj);
  t.trajectory_rms_before = eb.distance->rms;
  t.trajectory_rms_full = ef.distance->rms;
  t.trajectory_rms_kinematic = ek.distance->rms;
  save_device(t.full.calibrated, out + "/calibrated.yaml");
  save_device(t.kinematic_only.calibrated, out + "/calibrated-kinematic-only.yaml");

  t.figures.identification = ident;
  std::string fig10 = "t,distance,error_nominal,error_full,error_kinematic_only\n";
  t.figures.fig10.assign(5, {});
  const int step = std::max(1, static_cast<int>(sc.trajectory_rate_hz / 100));  // 100 Hz
  for (int r = 0; r < traj.rows; r += step) {
    const double row[] = {traj.t[r], traj.distance[r], eb.distance_error[r], ef.distance_error[r],
                          ek.distance_error[r]};
    fig10 += fmt::format("{},{},{},{},{}\n", row[0], row[1], row[2], row[3], row[4]);
    for (int c = 0; c < 5; ++c) t.figures.fig10[c].push_back(row[c]);
  }
  write_file_atomically(out + "/fig10_trajectory.csv", fig10);
  std::string fig8 = "pose,position_before,position_after,orientation_before,orientation_after\n";
  t.figures.fig8.assign(5, {});
  for (size_t r = 0; r < position_before.size(); ++r) {
    const double row[] = {static_cast<double>(r + 1), position_before[r], position_after[r],
                          orientation_before[r], orientation_after[r]};
    fig8 += fmt::format("{},{},{},{},{}\n", r + 1, row[1], row[2], row[3], row[4]);
    for (int c = 0; c < 5; ++c) t.figures.fig8[c].push_back(row[c]);
  }
  write_file_atomically(out + "/fig8_validation.csv", fig8);
  // Fig. 7: joint 4's transmission error: measured (ext - q - c), identified, true.
  for (const TransmissionFit& f : t.full.transmissions) {
    if (f.type != "polynomial") continue;
    const Transmission& fitted = t.full.calibrated.links[f.joint].transmission;
    const Transmission& real = sc.actual.links[f.joint].transmission;
    std::string fig7 = "q,measured,identified,truth\n";
    auto& series = t.figures.fig7[t.full.calibrated.links[f.joint].name];
    series.assign(4, {});
    for (int r = 0; r < ident.rows; ++r) {
      const double q = ident.q(r, f.joint);
      const double row[] = {q, ident.ext(r, f.joint) - q - f.offset, fitted.error(q),
                            real.error(q)};
      fig7 += fmt::format("{},{},{},{}\n", row[0], row[1], row[2], row[3]);
      for (int c = 0; c < 4; ++c) series[c].push_back(row[c]);
    }
    write_file_atomically(out + fmt::format("/fig7_{}.csv", t.full.calibrated.links[f.joint].name),
                          fig7);
  }
  return t;
}

namespace {

// A simulation draws readings within the joint limits: limits of 1e308 would
// overflow its own log into inf. Refused, naming the device file.
void check_simulated_limits(const Scenario& sc) {
  constexpr double kWidest = 1e3;  // rad or m
  for (const DeviceModel* m : {&sc.actual, &sc.nominal}) {
    for (int i = 0; i < m->dof(); ++i) {
      const Link& l = m->links[i];
      if (std::abs(l.lower) <= kWidest && std::abs(l.upper) <= kWidest) continue;
      throw InputError(sc.device_path, 0, fmt::format("links[{}].limits", i),
                       fmt::format("[{}, {}]: a simulation draws readings within the limits; at "
                                   "most +-{:g} rad or m",
                                   l.lower, l.upper, kWidest));
    }
  }
}

// A trial's own pipeline failed (its identification log written and read back,
// then calibrated): the message names the trial, not a staging file that is
// gone by the time it is read, nor an option the user never gave.
InputError study_failure(const Scenario& sc, int trial, const InputError& e) {
  std::string what = e.message();
  for (const auto& [option, instead] :
       {std::pair<std::string, std::string>{"--point-distance", "the scenario's socket distances"},
        {"--fixture", "the scenario's sockets"}}) {
    for (size_t at = what.find(option); at != std::string::npos; at = what.find(option, at)) {
      what.replace(at, option.size(), instead);
      at += instead.size();
    }
  }
  const bool simulated = e.file().find("/identification.csv") != std::string::npos ||
                         e.file().find("/validation.csv") != std::string::npos ||
                         e.file().find("/trajectory.csv") != std::string::npos;
  const std::string where =
      simulated
          ? fmt::format("its simulated {}{}", std::filesystem::path(e.file()).filename().string(),
                        e.line() > 0 ? fmt::format(" (line {})", e.line()) : "")
      : e.file().empty()
          ? std::string("its calibration")
          : fmt::format("{}{}", e.file(), e.line() > 0 ? fmt::format(":{}", e.line()) : "");
  return InputError(fmt::format("simulate: trial {} of {} (seed {}): {}: {}{}", trial + 1,
                                sc.trials, sc.seed, where, e.key().empty() ? "" : e.key() + ": ",
                                what));
}

}  // namespace

StudyResult run_study(const Scenario& sc, const std::string& out, int threads,
                      const std::function<void(int, int)>& progress) {
  // The command line's bounds, for every caller (Python's trials=10**9).
  if (sc.trials < 1 || sc.trials > 100000) {
    throw InputError(fmt::format("--trials {}: not in [1, 100000]", sc.trials));
  }
  check_simulated_limits(sc);
  const int n = sc.trials;
  std::vector<TrialResult> trials(n);
  std::atomic<int> next{0}, done{0};
  std::mutex report;
  std::exception_ptr failure;
  auto worker = [&] {
    for (int k = next++; k < n; k = next++) {
      try {
        trials[k] = run_trial(sc, trial_seed(sc.seed, k), k == 0 ? out : "");
      } catch (const InputError& e) {
        const std::lock_guard<std::mutex> lock(report);
        if (!failure) failure = std::make_exception_ptr(study_failure(sc, k, e));
      } catch (...) {
        const std::lock_guard<std::mutex> lock(report);
        if (!failure) failure = std::current_exception();
      }
      const int finished = ++done;
      if (progress) {
        const std::lock_guard<std::mutex> lock(report);
        progress(finished, n);
      }
    }
  };
  threads = std::max(1, std::min(threads, n));
  std::vector<std::thread> pool;
  for (int i = 1; i < threads; ++i) pool.emplace_back(worker);
  worker();
  for (std::thread& th : pool) th.join();
  if (failure) std::rethrow_exception(failure);

  StudyResult result;
  result.trials = n;
  result.threads = threads;
  // Statistics in trial order, so the thread count cannot change them.
  std::map<std::string, std::vector<double>> identified, improvement_pct, variance;
  std::map<std::string, StudyRow> reference;
  for (const TrialResult& t : trials) {
    for (const StudyRow& row : study_rows(sc, t.full)) {
      if (!row.held.empty()) continue;
      identified[row.name].push_back(row.identified);
      improvement_pct[row.name].push_back(row.improvement_pct);
      reference[row.name] = row;
      const auto v = t.crlb_variance.find(row.name);
      if (v != t.crlb_variance.end()) variance[row.name].push_back(v->second);
    }
  }
  for (const auto& [name, values] : identified) {
    MonteCarloStats m;
    m.trials = static_cast<int>(values.size());
    m.assigned = reference[name].assigned;
    m.nominal = reference[name].nominal;
    double sum = 0, sq = 0, ip = 0;
    for (size_t k = 0; k < values.size(); ++k) {
      sum += values[k];
      sq += (values[k] - m.assigned) * (values[k] - m.assigned);
      ip += improvement_pct[name][k];
    }
    m.mean = sum / values.size();
    m.rmse = std::sqrt(sq / values.size());
    m.mean_improvement_pct = ip / values.size();
    std::vector<double> sorted = improvement_pct[name];
    std::sort(sorted.begin(), sorted.end());
    m.improvement_p05 = sorted[static_cast<size_t>(0.05 * (sorted.size() - 1))];
    m.improvement_p95 = sorted[static_cast<size_t>(0.95 * (sorted.size() - 1))];
    double var = 0;
    for (double v : variance[name]) var += v;
    m.crlb_sd = variance[name].empty() ? 0 : std::sqrt(var / variance[name].size());
    m.efficiency = m.crlb_sd > 0 ? m.rmse / m.crlb_sd : 0;
    result.monte_carlo[name] = m;
  }
  result.first = std::move(trials[0]);
  return result;
}

namespace {

// results.json beyond the paper's study: no paper figures; what the truth is
// and each parameter's assigned and identified deviation, and its error in
// Cramer-Rao standard deviations.
void general_study_json(const Scenario& sc, const StudyResult& r, nlohmann::ordered_json& j) {
  using json = nlohmann::ordered_json;
  if (!sc.tip.empty()) j["tip"] = sc.tip;
  if (!sc.root.empty()) j["root"] = sc.root;
  j["measurement"] = traits(sc.measurement).name;
  if (sc.measurement == MeasurementType::kPose) j["noise"]["sigma_r"] = sc.noise.sigma_orientation;
  json truth = {{"transmissions", sc.paper_transmissions ? "paper" : "device"},
                {"kinematics", sc.random.enabled() ? "random"
                               : sc.paper_device   ? "paper Table 3"
                                                   : "nominal"}};
  if (sc.random.enabled()) {
    truth["random_deviations"] = {
        {"lengths", sc.random.lengths}, {"angles", sc.random.angles}, {"seed", sc.random.seed}};
  }
  truth["deviations"] = sc.deviations;
  j["truth"] = truth;
  for (auto& [name, p] : j["parameters"].items()) {
    p.erase("paper_improvement_pct");
    const double assigned = p["assigned"], identified = p["identified"];
    const auto mc = r.monte_carlo.find(name);
    const double sd = mc != r.monte_carlo.end() ? mc->second.crlb_sd : 0;
    p["error_in_crlb_sd"] = sd > 0 ? json((identified - assigned) / sd) : json(nullptr);
  }
  j["trajectory"].erase("paper_improvement_full_pct");
  j["trajectory"].erase("paper_improvement_kinematic_only_pct");
}

}  // namespace

std::string study_json(const Scenario& sc, const StudyResult& r) {
  using json = nlohmann::ordered_json;
  const TrialResult& t = r.first;
  json j;
  j["format"] = "hapticcal-study/1";
  j["device"] = sc.device_path;
  j["seed"] = sc.seed;
  j["trials"] = r.trials;
  j["noise"] = {{"sigma_e", sc.noise.sigma_ext},
                {"sigma_m", sc.noise.sigma_distance},
                {"sigma_m_formula", sc.sigma_m_formula},
                {"motor_counts_per_rev", sc.noise.motor_counts_per_rev}};
  j["poses"] = {{"identification", sc.identification_poses}, {"validation", sc.validation_poses}};
  if (!sc.identification_plan.empty()) j["identification_plan"] = sc.identification_plan;
  // Only when not the paper's procedure (the default study's file is unchanged).
  if (!sc.keep_all || !sc.fix.empty())
    j["calibration"] = {{"keep_all", sc.keep_all}, {"fix", sc.fix}};
  json params = json::object();
  std::map<std::string, StudyRow> by_name;  // results.json lists them alphabetically
  for (const StudyRow& row : study_rows(sc, t.full)) {
    if (row.held.empty()) by_name[row.name] = row;
  }
  for (const auto& [name, row] : by_name) {
    const auto paper = paper_improvement_pct(name);
    const auto mc = r.monte_carlo.find(name);
    params[name] = {
        {"assigned", row.assigned},
        {"nominal", row.nominal},
        {"identified", row.identified},
        {"assigned_deviation", row.assigned - row.nominal},
        {"identified_deviation", row.identified - row.nominal},
        {"improvement_pct", row.improvement_pct},
        {"paper_improvement_pct", paper ? json(*paper) : json(nullptr)},
        {"crlb_sd", mc != r.monte_carlo.end() ? json(mc->second.crlb_sd) : json(nullptr)}};
  }
  j["parameters"] = params;
  j["held"] = json::object();
  for (const ParameterEstimate& e : t.full.kinematics.parameters) {
    if (!e.identifiable) j["held"][e.name] = e.reason;
  }
  j["validation"] = {{"position_rms_before", t.position_rms_before},
                     {"position_rms_after", t.position_rms_after},
                     {"orientation_rms_before", t.orientation_rms_before},
                     {"orientation_rms_after", t.orientation_rms_after},
                     {"distance_rms_before", t.distance_rms_before},
                     {"distance_rms_after", t.distance_rms_after}};
  j["trajectory"] = {
      {"rms_before", t.trajectory_rms_before},
      {"rms_full", t.trajectory_rms_full},
      {"rms_kinematic_only", t.trajectory_rms_kinematic},
      {"improvement_full_pct", rms_improvement_pct(t.trajectory_rms_full, t.trajectory_rms_before)},
      {"improvement_kinematic_only_pct",
       rms_improvement_pct(t.trajectory_rms_kinematic, t.trajectory_rms_before)},
      {"paper_improvement_full_pct", kPaperImprovementFullPct},
      {"paper_improvement_kinematic_only_pct", kPaperImprovementKinematicOnlyPct}};
  if (r.trials > 1) {
    json mc = json::object();
    for (const auto& [name, m] : r.monte_carlo) {
      mc[name] = {{"assigned", m.assigned},
                  {"mean", m.mean},
                  {"mean_improvement_pct", m.mean_improvement_pct},
                  {"rmse", m.rmse},
                  {"crlb_sd", m.crlb_sd},
                  {"efficiency", m.efficiency},
                  {"improvement_p05", m.improvement_p05},
                  {"improvement_p95", m.improvement_p95},
                  {"trials", m.trials}};
    }
    j["monte_carlo"] = mc;
  }
  if (!sc.paper_comparison()) general_study_json(sc, r, j);
  return j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

}  // namespace hapticcal
