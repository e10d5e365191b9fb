// Calibration without an instrument (issue 13): fixture points (a ball tip put
// into the sockets of a fixture) and plane contacts, on the real MUKCa Franka
// Panda data (data/real/mukca, held-out placements) and on simulated data.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "hapticcal/identification/identification.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/model_source.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "hapticcal/study/simulation.hpp"
#include "identification/problem/stack.hpp"
#include "nlohmann/json.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

const char* kPlacements[] = {"back-high", "front", "right"};

// The MUKCa recordings of some placements as one fixture log: a row a
// configuration, labelled <placement>_<socket>.
Log mukca_log(const std::vector<std::string>& placements) {
  return parse_log(testing::mukca_csv(placements), "mukca");
}

std::vector<PointDistance> socket_distances(const std::vector<std::string>& placements) {
  std::vector<PointDistance> out;
  for (const std::string& p : placements) out.push_back({p + "_0", p + "_1", 0.05});
  return out;
}

DeviceModel panda() {
  return load_model(testing::real_data_path("mukca/panda.urdf"), "ball_link", "panda_link0");
}

// Leave one placement out: calibrate on the other two, evaluate on it (issue 13:
// nominal 7.5-10.3 mm; a reference fit with every joint origin free 0.96 /
// 0.66 / 0.72 mm, mean 0.78; the target, a mean of 0.70 mm, is not met:
// see docs/fixtures.md).
TEST(Fixture, MukcaPandaHeldOutPlacements) {
  const DeviceModel nominal = panda();
  double sum[2] = {0, 0};
  for (const bool keep_all : {false, true}) {
    for (const char* held_out : kPlacements) {
      std::vector<std::string> train;
      for (const char* p : kPlacements) {
        if (std::string(p) != held_out) train.push_back(p);
      }
      CalibrationOptions options;
      options.point_distances = socket_distances(train);
      options.keep_all = keep_all;
      options.search = !keep_all;  // --keep-all: one model
      const CalibrationResult r = calibrate(nominal, mukca_log(train), options);
      EXPECT_EQ(r.status, CalibrationStatus::kConverged) << held_out << ": " << r.status_reason;
      // Angles are reported in (-pi, pi] of nominal: the default fit on front
      // and right turned panda_joint7.pitch by 10.99 rad, a -1.58 rad turn.
      for (const ParameterEstimate& e : r.kinematics.parameters) {
        if (e.unit == ParameterUnit::kAngle) {
          EXPECT_LE(std::abs(e.value - e.nominal), M_PI) << e.name;
        }
      }
      const Log test = mukca_log({held_out});
      const std::vector<PointDistance> known = socket_distances({held_out});
      const Evaluation before = evaluate(nominal, test, known);
      const Evaluation after = evaluate(r.calibrated, test, known);
      std::printf(
          "%-9s %-10s mean point deviation %.3f -> %.3f mm, distance error %.3f -> %.3f mm (%d of "
          "%d parameters, %d iterations)\n",
          keep_all ? "keep-all" : "default", held_out, *before.mean_point_deviation * 1e3,
          *after.mean_point_deviation * 1e3, *before.max_point_distance_error * 1e3,
          *after.max_point_distance_error * 1e3, r.kinematics.identified,
          r.kinematics.structurally_identified, r.kinematics.iterations);
      EXPECT_LT(*after.mean_point_deviation, *before.mean_point_deviation / 5) << held_out;
      EXPECT_LT(*after.max_point_distance_error, *before.max_point_distance_error) << held_out;
      sum[keep_all] += *after.mean_point_deviation;
    }
  }
  std::printf("mean over the held-out placements: %.3f mm (default), %.3f mm (--keep-all)\n",
              sum[0] / 3 * 1e3, sum[1] / 3 * 1e3);
  EXPECT_LT(sum[1] / 3, 0.85e-3);  // the reference fit: 0.78 mm
  EXPECT_LT(sum[0] / 3, 1.0e-3);
}

// Simulated sockets (the real data's configurations moved onto the perturbed
// truth's common points) and plates: noise-free, so a calibration must fit them
// exactly and predict a placement it has not seen to a micrometre.
TEST(Fixture, SimulatedSocketsAndPlanesAreFittedExactly) {
  const DeviceModel nominal = panda();
  std::mt19937_64 rng(21);
  const DeviceModel truth = testing::perturbed(nominal, rng, 1e-3);
  const PreparedModel actual(truth);
  for (const bool planes : {false, true}) {
    SCOPED_TRACE(planes ? "planes" : "points");
    std::string train_csv =
        std::string("q1,q2,q3,q4,q5,q6,q7,") + (planes ? "plane" : "point") + "\n";
    std::string test_csv = train_csv;
    std::vector<PointDistance> train_known, test_known;
    for (const char* placement : kPlacements) {
      const Log real = mukca_log({placement});
      Eigen::Vector3d target[2];
      for (int r = 0; r < real.rows; ++r) {
        const int socket = real.label[r].back() - '0';
        Eigen::VectorXd q = real.q.row(r).transpose();
        if (r == 0 || real.label[r] != real.label[r - 1])
          target[socket] = actual.forward(q.data()).p;
        const Eigen::Vector3d normal = Eigen::Vector3d(0.2, -0.3 * socket, 1).normalized();
        q = reach(actual, q,
                  planes ? ToolTarget::on_plane(normal, normal.dot(target[socket]))
                         : ToolTarget::at(target[socket]),
                  {.max_steps = 50, .damping = 1e-12, .tolerance = 1e-13})
                .q;
        if (planes) {  // spread the contacts over the plate
          ASSERT_LT(std::abs(normal.dot(actual.forward(q.data()).p - target[socket])), 1e-12);
        } else {
          ASSERT_LT((actual.forward(q.data()).p - target[socket]).norm(), 1e-12);
        }
        std::string row;
        for (int j = 0; j < 7; ++j) row += fmt::format("{},", q[j]);
        (std::string(placement) == "front" ? test_csv : train_csv) += row + real.label[r] + "\n";
      }
      if (planes) continue;
      const PointDistance d{std::string(placement) + "_0", std::string(placement) + "_1",
                            (target[0] - target[1]).norm()};
      (std::string(placement) == "front" ? test_known : train_known).push_back(d);
    }
    CalibrationOptions options;
    options.point_distances = train_known;
    options.keep_all = true;
    options.search = false;  // one model
    const CalibrationResult r = calibrate(nominal, parse_log(train_csv, "train"), options);
    std::printf("%s: %s; RMS %.4g -> %.4g mm\n", planes ? "planes" : "points",
                r.status_reason.c_str(), r.kinematics.rms_before * 1e3,
                r.kinematics.rms_after * 1e3);
    ASSERT_EQ(r.status, CalibrationStatus::kConverged) << r.status_reason;
    EXPECT_LT(r.kinematics.rms_after, 1e-9);
    const Log test = parse_log(test_csv, "test");
    const Evaluation before = evaluate(nominal, test, test_known);
    const Evaluation after = evaluate(r.calibrated, test, test_known);
    if (planes) {
      std::printf("planes: held-out RMS plane distance %.4f -> %.6f mm (%d parameters)\n",
                  *before.rms_plane_distance * 1e3, *after.rms_plane_distance * 1e3,
                  r.kinematics.identified);
      EXPECT_LT(*after.rms_plane_distance, 1e-9);
      EXPECT_GT(*before.rms_plane_distance, 1e-4);
    } else {
      std::printf(
          "points: held-out mean point deviation %.4f -> %.6f mm, distance error %.6f mm "
          "(%d parameters)\n",
          *before.mean_point_deviation * 1e3, *after.mean_point_deviation * 1e3,
          *after.max_point_distance_error * 1e3, r.kinematics.identified);
      EXPECT_LT(*after.mean_point_deviation, 1e-6);
      EXPECT_LT(*after.max_point_distance_error, 1e-6);
      EXPECT_GT(*before.mean_point_deviation, 1e-4);
    }
  }
}

}  // namespace
}  // namespace hapticcal
namespace hapticcal {
namespace {

// A two-socket calibration (15 configurations a socket, placement error
// `sigma` per axis) of `nominal` with a truth 1 mm / 1 mrad off in every
// parameter two sockets identify, over `trials` trials: per parameter the RMSE
// and the Cramer-Rao sd (sigma^2 (J^T J)^-1 of the projected rows at the truth,
// each trial's readings, averaged). With `known` the fixture's 50 mm is given
// (exactly: its row is the constrained least squares').
struct Efficiency {
  std::vector<std::string> names;
  Eigen::VectorXd rmse, crlb_sd;
  int not_converged = 0;
};
Efficiency two_socket_study(const DeviceModel& nominal, bool known, int trials, double sigma,
                            int per_socket = 15) {
  const auto sockets = default_sockets(nominal);
  CalibrationOptions options;
  options.keep_all = true;
  options.search = false;  // one model
  options.folds = 0;
  if (known) options.point_distances = {{"a", "b", 0.05}};
  // What two sockets identify: the rank test on exact data of the nominal device.
  const CalibrationResult exact =
      calibrate(nominal, simulate_fixture_log(nominal, sockets, per_socket, 0, 7), options);
  EXPECT_EQ(exact.status, CalibrationStatus::kConverged) << exact.status_reason;
  std::vector<int> slots;
  Efficiency out;
  for (const ParameterEstimate& e : exact.kinematics.parameters) {
    if (!e.identifiable) continue;
    slots.push_back(e.slot);
    out.names.push_back(e.name);
  }
  DeviceModel truth = nominal;
  Eigen::VectorXd p = truth.kinematic_parameters();
  std::mt19937_64 rng(5);
  std::normal_distribution<double> deviation(0.0, 1e-3), gauss(0.0, 1.0);
  for (int slot : slots) p[slot] += deviation(rng);
  truth.set_kinematic_parameters(p);
  const int k = static_cast<int>(slots.size());
  Eigen::VectorXd squared = Eigen::VectorXd::Zero(k), variance = Eigen::VectorXd::Zero(k);
  int used = 0;
  for (int t = 0; t < trials; ++t) {
    const Log log = simulate_fixture_log(truth, sockets, per_socket, sigma, 1000 + t);
    CalibrationOptions o = options;

    const CalibrationResult r = calibrate(nominal, log, o);
    if (r.status != CalibrationStatus::kConverged) {
      ++out.not_converged;
      continue;
    }
    EXPECT_EQ(r.kinematics.identified, k);
    const Eigen::VectorXd estimate = r.calibrated.kinematic_parameters();
    const KinematicProblem problem = kinematic_problem(truth, log, {}, o);
    const detail::Stack at =
        detail::stack(truth.structure(), p, problem.joints, detail::rows_of(problem),
                      problem.measured, problem.weights);
    Eigen::MatrixXd J(at.J.rows(), k);
    for (int c = 0; c < k; ++c) J.col(c) = at.J.col(slots[c]);
    const Eigen::MatrixXd covariance = sigma * sigma * (J.transpose() * J).inverse();
    for (int c = 0; c < k; ++c) {
      squared[c] += std::pow(estimate[slots[c]] - p[slots[c]], 2);
      variance[c] += covariance(c, c);
    }
    ++used;
  }
  out.rmse = (squared / used).cwiseSqrt();
  out.crlb_sd = (variance / used).cwiseSqrt();
  return out;
}

// Issue 13: a two-socket calibration of the PHANToM is efficient: over 200
// trials every identifiable parameter's RMSE is its Cramer-Rao bound within
// 10 % (the sockets' places unknown, their distance not given: the projected
// least squares is then exactly maximum likelihood).
TEST(Fixture, TwoSocketCalibrationOfThePhantomIsEfficient) {
  const Efficiency e = two_socket_study(testing::builtin("phantom-premium-1.5"), false, 200, 1e-4);
  EXPECT_EQ(e.not_converged, 0);
  for (size_t c = 0; c < e.names.size(); ++c) {
    const double ratio = e.rmse[c] / e.crlb_sd[c];
    std::printf("PHANToM %-10s RMSE %.4f mm, CRLB %.4f mm: %.3f\n", e.names[c].c_str(),
                e.rmse[c] * 1e3, e.crlb_sd[c] * 1e3, ratio);
    EXPECT_GT(ratio, 0.9) << e.names[c];
    EXPECT_LT(ratio, 1.1) << e.names[c];
  }
}

// Issue 13: a two-socket calibration of the Panda is efficient too, given the
// fixture's 50 mm (as MUKCa's fixture gives it) and 30 configurations a socket
// (as MUKCa recorded): every one of its 25 identifiable parameters has an RMSE
// within 10 % of its Cramer-Rao bound over 200 trials. With 15 a socket the
// flange's rotations (the ball 0.09 mm off joint 7's axis, bounds of 0.2 rad)
// leave the linear regime: up to 3.0.
TEST(Fixture, TwoSocketCalibrationOfThePandaWithTheKnownDistanceIsEfficient) {
  const Efficiency e = two_socket_study(panda(), true, 200, 1e-4, 30);
  EXPECT_EQ(e.not_converged, 0);
  EXPECT_EQ(e.names.size(), 25u);
  for (size_t c = 0; c < e.names.size(); ++c) {
    const double ratio = e.rmse[c] / e.crlb_sd[c];
    std::printf("Panda %-18s RMSE %.4f, CRLB %.4f (m or rad): %.3f\n", e.names[c].c_str(),
                e.rmse[c], e.crlb_sd[c], ratio);
    EXPECT_GT(ratio, 0.9) << e.names[c];
    EXPECT_LT(ratio, 1.1) << e.names[c];
  }
}

// With the fixture's 50 mm given, the PHANToM recovers the assigned deviations
// (RMSE within 3 Cramer-Rao sd of the truth; 0.85-1.06 in 30 trials: j1.a, seen
// only through the 50 mm, has a bound of 3.7 mm, beyond the linear regime of a
// 1 mm deviation, so 0.9-1.1 is not expected of it).
TEST(Fixture, TwoSocketCalibrationWithTheKnownDistanceRecoversTheDeviations) {
  const Efficiency e = two_socket_study(testing::builtin("phantom-premium-1.5"), true, 30, 1e-4);
  EXPECT_EQ(e.not_converged, 0);
  const double worst = (e.rmse.array() / e.crlb_sd.array()).maxCoeff();
  std::printf("PHANToM (50 mm given): %zu parameters, RMSE / CRLB %.3f .. %.3f over 30 trials\n",
              e.names.size(), (e.rmse.array() / e.crlb_sd.array()).minCoeff(), worst);
  EXPECT_LT(worst, 3.0);
}

// Without a known distance the fixture cannot see the robot's size: on the real
// Panda data a length that carries the scale is held, with that reason, and the
// other lengths are well determined (the greedy rank test used to hold the
// ball's 0.025 mm x offset, which carries the scale only faintly: link lengths then
// had standard deviations of 1.5-1.8 mm; now 0.04-0.22 mm).
TEST(Fixture, WithoutAKnownDistanceTheRobotsSizeIsNamed) {
  CalibrationOptions options;
  options.keep_all = true;
  options.search = false;  // one model
  options.folds = 0;
  const DeviceModel nominal = panda();
  const CalibrationResult r =
      calibrate(nominal, mukca_log({"back-high", "front", "right"}), options);
  EXPECT_EQ(r.status, CalibrationStatus::kConverged) << r.status_reason;
  int sized = 0;
  for (const ParameterEstimate& e : r.kinematics.parameters) {
    const bool length = e.unit == ParameterUnit::kLength;
    if (!e.identifiable && e.reason.find("a uniform scale of the robot") != std::string::npos) {
      ++sized;
      EXPECT_TRUE(length) << e.name;
      EXPECT_GT(std::abs(e.nominal), 0.1) << e.name << " carries the scale faintly";
    }
    // The arm's links (the flange's geometry, with the ball 0.09 mm off joint
    // 7's axis, is weakly seen by any fixture: 2-3 cm).
    const bool arm = e.name < "panda_joint6";
    if (e.identifiable && length && arm) {
      EXPECT_LT(e.sd, 1e-3) << e.name;
    }
  }
  EXPECT_EQ(sized, 1);
}

}  // namespace
}  // namespace hapticcal
namespace hapticcal {
namespace {

// Issue 13's haptic study: the built-in PHANToM calibrated with a simulated
// two-socket fixture and nothing else (data/scenarios/phantom-two-socket.yaml),
// calibrated as an owner would (calibrate's default, model selection): the
// tool point over 200 validation poses gets three times closer to the truth.
TEST(Fixture, HapticStudyCalibratesThePhantomWithTwoSockets) {
  const std::string out = ::testing::TempDir() + "/hapticcal_haptic_study";
  std::filesystem::remove_all(out);
  const testing::CliResult r = testing::run_cli(
      {"simulate", "--scenario", testing::source_path("data/scenarios/phantom-two-socket.yaml"),
       "--trials", "3", "--out", out});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(testing::slurp(out + "/results.json"));
  EXPECT_EQ(j["measurement"], "point");
  const double before = j["validation"]["position_rms_before"];
  const double after = j["validation"]["position_rms_after"];
  std::printf("PHANToM, two sockets: validation position RMS %.3f -> %.3f mm\n", before * 1e3,
              after * 1e3);
  EXPECT_LT(after, before / 3);  // model selection holds j1.a, which two sockets barely see
  std::filesystem::remove_all(out);
}

// The scenario keys of fixture simulations: each refusal names its key.
TEST(Fixture, ScenarioKeysOfSocketsAreChecked) {
  const std::string dir = ::testing::TempDir() + "/hapticcal_socket_keys";
  std::filesystem::create_directories(dir);
  const std::string device = testing::source_path("data/devices/phantom-premium-1.5.yaml");
  const std::pair<std::string, std::string> cases[] = {
      {"measurement: distance\nsockets: {a: [0, 0, 0], b: [0.05, 0, 0]}\n",
       "sockets: sockets are for measurement: point"},
      {"measurement: point\nsockets: {a: [0, 0, 0]}\n", "sockets: expected a map of 2 to 20"},
      {"measurement: point\nsockets: {a: [0, 0], b: [0, 0, 1]}\n",
       "sockets.a: expected [X, Y, Z] in metres"},
      {"measurement: point\nsockets: {a: [0, 0, 1e9], b: [0, 0, 1]}\n", "sockets.a: 1000000000 m"},
      {"measurement: point\nsocket_distances: maybe\n",
       "socket_distances: expected known or unknown"},
      {"measurement: point\nsockets: {a: [5, 5, 5], b: [5, 5, 5.05]}\n",
       "socket 'a' cannot be reached"},
  };
  int k = 0;
  for (const auto& [body, expected] : cases) {
    const std::string path = dir + "/s" + std::to_string(k++) + ".yaml";
    std::ofstream(path) << "format: hapticcal-scenario/1\ndevice: " << device << "\n" << body;
    const testing::CliResult r =
        testing::run_cli({"simulate", "--scenario", path, "--out", dir + "/out"});
    EXPECT_EQ(r.exit_code, 2) << body;
    EXPECT_NE(r.err.find(expected), std::string::npos) << body << " -> " << r.err;
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace hapticcal
namespace hapticcal {
namespace {

// simulate measures fixture points on every kind of chain: the PHANToM (DH
// with capstans), the Meca500 (MDH) and the Panda (URDF), default sockets.
TEST(Fixture, SimulateMeasuresSocketsOnEveryKindOfChain) {
  const std::string dir = ::testing::TempDir() + "/hapticcal_sockets_devices";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::pair<std::string, std::string> devices[] = {
      {testing::source_path("data/devices/phantom-premium-1.5.yaml"), ""},
      {testing::source_path("examples/meca500/meca500.yaml"), ""},
      {testing::real_data_path("mukca/panda.urdf"), "tip: ball_link\n"}};
  int k = 0;
  for (const auto& [device, chain] : devices) {
    SCOPED_TRACE(device);
    const std::string path = dir + "/s" + std::to_string(k) + ".yaml";
    std::ofstream(path) << "format: hapticcal-scenario/1\ndevice: " << device << "\n"
                        << chain << "measurement: point\nposes: {identification: 60}\n";
    const std::string out = dir + "/out" + std::to_string(k++);
    const testing::CliResult r = testing::run_cli({"simulate", "--scenario", path, "--out", out});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto j = nlohmann::json::parse(testing::slurp(out + "/results.json"));
    const double before = j["validation"]["position_rms_before"];
    const double after = j["validation"]["position_rms_after"];
    std::printf("%s: validation position RMS %.3f -> %.3f mm\n",
                j["device"].get<std::string>().c_str(), before * 1e3, after * 1e3);
    EXPECT_LT(after, before);
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace hapticcal
namespace hapticcal {
namespace {

// simulate measures plane contacts on every kind of chain (issue 13): the
// PHANToM (DH with capstans), the Meca500 (MDH) and the Panda (URDF), default
// plates. Planes cannot see the robot's size: the study holds what they cannot
// identify, reports assigned and identified deviations of what they can, and
// the calibrated model predicts the validation tool points better than nominal.
TEST(Fixture, SimulateMeasuresPlanesOnEveryKindOfChain) {
  const std::string dir = ::testing::TempDir() + "/hapticcal_planes_devices";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  // The Panda's plane calibration is ill-conditioned: at the default contact
  // error (10 um) it ends farther from the truth than nominal (printed, not
  // checked: see docs/fixtures.md); at 1 nm it recovers the truth.
  struct Run {
    std::string device, chain, noise;
    bool improves;
  };
  const Run runs[] = {{testing::source_path("data/devices/phantom-premium-1.5.yaml"), "", "", true},
                      {testing::source_path("examples/meca500/meca500.yaml"), "", "", true},
                      {testing::real_data_path("mukca/panda.urdf"), "tip: ball_link\n", "", false},
                      {testing::real_data_path("mukca/panda.urdf"), "tip: ball_link\n",
                       "noise: {sigma_m: 1.0e-9}\n", true}};
  int k = 0;
  for (const auto& [device, chain, noise, improves] : runs) {
    SCOPED_TRACE(device + " " + noise);
    const std::string path = dir + "/s" + std::to_string(k) + ".yaml";
    std::ofstream(path) << "format: hapticcal-scenario/1\ndevice: " << device << "\n"
                        << chain << noise
                        << "measurement: plane\nposes: {identification: 150, validation: 100}\n"
                           "trajectory: {seconds: 2, rate_hz: 100}\n";
    const std::string out = dir + "/out" + std::to_string(k++);
    const testing::CliResult r = testing::run_cli({"simulate", "--scenario", path, "--out", out});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto j = nlohmann::json::parse(testing::slurp(out + "/results.json"));
    EXPECT_EQ(j["measurement"], "plane");
    const Log ident = read_log(out + "/identification.csv");
    EXPECT_TRUE(ident.has_plane);
    EXPECT_EQ(ident.rows, 150);
    const double before = j["validation"]["position_rms_before"];
    const double after = j["validation"]["position_rms_after"];
    int deviating = 0;
    double worst = 0;
    for (const auto& [name, p] : j["parameters"].items()) {
      ASSERT_TRUE(p.contains("assigned_deviation") && p.contains("identified_deviation")) << name;
      if (p["assigned_deviation"].get<double>() == 0) continue;
      ++deviating;
      worst = std::max(worst, std::abs(p["identified_deviation"].get<double>() -
                                       p["assigned_deviation"].get<double>()));
    }
    std::printf(
        "%s%s, 3 plates: %zu parameters reported (%d deviating, largest error %.4f mm or mrad), "
        "%zu held; validation position RMS %.4f -> %.4f mm\n",
        j["device"].get<std::string>().c_str(), noise.empty() ? "" : " (contact sd 1 nm)",
        j["parameters"].size(), deviating, worst * 1e3, j["held"].size(), before * 1e3,
        after * 1e3);
    EXPECT_GT(deviating, 0);
    EXPECT_FALSE(j["held"].empty());  // the base pose at least
    if (improves) {
      EXPECT_LT(after, before / 10);
    }
  }
  std::filesystem::remove_all(dir);
}

// Noise-free plane contacts simulated by simulate_plane_log on a truth 1 mm /
// 1 mrad off in what three plates identify: they are fitted exactly and a
// fourth plate, held out, is predicted to 1e-9 m.
TEST(Fixture, SimulatedPlaneContactsAreFittedExactly) {
  for (const DeviceModel& nominal : {testing::builtin("phantom-premium-1.5"), panda()}) {
    SCOPED_TRACE(nominal.name);
    std::vector<SimulatedPlane> plates = default_planes(nominal);
    CalibrationOptions options;
    options.keep_all = true;
    options.search = false;  // one model
    // What three plates identify (the rank test on exact data of the nominal
    // device) deviates 1 mm / 1 mrad.
    const CalibrationResult exact =
        calibrate(nominal, simulate_plane_log(nominal, plates, 30, 0, 2), options);
    DeviceModel truth = nominal;
    Eigen::VectorXd p = truth.kinematic_parameters();
    std::mt19937_64 rng(8);
    std::normal_distribution<double> deviation(0.0, 1e-3);
    for (const ParameterEstimate& e : exact.kinematics.parameters) {
      if (e.identifiable) p[e.slot] += deviation(rng);
    }
    truth.set_kinematic_parameters(p);
    ASSERT_EQ(plates.size(), 3u);
    for (size_t a = 0; a < plates.size(); ++a) {
      for (size_t b = a + 1; b < plates.size(); ++b)
        EXPECT_LT(std::abs(plates[a].normal.dot(plates[b].normal)), 0.9);  // not parallel
    }
    const Eigen::Vector3d tilted = Eigen::Vector3d(1, 1, 1).normalized();
    const std::vector<SimulatedPlane> held_out = {{"held-out", plates[0].point, tilted}};
    const Log train = simulate_plane_log(truth, plates, 30, 0, 3);
    const Log test = simulate_plane_log(truth, held_out, 30, 0, 4);
    for (int r = 0; r < train.rows; ++r) {
      const SimulatedPlane& plate = plates[r / 30];
      const Eigen::VectorXd q = train.q.row(r).transpose();
      ASSERT_LT(std::abs(plate.normal.dot(PreparedModel(truth).forward(q.data()).p - plate.point)),
                1e-9);
      ASSERT_EQ(train.label[r], plate.name);
    }
    const CalibrationResult r = calibrate(nominal, train, options);
    ASSERT_EQ(r.status, CalibrationStatus::kConverged) << r.status_reason;
    EXPECT_LT(r.kinematics.rms_after, 1e-9);
    const Evaluation before = evaluate(nominal, test), after = evaluate(r.calibrated, test);
    std::printf("%s: 3 plates, %d parameters; held-out plate RMS distance %.4f mm -> %.3g m\n",
                nominal.name.c_str(), r.kinematics.identified, *before.rms_plane_distance * 1e3,
                *after.rms_plane_distance);
    EXPECT_LT(*after.rms_plane_distance, 1e-9);
    EXPECT_GT(*before.rms_plane_distance, 1e-5);
  }
}

// A plane simulate cannot reach is refused with its name (exit 2).
TEST(Fixture, UnreachablePlaneIsRefused) {
  const std::string dir = ::testing::TempDir() + "/hapticcal_plane_unreachable";
  std::filesystem::create_directories(dir);
  const std::string path = dir + "/s.yaml";
  std::ofstream(path) << "format: hapticcal-scenario/1\ndevice: "
                      << testing::source_path("data/devices/phantom-premium-1.5.yaml")
                      << "\nmeasurement: plane\nplanes: {far: {point: [0, 0, 50], normal: [0, 0, "
                         "1]}}\nposes: {identification: 8}\n";
  const testing::CliResult r =
      testing::run_cli({"simulate", "--scenario", path, "--out", dir + "/out"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("plane 'far' cannot be reached"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir + "/out"));
  std::filesystem::remove_all(dir);
}

// The README's fixture walk-through (two placements, the sockets' distance
// known): neither the terminal's identified table nor the report's lists a
// parameter whose sd is above its tolerance (ISO 2768-m: 0.5 mm, 5 mrad) or
// that is correlated beyond 0.99 with another; those are listed apart.
TEST(Fixture, WhatTheDataCannotSeeIsNotCalledIdentified) {
  const std::string dir = testing::fresh_folder("fixture_undetermined");
  std::ofstream(dir + "/train.csv") << testing::mukca_csv({"front", "right"});
  const testing::CliResult r = testing::run_cli(
      {"calibrate", "--model", testing::real_data_path("mukca/panda.urdf"), "--tip", "ball_link",
       "--log", dir + "/train.csv", "--out", dir + "/cal", "--point-distance",
       "front_0:front_1=0.05", "--point-distance", "right_0:right_1=0.05"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(testing::slurp(dir + "/cal/results.json"));
  // The terminal's identified table: the lines between its header and the next heading.
  const std::size_t header = r.out.find("  parameter ");
  ASSERT_NE(header, std::string::npos) << r.out;
  const std::size_t table = r.out.find('\n', header) + 1;
  const std::size_t apart = r.out.find("  not determined by these data", table);
  ASSERT_NE(apart, std::string::npos) << r.out;
  const std::string identified = r.out.substr(table, apart - table);
  const std::string html = testing::slurp(dir + "/cal/report.html");
  const std::size_t report_identified = html.find("<h2>Identified kinematic parameters</h2>");
  const std::size_t report_apart = html.find("<h2>Fitted, not determined by these data</h2>");
  ASSERT_NE(report_identified, std::string::npos);
  ASSERT_NE(report_apart, std::string::npos);
  const std::string report_table = html.substr(report_identified, report_apart - report_identified);
  int undetermined = 0, shown = 0;
  for (const auto& [name, p] : j["parameters"].items()) {
    if (!p["identifiable"].get<bool>() || name.rfind("base.", 0) == 0) continue;
    const bool angle = name.find(".roll") != std::string::npos ||
                       name.find(".pitch") != std::string::npos ||
                       name.find(".yaw") != std::string::npos;
    const double tolerance = angle ? 5e-3 : 0.5e-3;
    const bool seen =
        p["sd"].get<double>() <= tolerance && std::abs(p["max_correlation"].get<double>()) <= 0.99;
    SCOPED_TRACE(name);
    EXPECT_EQ(p["determined"].get<bool>(), seen);
    const std::string cell = "<tr><td>" + name + "</td>";  // a row of its own
    EXPECT_EQ(identified.find("  " + name + " ") != std::string::npos, seen) << identified;
    EXPECT_EQ(report_table.find(cell) != std::string::npos, seen);
    undetermined += !seen;
    shown += seen;
  }
  std::printf("MUKCa front + right: %d identified, %d fitted but not determined\n", shown,
              undetermined);
  EXPECT_GE(undetermined, 2);  // panda_joint6.pitch and panda_joint7.y at least (0.996)
  EXPECT_NE(r.out.find(fmt::format("{} parameters identified ({} more fitted, not determined)",
                                   shown, undetermined)),
            std::string::npos)
      << r.out;
  // The notes say which evidence judged the model: no held-out error here.
  EXPECT_EQ(r.out.find("the held-out error judged the model"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace hapticcal
