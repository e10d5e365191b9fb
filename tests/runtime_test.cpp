// The C runtime (include/hapticcal/runtime.h) against the library's generic
// kinematics, orocos KDL and numerical derivatives; its error paths; and
// concurrent readers of one model.
#include "hapticcal/runtime.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainjnttojacsolver.hpp>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/model_io/urdf.hpp"
#include "hapticcal/study/paper.hpp"
#include "kdl_chain.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

struct ModelDeleter {
  void operator()(hapticcal_model* m) const { hapticcal_free(m); }
};
using RuntimeModel = std::unique_ptr<hapticcal_model, ModelDeleter>;

RuntimeModel load(const std::string& path, const char* tip = nullptr) {
  hapticcal_model* m = nullptr;
  char message[512];
  const hapticcal_status status =
      hapticcal_load(path.c_str(), tip, nullptr, &m, message, sizeof message);
  EXPECT_EQ(status, HAPTICCAL_OK) << message;
  EXPECT_STREQ(message, "");
  return RuntimeModel(m);
}

// `model` as a device file in the test's scratch folder, loaded by the runtime.
RuntimeModel load_saved(const DeviceModel& model, const std::string& name) {
  const std::string path =
      ::testing::TempDir() + "/runtime_test_" + std::to_string(::getpid()) + "_" + name + ".yaml";
  save_device(model, path);
  RuntimeModel m = load(path);
  std::filesystem::remove(path);
  return m;
}

// The paper's actual device: capstans on joints 1-4, joint 4 a capstan then a
// parallelogram (a Chain), Table 3 deviations.
DeviceModel paper_device() { return paper_actual_device(testing::builtin("baser-7dof")); }

Frame<double> pose_of(const double* T) {
  Frame<double> f;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) f.R(r, c) = T[4 * r + c];
    f.p[r] = T[4 * r + 3];
  }
  return f;
}

// forward and jacobian (both frames) against the generic templated kinematics
// (forward_kinematics + geometric_jacobian on the compensated readings), against
// PreparedModel, and against KDL, on `samples` random readings within the limits.
void expect_agrees_with_library(const DeviceModel& model, const hapticcal_model* runtime,
                                int samples) {
  ASSERT_EQ(hapticcal_dof(runtime), model.dof());
  const int n = model.dof();
  const ChainStructure s = model.structure();
  const Eigen::VectorXd params = model.kinematic_parameters();
  const PreparedModel prepared(model);
  const KDL::Chain chain = testing::kdl_chain(model);
  KDL::ChainFkSolverPos_recursive kdl_fk(chain);
  KDL::ChainJntToJacSolver kdl_jacobian(chain);
  std::mt19937_64 rng(7);
  std::vector<double> J(6 * n), J_tool(6 * n), joint(n);
  double T[16], T_jac[16];
  Jacobian6<double> J_lib(6, n), J_lib_tool(6, n), J_prep(6, n);
  for (int k = 0; k < samples; ++k) {
    SCOPED_TRACE(k);
    const Eigen::VectorXd q = testing::random_readings(model, rng);
    ASSERT_EQ(hapticcal_compensate(runtime, q.data(), joint.data()), HAPTICCAL_OK);
    ASSERT_EQ(hapticcal_forward(runtime, q.data(), T), HAPTICCAL_OK);
    ASSERT_EQ(hapticcal_jacobian(runtime, q.data(), HAPTICCAL_FRAME_MEASUREMENT, J.data(), T_jac),
              HAPTICCAL_OK);
    ASSERT_EQ(hapticcal_jacobian(runtime, q.data(), HAPTICCAL_FRAME_TOOL, J_tool.data(), nullptr),
              HAPTICCAL_OK);
    EXPECT_EQ(T[12], 0.0);
    EXPECT_EQ(T[13], 0.0);
    EXPECT_EQ(T[14], 0.0);
    EXPECT_EQ(T[15], 1.0);

    const Eigen::VectorXd theta = model.compensate(q);
    EXPECT_LE((Eigen::Map<const Eigen::VectorXd>(joint.data(), n) - theta).cwiseAbs().maxCoeff(),
              1e-12);
    std::array<Frame<double>, kMaxDof + 1> frames;
    const Frame<double> T_lib = forward_kinematics(s, params.data(), theta.data(), frames.data());
    geometric_jacobian(s, frames.data(), T_lib, JacobianFrame::kMeasurement, J_lib);
    geometric_jacobian(s, frames.data(), T_lib, JacobianFrame::kTool, J_lib_tool);
    const Frame<double> T_run = pose_of(T), T_run_jac = pose_of(T_jac);
    const Eigen::Map<const Jacobian6<double>> J_run(J.data(), 6, n),
        J_run_tool(J_tool.data(), 6, n);
    EXPECT_LE((T_run.R - T_lib.R).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LE((T_run.p - T_lib.p).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LE((T_run_jac.R - T_lib.R).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LE((T_run_jac.p - T_lib.p).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LE((J_run - J_lib).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LE((J_run_tool - J_lib_tool).cwiseAbs().maxCoeff(), 1e-12);

    // The fast path the runtime wraps, to the last bit.
    const Frame<double> T_prep =
        prepared.forward_jacobian(q.data(), JacobianFrame::kMeasurement, J_prep);
    EXPECT_EQ((T_run_jac.p - T_prep.p).cwiseAbs().maxCoeff(), 0.0);
    EXPECT_EQ((J_run - J_prep).cwiseAbs().maxCoeff(), 0.0);

    // KDL (an independent implementation) on the compensated values.
    const testing::KdlSolution kdl = testing::kdl_solve(kdl_fk, kdl_jacobian, theta);
    EXPECT_LE((T_run.R - kdl.T.R).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LE((T_run.p - kdl.T.p).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LE((J_run - kdl.J).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LE((J_run_tool - kdl.J_tool).cwiseAbs().maxCoeff(), 1e-12);
    if (::testing::Test::HasFailure()) return;
  }
}

TEST(Runtime, ForwardAndJacobianMatchTheLibraryAndKdlOnBuiltinDevices) {
  for (const char* name : {"baser-7dof", "phantom-premium-1.5"}) {
    SCOPED_TRACE(name);
    const RuntimeModel runtime =
        load(testing::source_path(std::string("data/devices/") + name + ".yaml"));
    ASSERT_TRUE(runtime);
    expect_agrees_with_library(testing::builtin(name), runtime.get(), 1000);
  }
}

TEST(Runtime, ForwardAndJacobianMatchTheLibraryAndKdlOnCalibratedModels) {
  // Eccentric capstans, a capstan + parallelogram chain, perturbed geometry.
  const DeviceModel paper = paper_device();
  const RuntimeModel runtime = load_saved(paper, "paper");
  ASSERT_TRUE(runtime);
  expect_agrees_with_library(paper, runtime.get(), 1000);
  std::mt19937_64 rng(3);
  const DeviceModel perturbed = testing::perturbed(testing::builtin("phantom-premium-1.5"), rng);
  const RuntimeModel runtime2 = load_saved(perturbed, "phantom_perturbed");
  ASSERT_TRUE(runtime2);
  expect_agrees_with_library(perturbed, runtime2.get(), 1000);
}

TEST(Runtime, ForwardAndJacobianMatchTheLibraryAndKdlOnThePandaUrdf) {
  const std::string path = testing::real_data_path("mukca/panda.urdf");
  ASSERT_TRUE(std::filesystem::exists(path)) << "missing from the repository: " << path;
  const RuntimeModel runtime = load(path, "ball_link");
  ASSERT_TRUE(runtime);
  expect_agrees_with_library(load_urdf(path, "ball_link"), runtime.get(), 1000);
}

// The small rotation w with R_plus = exp([w]) R_minus, from the skew part.
Eigen::Vector3d rotation_between(const Eigen::Matrix3d& R_minus, const Eigen::Matrix3d& R_plus) {
  const Eigen::Matrix3d D = R_plus * R_minus.transpose();
  const Eigen::AngleAxisd aa(D);
  return aa.angle() * aa.axis();
}

// tau_r . dr = F . dx: each reading moved by +-h, the tool's displacement and
// rotation by central differences, F's virtual work against tau_r[i] h.
void expect_virtual_work(const DeviceModel& model, const hapticcal_model* runtime) {
  const int n = model.dof();
  std::mt19937_64 rng(11);
  std::normal_distribution<double> normal;
  std::vector<double> tau(n), tau_tool(n);
  const double h = 1e-6;
  for (int k = 0; k < 200; ++k) {
    SCOPED_TRACE(k);
    Eigen::VectorXd q = testing::random_readings(model, rng);
    Eigen::Matrix<double, 6, 1> F, F_tool;
    for (int j = 0; j < 6; ++j) {
      F[j] = 10 * normal(rng);
      F_tool[j] = 10 * normal(rng);
    }
    ASSERT_EQ(hapticcal_joint_torques(runtime, q.data(), F.data(), HAPTICCAL_FRAME_MEASUREMENT,
                                      tau.data()),
              HAPTICCAL_OK);
    ASSERT_EQ(hapticcal_joint_torques(runtime, q.data(), F_tool.data(), HAPTICCAL_FRAME_TOOL,
                                      tau_tool.data()),
              HAPTICCAL_OK);
    double T[16];
    ASSERT_EQ(hapticcal_forward(runtime, q.data(), T), HAPTICCAL_OK);
    const Eigen::Matrix3d R = pose_of(T).R;
    for (int i = 0; i < n; ++i) {
      Eigen::VectorXd plus = q, minus = q;
      plus[i] += h;
      minus[i] -= h;
      double Tp[16], Tm[16];
      ASSERT_EQ(hapticcal_forward(runtime, plus.data(), Tp), HAPTICCAL_OK);
      ASSERT_EQ(hapticcal_forward(runtime, minus.data(), Tm), HAPTICCAL_OK);
      const Frame<double> fp = pose_of(Tp), fm = pose_of(Tm);
      const Eigen::Vector3d dp = (fp.p - fm.p) / (2 * h);
      const Eigen::Vector3d dw = rotation_between(fm.R, fp.R) / (2 * h);
      const double work = F.head<3>().dot(dp) + F.tail<3>().dot(dw);
      const double work_tool =
          F_tool.head<3>().dot(R.transpose() * dp) + F_tool.tail<3>().dot(R.transpose() * dw);
      EXPECT_NEAR(tau[i], work, 1e-6 * (1 + std::abs(work))) << "joint " << i;
      EXPECT_NEAR(tau_tool[i], work_tool, 1e-6 * (1 + std::abs(work_tool))) << "joint " << i;
    }
    if (::testing::Test::HasFailure()) return;
  }
}

TEST(Runtime, JointTorquesDoTheVirtualWorkOfTheWrenchWithCapstansAndParallelogram) {
  const DeviceModel paper = paper_device();
  const RuntimeModel runtime = load_saved(paper, "paper_torques");
  ASSERT_TRUE(runtime);
  expect_virtual_work(paper, runtime.get());
}

TEST(Runtime, JointTorquesDoTheVirtualWorkOnAMixedChainWithPrismaticJoints) {
  const DeviceModel mixed = testing::mixed_chain(BaseKind::kDh);
  const RuntimeModel runtime = load_saved(mixed, "mixed_torques");
  ASSERT_TRUE(runtime);
  expect_virtual_work(mixed, runtime.get());
}

// Without the transmission derivative the torques would be J^T F: on the
// paper's device they differ by more than the check's tolerance, so the test
// above protects the (d theta / d r)^T factor.
TEST(Runtime, TransmissionDerivativeChangesTheTorques) {
  const DeviceModel paper = paper_device();
  const RuntimeModel runtime = load_saved(paper, "paper_jtf");
  ASSERT_TRUE(runtime);
  const int n = paper.dof();
  std::mt19937_64 rng(5);
  const Eigen::VectorXd q = testing::random_readings(paper, rng);
  const double F[6] = {3, -4, 5, 0.2, 0.1, -0.3};
  std::vector<double> tau(n), J(6 * n);
  ASSERT_EQ(
      hapticcal_joint_torques(runtime.get(), q.data(), F, HAPTICCAL_FRAME_MEASUREMENT, tau.data()),
      HAPTICCAL_OK);
  ASSERT_EQ(
      hapticcal_jacobian(runtime.get(), q.data(), HAPTICCAL_FRAME_MEASUREMENT, J.data(), nullptr),
      HAPTICCAL_OK);
  double largest = 0;
  for (int i = 0; i < n; ++i) {
    double jtf = 0;
    for (int k = 0; k < 6; ++k) jtf += J[6 * i + k] * F[k];
    largest = std::max(largest, std::abs(tau[i] - jtf) / (1 + std::abs(jtf)));
  }
  EXPECT_GT(largest, 1e-4);
}

// d theta / d r by central differences of hapticcal_compensate: the full n x n
// matrix, off-diagonal terms included, against reading_jacobian (diagonal for
// an uncoupled model).
TEST(Runtime, CompensationJacobianIsDiagonalAndMatchesTheTransmissionDerivatives) {
  for (const DeviceModel& model : {paper_device(), testing::mixed_chain(BaseKind::kPose)}) {
    SCOPED_TRACE(model.name);
    const RuntimeModel runtime = load_saved(model, "compensation");
    ASSERT_TRUE(runtime);
    const int n = model.dof();
    const PreparedModel prepared(model);
    std::mt19937_64 rng(9);
    const double h = 1e-6;
    for (int k = 0; k < 100; ++k) {
      const Eigen::VectorXd q = testing::random_readings(model, rng);
      std::vector<double> D(n * n), plus(n), minus(n);
      prepared.reading_jacobian(q.data(), D.data());
      for (int j = 0; j < n; ++j) {
        Eigen::VectorXd qp = q, qm = q;
        qp[j] += h;
        qm[j] -= h;
        ASSERT_EQ(hapticcal_compensate(runtime.get(), qp.data(), plus.data()), HAPTICCAL_OK);
        ASSERT_EQ(hapticcal_compensate(runtime.get(), qm.data(), minus.data()), HAPTICCAL_OK);
        for (int i = 0; i < n; ++i) {
          const double numeric = (plus[i] - minus[i]) / (2 * h);
          EXPECT_NEAR(numeric, D[j * n + i], 1e-7) << i << ", " << j;
          if (i != j) {
            EXPECT_EQ(D[j * n + i], 0.0);
          }
        }
        const double diagonal = D[j * n + j];
        EXPECT_NEAR(diagonal, 1 + model.links[j].transmission.derivative(q[j]), 1e-12);
      }
    }
  }
}

// runtime_alloc_test runs on tests/data/paper-actual-7dof.yaml and
// mixed-chain.yaml: they are save_device of these models (regenerate with
// HAPTICCAL_REGENERATE=1).
TEST(Runtime, AllocationTestModelsAreThePaperDeviceAndTheMixedChain) {
  const std::pair<std::string, DeviceModel> files[] = {
      {"tests/data/paper-actual-7dof.yaml", paper_device()},
      {"tests/data/mixed-chain.yaml", testing::mixed_chain(BaseKind::kDh)}};
  for (const auto& [relative, model] : files) {
    const std::string path = testing::source_path(relative);
    if (std::getenv("HAPTICCAL_REGENERATE")) save_device(model, path);
    // As loaded (a loader normalises axes).
    EXPECT_EQ(device_to_yaml(load_device(path)),
              device_to_yaml(parse_device(device_to_yaml(model), relative)))
        << relative;
  }
}

TEST(Runtime, ConcurrentReadersOfOneModelGetTheSingleThreadResults) {
  const DeviceModel paper = paper_device();
  const RuntimeModel runtime = load_saved(paper, "threads");
  ASSERT_TRUE(runtime);
  const int n = paper.dof();
  std::mt19937_64 rng(13);
  std::vector<Eigen::VectorXd> qs;
  for (int k = 0; k < 500; ++k) qs.push_back(testing::random_readings(paper, rng));
  const double F[6] = {1, 2, -3, 0.1, -0.2, 0.3};
  // Per sample: pose, Jacobian, joint values, torques.
  const int width = 16 + 6 * n + n + n;
  auto evaluate = [&](std::vector<double>& out) {
    out.assign(qs.size() * width, 0.0);
    bool ok = true;
    for (size_t k = 0; k < qs.size(); ++k) {
      double* row = out.data() + k * width;
      ok &= hapticcal_jacobian(runtime.get(), qs[k].data(), HAPTICCAL_FRAME_TOOL, row + 16, row) ==
            HAPTICCAL_OK;
      ok &= hapticcal_compensate(runtime.get(), qs[k].data(), row + 16 + 6 * n) == HAPTICCAL_OK;
      ok &= hapticcal_joint_torques(runtime.get(), qs[k].data(), F, HAPTICCAL_FRAME_MEASUREMENT,
                                    row + 16 + 7 * n) == HAPTICCAL_OK;
    }
    return ok;
  };
  std::vector<double> reference;
  ASSERT_TRUE(evaluate(reference));
  constexpr int kThreads = 4;
  std::vector<std::vector<double>> results(kThreads);
  std::vector<int> ok(kThreads, 1);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      for (int round = 0; round < 20 && ok[t]; ++round) {
        ok[t] = evaluate(results[t]) && results[t] == reference;
      }
    });
  }
  for (std::thread& t : threads) t.join();
  for (int t = 0; t < kThreads; ++t) EXPECT_TRUE(ok[t]) << "thread " << t;
}

// Every malformed device file of tests/malformed gives HAPTICCAL_E_INPUT and the
// one-line message the command line prints for it (cases.txt).
TEST(Runtime, MalformedDeviceFilesGiveTheCommandLinesOneLineMessage) {
  std::ifstream cases(testing::source_path("tests/malformed/cases.txt"));
  ASSERT_TRUE(cases);
  std::string line;
  int checked = 0;
  while (std::getline(cases, line)) {
    if (line.rfind("model|", 0) != 0) continue;
    std::vector<std::string> fields;
    std::stringstream split(line);
    for (std::string f; std::getline(split, f, '|');) fields.push_back(f);
    ASSERT_GE(fields.size(), 4u) << line;
    if (!fields[2].empty()) continue;  // needs command-line arguments
    SCOPED_TRACE(fields[1]);
    hapticcal_model* m = reinterpret_cast<hapticcal_model*>(&checked);  // must be reset
    char message[256];
    const std::string path = testing::source_path("tests/malformed/" + fields[1]);
    EXPECT_EQ(hapticcal_load(path.c_str(), nullptr, nullptr, &m, message, sizeof message),
              HAPTICCAL_E_INPUT);
    EXPECT_EQ(m, nullptr);
    EXPECT_NE(std::string(message).find(fields[3]), std::string::npos) << message;
    EXPECT_EQ(std::string(message).find('\n'), std::string::npos) << message;
    ++checked;
  }
  EXPECT_GE(checked, 20);
}

TEST(Runtime, LoadErrorsNameTheProblemAndTruncateTheMessage) {
  hapticcal_model* m = nullptr;
  char message[128];
  // A tip with a device file.
  const std::string device = testing::source_path("data/devices/baser-7dof.yaml");
  EXPECT_EQ(hapticcal_load(device.c_str(), "tool", nullptr, &m, message, sizeof message),
            HAPTICCAL_E_INPUT);
  EXPECT_EQ(m, nullptr);
  EXPECT_STRNE(message, "");
  // An unknown URDF tip names it.
  const std::string urdf = testing::real_data_path("mukca/panda.urdf");
  ASSERT_TRUE(std::filesystem::exists(urdf)) << "missing from the repository: " << urdf;
  EXPECT_EQ(hapticcal_load(urdf.c_str(), "no_such_link", nullptr, &m, message, sizeof message),
            HAPTICCAL_E_INPUT);
  EXPECT_NE(std::string(message).find("no_such_link"), std::string::npos) << message;
  // A short buffer gets the start of the line, terminated.
  char tiny[8];
  std::memset(tiny, 'x', sizeof tiny);
  EXPECT_EQ(hapticcal_load("/no/such/file.yaml", nullptr, nullptr, &m, tiny, sizeof tiny),
            HAPTICCAL_E_INPUT);
  EXPECT_STREQ(tiny, "/no/suc");
  // No buffer at all.
  EXPECT_EQ(hapticcal_load("/no/such/file.yaml", nullptr, nullptr, &m, nullptr, 0),
            HAPTICCAL_E_INPUT);
}

TEST(Runtime, NullPointersAndBadFramesAreArgumentErrors) {
  const RuntimeModel runtime = load(testing::source_path("data/devices/baser-7dof.yaml"));
  ASSERT_TRUE(runtime);
  const hapticcal_model* m = runtime.get();
  double q[7] = {0}, out[64], F[6] = {1, 0, 0, 0, 0, 0};
  char message[64];
  hapticcal_model* loaded = nullptr;
  EXPECT_EQ(hapticcal_load(nullptr, nullptr, nullptr, &loaded, message, sizeof message),
            HAPTICCAL_E_ARGUMENT);
  EXPECT_STRNE(message, "");
  const std::string path = testing::source_path("data/devices/baser-7dof.yaml");
  EXPECT_EQ(hapticcal_load(path.c_str(), nullptr, nullptr, nullptr, message, sizeof message),
            HAPTICCAL_E_ARGUMENT);
  EXPECT_EQ(hapticcal_load(path.c_str(), nullptr, nullptr, &loaded, nullptr, 10),
            HAPTICCAL_E_ARGUMENT);
  EXPECT_EQ(loaded, nullptr);
  EXPECT_EQ(hapticcal_dof(nullptr), -1);
  EXPECT_EQ(hapticcal_dof(m), 7);
  hapticcal_free(nullptr);

  EXPECT_EQ(hapticcal_compensate(nullptr, q, out), HAPTICCAL_E_ARGUMENT);
  EXPECT_EQ(hapticcal_compensate(m, nullptr, out), HAPTICCAL_E_ARGUMENT);
  EXPECT_EQ(hapticcal_compensate(m, q, nullptr), HAPTICCAL_E_ARGUMENT);
  EXPECT_EQ(hapticcal_forward(nullptr, q, out), HAPTICCAL_E_ARGUMENT);
  EXPECT_EQ(hapticcal_forward(m, nullptr, out), HAPTICCAL_E_ARGUMENT);
  EXPECT_EQ(hapticcal_forward(m, q, nullptr), HAPTICCAL_E_ARGUMENT);
  const auto measurement = HAPTICCAL_FRAME_MEASUREMENT;
  const auto bad = static_cast<hapticcal_frame>(7);
  EXPECT_EQ(hapticcal_jacobian(nullptr, q, measurement, out, nullptr), HAPTICCAL_E_ARGUMENT);
  EXPECT_EQ(hapticcal_jacobian(m, nullptr, measurement, out, nullptr), HAPTICCAL_E_ARGUMENT);
  EXPECT_EQ(hapticcal_jacobian(m, q, measurement, nullptr, nullptr), HAPTICCAL_E_ARGUMENT);
  EXPECT_EQ(hapticcal_jacobian(m, q, bad, out, nullptr), HAPTICCAL_E_ARGUMENT);
  EXPECT_EQ(hapticcal_joint_torques(nullptr, q, F, measurement, out), HAPTICCAL_E_ARGUMENT);
  EXPECT_EQ(hapticcal_joint_torques(m, nullptr, F, measurement, out), HAPTICCAL_E_ARGUMENT);
  EXPECT_EQ(hapticcal_joint_torques(m, q, nullptr, measurement, out), HAPTICCAL_E_ARGUMENT);
  EXPECT_EQ(hapticcal_joint_torques(m, q, F, measurement, nullptr), HAPTICCAL_E_ARGUMENT);
  EXPECT_EQ(hapticcal_joint_torques(m, q, F, bad, out), HAPTICCAL_E_ARGUMENT);

  for (int s = 0; s <= 4; ++s) {
    EXPECT_STRNE(hapticcal_status_string(static_cast<hapticcal_status>(s)), "unknown status");
  }
  EXPECT_STREQ(hapticcal_status_string(static_cast<hapticcal_status>(99)), "unknown status");
}

}  // namespace
}  // namespace hapticcal
