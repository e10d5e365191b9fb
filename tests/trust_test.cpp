// Issue 10: a failed or implausible calibration never looks like a success,
// repeated poses count once, and a command's outputs appear as one set or not
// at all (interrupts, concurrent runs, bad --out).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/model_io/device.hpp"
#include "test_models.hpp"

extern char** environ;

namespace hapticcal {
namespace {

namespace fs = std::filesystem;

std::string slurp(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// A running hapticcal process (argument vector, no shell), output to files.
struct Child {
  pid_t pid = -1;
  std::string out_path, err_path;

  Child(const std::vector<std::string>& args, const fs::path& scratch) {
    static int counter = 0;
    out_path = (scratch / fmt_name("out", counter)).string();
    err_path = (scratch / fmt_name("err", counter++)).string();
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC,
                                     0644);
    posix_spawn_file_actions_addopen(&actions, 2, err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC,
                                     0644);
    std::vector<std::string> argv{HAPTICCAL_CLI};
    argv.insert(argv.end(), args.begin(), args.end());
    std::vector<char*> raw;
    for (std::string& a : argv) raw.push_back(a.data());
    raw.push_back(nullptr);
    const int err = posix_spawn(&pid, HAPTICCAL_CLI, &actions, nullptr, raw.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    EXPECT_EQ(err, 0);
  }

  static std::string fmt_name(const char* kind, int k) {
    return std::string("child_") + kind + "_" + std::to_string(k) + ".txt";
  }

  // Exit code, or 128 + signal; the child's peak memory in `usage`.
  int wait(struct rusage* usage = nullptr) {
    int status = 0;
    struct rusage own {};
    while (::wait4(pid, &status, 0, usage ? usage : &own) < 0) {
      if (errno != EINTR) return -1;
    }
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }
  std::string out() const { return slurp(out_path); }
  std::string err() const { return slurp(err_path); }
};

struct CliRun {
  int code;
  std::string out, err;
};

class Trust : public ::testing::Test {
 protected:
  void SetUp() override {
    scratch_ = fs::temp_directory_path() /
               ("hapticcal_trust_" + std::to_string(::getpid()) + "_" +
                ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(scratch_);
    fs::create_directories(scratch_);
  }
  void TearDown() override { fs::remove_all(scratch_); }

  CliRun run(const std::vector<std::string>& args) {
    Child c(args, scratch_);
    const int code = c.wait();
    return {code, c.out(), c.err()};
  }

  fs::path scratch_;
};

// The staging folders a run may leave beside its --out.
std::vector<std::string> leftovers(const fs::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (name.find(".tmp-") != std::string::npos) out.push_back(name);
  }
  return out;
}

std::string fmt_double(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

// docs/calibrate.md's memory statement ("Long logs"): peak below 200 MB + this many
// KB per log row (a 10^6-row position log: under 1 GB).
constexpr double kPeakKbPerRow = 0.8;

const std::string kMeca = testing::source_path("examples/meca500/meca500.yaml");
const std::string kMecaLog =
    testing::source_path("examples/meca500/cal-norm_dist_data_0deg_160cube.csv");

// The Meca500 log with its lines filtered (header kept) and the header edited.
std::string meca_log_variant(const fs::path& path, int keep_every, const std::string& from,
                             const std::string& to) {
  std::istringstream in(slurp(kMecaLog));
  std::string line, text;
  int data = 0;
  bool header = true;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    if (header) {
      const size_t at = line.find(from);
      if (!from.empty() && at != std::string::npos) line.replace(at, from.size(), to);
      text += line + "\n";
      header = false;
      continue;
    }
    if (data++ % keep_every == 0) text += line + "\n";
  }
  std::ofstream(path) << text;
  return path.string();
}

// The Meca500 log with `edit(n, line)` applied to each line (n from 0, the header).
std::string edited_meca_log(const fs::path& path,
                            const std::function<void(int, std::string&)>& edit) {
  std::istringstream in(slurp(kMecaLog));
  std::string line, text;
  for (int n = 0; std::getline(in, line); ++n) {
    edit(n, line);
    text += line + "\n";
  }
  std::ofstream(path) << text;
  return path.string();
}

// `line` with its comma-separated field `index` (from 0) replaced by `value`.
void replace_field(std::string& line, int index, const std::string& value) {
  size_t begin = 0;
  for (int k = 0; k < index; ++k) begin = line.find(',', begin) + 1;
  line.replace(begin, line.find(',', begin) - begin, value);
}

TEST_F(Trust, ReadingsOutsideTheLimitsAreRefusedWithTheLikelyUnit) {
  const std::string log = meca_log_variant(scratch_ / "unitless.csv", 1, "q1[deg]", "q1");
  const CliRun r =
      run({"calibrate", "--model", kMeca, "--log", log, "--out", (scratch_ / "out").string()});
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << r.err;
  EXPECT_NE(r.err.find("unitless.csv: q1:"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("name the column q1[deg]"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(scratch_ / "out")) << "a refused run leaves no output folder";
}

TEST_F(Trust, ForcedUnitlessLogExits3AndKeepsThePreviousModel) {
  const fs::path out = scratch_ / "out";
  const CliRun good =
      run({"calibrate", "--model", kMeca, "--log", kMecaLog, "--out", out.string()});
  ASSERT_EQ(good.code, 0) << good.err;
  EXPECT_NE(good.out.rfind("status: converged\n"), std::string::npos) << good.out;
  const std::string model_before = slurp(out / "calibrated.yaml");
  ASSERT_FALSE(model_before.empty());

  const std::string log = meca_log_variant(scratch_ / "unitless.csv", 1, "q1[deg]", "q1");
  const CliRun bad =
      run({"calibrate", "--model", kMeca, "--log", log, "--out", out.string(), "--force"});
  EXPECT_EQ(bad.code, 3) << bad.out << bad.err;
  // The terminal's last line says so.
  const std::string last = bad.out.substr(bad.out.rfind('\n', bad.out.size() - 2) + 1);
  EXPECT_EQ(last.rfind("status: not converged", 0), 0u) << last;
  EXPECT_NE(last.find("the previous calibrated.yaml is kept"), std::string::npos) << last;
  EXPECT_EQ(slurp(out / "calibrated.yaml"), model_before) << "the good model was replaced";
  const auto j = nlohmann::json::parse(slurp(out / "results.json"));
  EXPECT_EQ(j["status"], "not converged");
  EXPECT_EQ(j["usable"], false);
  EXPECT_NE(j["status_reason"].get<std::string>().find("did not converge"), std::string::npos);
  EXPECT_EQ(j["log"], log);
  const std::string report = slurp(out / "report.html");
  EXPECT_NE(report.find("Status: not converged"), std::string::npos);
  EXPECT_NE(report.find("no new calibrated.yaml was written"), std::string::npos);
}

TEST_F(Trust, LogOfAnotherDeviceIsRefused) {
  // The PHANToM's limits already refuse the Meca500's readings ...
  const CliRun phantom =
      run({"calibrate", "--model", testing::source_path("data/devices/phantom-premium-1.5.yaml"),
           "--log", kMecaLog, "--out", (scratch_ / "a").string()});
  EXPECT_EQ(phantom.code, 2) << phantom.out;
  EXPECT_NE(phantom.err.find("outside j5's limits"), std::string::npos) << phantom.err;
  // ... and a model that admits the readings but is another arm (every length
  // doubled) fails the reach test: even with its base pose fitted, its nominal
  // error is beyond 5 % of the reach.
  DeviceModel other = testing::meca500();
  for (Link& link : other.links) {
    link.a *= 2;
    link.d *= 2;
  }
  const fs::path model = scratch_ / "other.yaml";
  save_device(other, model.string());
  const CliRun r = run({"calibrate", "--model", model.string(), "--log", kMecaLog, "--out",
                        (scratch_ / "b").string()});
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.err.find("is this log from this device (meca500)?"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(scratch_ / "b"));
  // --force turns both into warnings; the change of j3.a is then flagged.
  const CliRun forced = run({"calibrate", "--model", model.string(), "--log", kMecaLog, "--out",
                             (scratch_ / "b").string(), "--force"});
  EXPECT_NE(forced.out.find("warning: the nominal model's RMS error"), std::string::npos);
  const auto j = nlohmann::json::parse(slurp(scratch_ / "b/results.json"));
  EXPECT_EQ(j["parameters"]["j3.a"]["large_change"], true);
  EXPECT_EQ(j["parameters"]["j3.beta"]["large_change"], false);
  // A base pose that is only roughly known is no reason to refuse: 4 cm off,
  // the log is calibrated as with the right base.
  DeviceModel shifted = testing::meca500();
  Eigen::VectorXd p = shifted.kinematic_parameters();
  p.head<3>() += Eigen::Vector3d(0.035, -0.035, 0.03);
  shifted.set_kinematic_parameters(p);
  save_device(shifted, (scratch_ / "shifted.yaml").string());
  const CliRun rough = run({"calibrate", "--model", (scratch_ / "shifted.yaml").string(), "--log",
                            kMecaLog, "--out", (scratch_ / "c").string()});
  EXPECT_EQ(rough.code, 0) << rough.err;
  EXPECT_NE(rough.out.find("with its base pose fitted (below 5 % of the reach"), std::string::npos)
      << rough.out;
}

TEST_F(Trust, RepeatedPosesCountOnce) {
  // The Meca500 logs hold every pose 3 times: the sd must be that of one row a pose.
  const CliRun all = run({"calibrate", "--model", kMeca, "--log", kMecaLog, "--keep-all", "--out",
                          (scratch_ / "all").string()});
  ASSERT_EQ(all.code, 0) << all.err;
  const std::string single = meca_log_variant(scratch_ / "single.csv", 3, "", "");
  const CliRun one = run({"calibrate", "--model", kMeca, "--log", single, "--keep-all", "--out",
                          (scratch_ / "one").string()});
  ASSERT_EQ(one.code, 0) << one.err;
  const auto ja = nlohmann::json::parse(slurp(scratch_ / "all/results.json"));
  const auto jo = nlohmann::json::parse(slurp(scratch_ / "one/results.json"));
  EXPECT_EQ(ja["rows_used"], 210);
  EXPECT_EQ(ja["poses"], 70);
  EXPECT_EQ(jo["poses"], 70);
  for (const char* name : {"j3.beta", "j2.a", "j2.theta", "tool.x"}) {
    const double sd_all = ja["parameters"][name]["sd"], sd_one = jo["parameters"][name]["sd"];
    EXPECT_NEAR(sd_all / sd_one, 1.0, 0.10) << name;
  }
  EXPECT_NEAR(ja["condition_number"].get<double>() / jo["condition_number"].get<double>(), 1.0,
              0.01);
  // The repeatability, recomputed here from the raw rows (mm in the file).
  const Log log = read_log(kMecaLog);
  double sum = 0;
  int dof = 0;
  // A row repeating another's numbers exactly is that sample again, not a repeat.
  for (int r = 0; r + 2 < log.rows; r += 3) {
    std::vector<Eigen::Vector3d> distinct;
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d p = log.position.row(r + k).transpose();
      if (std::find(distinct.begin(), distinct.end(), p) == distinct.end()) distinct.push_back(p);
    }
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const Eigen::Vector3d& p : distinct) mean += p / static_cast<double>(distinct.size());
    for (const Eigen::Vector3d& p : distinct) sum += (p - mean).squaredNorm();
    dof += static_cast<int>(distinct.size()) - 1;
  }
  EXPECT_NEAR(ja["repeatability"].get<double>(), std::sqrt(sum / dof), 1e-12);
  EXPECT_TRUE(jo["repeatability"].is_null());
  // With a given per-reading sigma, a mean of 3 repeats is sqrt(3) better known.
  const CliRun given_all = run({"calibrate", "--model", kMeca, "--log", kMecaLog, "--sigma", "1e-5",
                                "--keep-all", "--out", (scratch_ / "ga").string()});
  const CliRun given_one = run({"calibrate", "--model", kMeca, "--log", single, "--sigma", "1e-5",
                                "--keep-all", "--out", (scratch_ / "go").string()});
  ASSERT_EQ(given_all.code, 0);
  ASSERT_EQ(given_one.code, 0);
  const auto ga = nlohmann::json::parse(slurp(scratch_ / "ga/results.json"));
  const auto go = nlohmann::json::parse(slurp(scratch_ / "go/results.json"));
  for (const char* name : {"j3.beta", "j2.a", "tool.x"}) {
    const double all = ga["parameters"][name]["sd"], one = go["parameters"][name]["sd"];
    EXPECT_NEAR(all / one, 1 / std::sqrt(3.0), 0.02) << name;
  }
  // --samples counts poses.
  const CliRun sampled = run({"calibrate", "--model", kMeca, "--log", kMecaLog, "--samples", "40",
                              "--out", (scratch_ / "s").string()});
  ASSERT_EQ(sampled.code, 0) << sampled.err;
  const auto js = nlohmann::json::parse(slurp(scratch_ / "s/results.json"));
  EXPECT_EQ(js["poses"], 40);
  EXPECT_EQ(js["rows_used"], 120);
}

TEST_F(Trust, NonFiniteErrorsAreBadInput) {
  // Line 6 (the 5th data row): x (field 6) becomes 1e308, finite, but its error overflows.
  const std::string log = edited_meca_log(scratch_ / "huge.csv", [](int n, std::string& line) {
    if (n == 5) replace_field(line, 6, "1e308");
  });
  const CliRun e = run({"evaluate", "--model", kMeca, "--log", log, "--json"});
  EXPECT_EQ(e.code, 2) << e.out;
  EXPECT_NE(e.err.find("huge.csv:6:"), std::string::npos) << e.err;
  const CliRun c =
      run({"calibrate", "--model", kMeca, "--log", log, "--out", (scratch_ / "o").string()});
  EXPECT_EQ(c.code, 2) << c.out;
  EXPECT_NE(c.err.find("huge.csv:6:"), std::string::npos) << c.err;
}

TEST_F(Trust, LinesOfCommasAreRefusedWithoutTheirMemory) {
  // 20 MB of commas in a data row, then in a header: the field count is read
  // before the fields are split (it took 1.1 GB).
  const std::string commas(20'000'000, ',');
  std::ofstream(scratch_ / "row.csv") << "q1,q2,x,y,z\n" << commas << "\n";
  std::ofstream(scratch_ / "header.csv") << commas << "\n";
  const std::string model = testing::source_path("tests/malformed/good-2dof.yaml");
  for (const char* file : {"row.csv", "header.csv"}) {
    SCOPED_TRACE(file);
    Child c({"evaluate", "--model", model, "--log", (scratch_ / file).string()}, scratch_);
    struct rusage usage {};
    EXPECT_EQ(c.wait(&usage), 2);
    EXPECT_NE(c.err().find(std::string(file) + ":"), std::string::npos) << c.err();
    EXPECT_NE(c.err().find("20000001"), std::string::npos) << c.err();
    EXPECT_LT(usage.ru_maxrss / 1024.0, 200) << "MB for a 20 MB file";
  }
}

TEST_F(Trust, NumericOptionsAreRangeChecked) {
  const std::string device = testing::source_path("data/devices/baser-7dof.yaml");
  const std::vector<std::string> force{"force",     "--actual", device,
                                       "--nominal", device,     "--calibrated",
                                       device,      "--out",    (scratch_ / "f").string()};
  auto with = [&](std::vector<std::string> args, const std::string& option,
                  const std::string& value) {
    args.push_back(option);
    args.push_back(value);
    return run(args);
  };
  // Each once crashed or printed nan with exit 0.
  for (const auto& [option, value, limit] :
       std::vector<std::tuple<std::string, std::string, std::string>>{
           {"--seconds", "3000000", "[0, 600] s"},
           {"--travel", "1e308", "[-1, 1] m"},
           {"--travel", "nan", "[-1, 1] m"},
           {"--gain", "inf", "[-100, 100]"},
           {"--stiffness", "-5", "[0.001, 1000000] N/m"}}) {
    SCOPED_TRACE(option + " " + value);
    const CliRun r = with(force, option, value);
    EXPECT_EQ(r.code, 2);
    EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << r.err;
    EXPECT_NE(r.err.find(option), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(limit), std::string::npos) << r.err;
  }
  EXPECT_FALSE(fs::exists(scratch_ / "f"));
  const CliRun trials =
      run({"simulate", "--trials", "1000000000", "--out", (scratch_ / "s").string()});
  EXPECT_EQ(trials.code, 2);
  EXPECT_NE(trials.err.find("[1, 100000]"), std::string::npos) << trials.err;
}

TEST_F(Trust, WriteFailuresAreIoErrorsNotBadInput) {
  // Exit 1 with the system's reason, not 2 ("bad input").
  EXPECT_THROW(write_file_atomically("/proc/hapticcal-cannot-write-here", "x"), IoError);
  try {
    write_file_atomically("/proc/hapticcal-cannot-write-here", "x");
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("/proc/hapticcal-cannot-write-here: cannot write: "),
              std::string::npos)
        << e.what();
  }
}

TEST_F(Trust, SmallDeviceGetsItsOwnTruthNeverThePapersFourDrives) {
  // Found by fuzz_scenario: Table 2's four drives written past a 2-joint device.
  // The paper's truth is the paper's device's only (issue 13): a 2-joint device
  // is simulated with its own transmissions, and asking for the paper's is refused.
  const std::string device = testing::source_path("tests/malformed/good-2dof.yaml");
  const CliRun r = run({"simulate", "--device", device, "--out", (scratch_ / "o").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  const DeviceModel nominal = load_device(device),
                    actual = load_device((scratch_ / "o" / "actual.yaml").string());
  ASSERT_EQ(actual.dof(), 2);
  for (int j = 0; j < 2; ++j) {
    EXPECT_EQ(actual.links[j].transmission.parameters(),
              nominal.links[j].transmission.parameters());
  }
  const fs::path scenario = scratch_ / "paper.yaml";
  std::ofstream(scenario) << "format: hapticcal-scenario/1\ndevice: " << device
                          << "\ntransmissions: paper\n";
  const CliRun refused =
      run({"simulate", "--scenario", scenario.string(), "--out", (scratch_ / "p").string()});
  EXPECT_EQ(refused.code, 2);
  EXPECT_NE(refused.err.find("paper.yaml:3: transmissions: the paper's capstans"),
            std::string::npos)
      << refused.err;
  EXPECT_FALSE(fs::exists(scratch_ / "p"));
}

TEST_F(Trust, OutputFolderIsCheckedBeforeAnyWork) {
  const std::vector<std::string> base{"calibrate", "--model", kMeca, "--log", kMecaLog, "--out"};
  auto with_out = [&](const std::string& out) {
    std::vector<std::string> a = base;
    a.push_back(out);
    return run(a);
  };
  const CliRun empty = with_out("");
  EXPECT_EQ(empty.code, 2);
  EXPECT_NE(empty.err.find("--out: an empty path"), std::string::npos) << empty.err;
  EXPECT_EQ(empty.out, "") << "no work before the check";
  EXPECT_EQ(with_out(".").code, 2);
  EXPECT_EQ(with_out("/").code, 2);
  // A folder of someone else's files is never replaced.
  fs::create_directories(scratch_ / "mine");
  std::ofstream(scratch_ / "mine/thesis.tex") << "precious";
  const CliRun foreign = with_out((scratch_ / "mine").string());
  EXPECT_EQ(foreign.code, 2);
  EXPECT_NE(foreign.err.find("holds files hapticcal did not write"), std::string::npos);
  EXPECT_EQ(slurp(scratch_ / "mine/thesis.tex"), "precious");
  // A file in the way, and an unwritable parent: I/O errors, exit 1, with the reason.
  std::ofstream(scratch_ / "file") << "x";
  const CliRun under_file = with_out((scratch_ / "file/out").string());
  EXPECT_EQ(under_file.code, 1) << under_file.err;
  EXPECT_EQ(under_file.out, "");
  if (::geteuid() != 0) {  // root writes anywhere
    fs::create_directories(scratch_ / "ro");
    fs::permissions(scratch_ / "ro", fs::perms::owner_read | fs::perms::owner_exec);
    const CliRun ro = with_out((scratch_ / "ro/out").string());
    EXPECT_EQ(ro.code, 1);
    EXPECT_NE(ro.err.find("Permission denied"), std::string::npos) << ro.err;
    fs::permissions(scratch_ / "ro", fs::perms::owner_all);
  }
}

TEST_F(Trust, ARerunReplacesOnlyWhatItsLastRunWrote) {
  const std::vector<std::string> cal{"calibrate", "--model", kMeca, "--log", kMecaLog, "--out"};
  auto into = [&](const fs::path& out) {
    std::vector<std::string> a = cal;
    a.push_back(out.string());
    return run(a);
  };
  // A results.json is no licence: a folder without the marker is refused.
  fs::create_directories(scratch_ / "proj/src");
  std::ofstream(scratch_ / "proj/results.json") << "{}";
  std::ofstream(scratch_ / "proj/src/thesis.tex") << "precious";
  EXPECT_EQ(into(scratch_ / "proj").code, 2);
  EXPECT_EQ(slurp(scratch_ / "proj/src/thesis.tex"), "precious");
  // A set with a file added by hand, or another set nested in it, is refused too.
  ASSERT_EQ(into(scratch_ / "set").code, 0);
  const std::string marker = slurp(scratch_ / "set/.hapticcal-output");
  EXPECT_EQ(marker.rfind("hapticcal calibrate\n", 0), 0u) << marker;
  EXPECT_NE(marker.find("\ncalibrated.yaml\n"), std::string::npos) << marker;
  std::ofstream(scratch_ / "set/notes.txt") << "mine";
  const CliRun added = into(scratch_ / "set");
  EXPECT_EQ(added.code, 2);
  EXPECT_NE(added.err.find("holds 'notes.txt', which its last run did not write"),
            std::string::npos)
      << added.err;
  fs::remove(scratch_ / "set/notes.txt");
  ASSERT_EQ(run({"simulate", "--trials", "1", "--out", (scratch_ / "set/sim").string()}).code, 0);
  EXPECT_EQ(into(scratch_ / "set").code, 2);
  EXPECT_TRUE(fs::exists(scratch_ / "set/sim/results.json"));
  // A trailing slash names the folder; a symbolic link is followed, and stays.
  fs::remove_all(scratch_ / "set/sim");
  EXPECT_EQ(into(fs::path((scratch_ / "set").string() + "/")).code, 0);
  fs::create_directory_symlink(scratch_ / "set", scratch_ / "link");
  const std::string before = slurp(scratch_ / "set/results.json");
  ASSERT_EQ(run({"calibrate", "--model", kMeca, "--log", kMecaLog, "--samples", "30", "--out",
                 (scratch_ / "link").string()})
                .code,
            0);
  EXPECT_TRUE(fs::is_symlink(scratch_ / "link"));
  EXPECT_NE(slurp(scratch_ / "set/results.json"), before) << "the linked folder was not replaced";
  EXPECT_EQ(nlohmann::json::parse(slurp(scratch_ / "link/results.json"))["poses"], 30);
}

TEST_F(Trust, KilledRunsLeaveNothingTheNextRunKeeps) {
  const fs::path out = scratch_ / "fresh";
  // SIGTERM early into a new folder: no folder at all afterwards.
  Child early({"simulate", "--trials", "1", "--out", out.string()}, scratch_);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  ::kill(early.pid, SIGTERM);
  EXPECT_EQ(early.wait(), 143);
  EXPECT_FALSE(fs::exists(out));
  EXPECT_EQ(leftovers(scratch_), std::vector<std::string>{});
  // SIGKILL cannot be handled: its staging folder stays until the next run
  // into that folder sweeps it.
  Child killed({"simulate", "--trials", "1", "--out", out.string()}, scratch_);
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  ::kill(killed.pid, SIGKILL);
  killed.wait();
  EXPECT_FALSE(leftovers(scratch_).empty()) << "killed before it made its staging folder";
  ASSERT_EQ(run({"calibrate", "--model", kMeca, "--log", kMecaLog, "--out", out.string()}).code, 0);
  EXPECT_EQ(leftovers(scratch_), std::vector<std::string>{});
  // A closed pipe on stdout: an error, not a death that leaves the staging folder.
  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  ::close(fds[0]);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, fds[1], 1);
  std::vector<std::string> argv{HAPTICCAL_CLI, "calibrate", "--model", kMeca,
                                "--log",       kMecaLog,    "--out",   (scratch_ / "p").string()};
  std::vector<char*> raw;
  for (std::string& a : argv) raw.push_back(a.data());
  raw.push_back(nullptr);
  pid_t pid = -1;
  ASSERT_EQ(posix_spawn(&pid, HAPTICCAL_CLI, &actions, nullptr, raw.data(), environ), 0);
  posix_spawn_file_actions_destroy(&actions);
  ::close(fds[1]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  EXPECT_TRUE(WIFEXITED(status)) << "killed by signal " << WTERMSIG(status);
  EXPECT_EQ(leftovers(scratch_), std::vector<std::string>{});
}

TEST_F(Trust, AFailedRunKeepsOnlyAModelOfTheSameDevice) {
  // A simulate set holds the 7-DOF's calibrated.yaml: a failed Meca500
  // calibration into it must not present that as its previous model.
  const fs::path out = scratch_ / "o";
  ASSERT_EQ(run({"simulate", "--trials", "1", "--out", out.string()}).code, 0);
  const std::string log = meca_log_variant(scratch_ / "unitless.csv", 1, "q1[deg]", "q1");
  const CliRun bad =
      run({"calibrate", "--model", kMeca, "--log", log, "--out", out.string(), "--force"});
  EXPECT_EQ(bad.code, 3);
  EXPECT_FALSE(fs::exists(out / "calibrated.yaml"));
  EXPECT_NE(bad.out.find("no calibrated.yaml written"), std::string::npos) << bad.out;
}

TEST_F(Trust, NegativeZeroReadingsAreTheSamePose) {
  // The first pose's three rows: q1 = 0, -0, -0 (a logger printing -0.000).
  const Log log = read_log(edited_meca_log(scratch_ / "zero.csv", [](int n, std::string& line) {
    if (n >= 1 && n <= 3) replace_field(line, 0, n == 1 ? "0" : "-0.000");
  }));
  ASSERT_TRUE(log.q(0, 0) == 0 && !std::signbit(log.q(0, 0)) && std::signbit(log.q(1, 0)));
  EXPECT_EQ(repeated_poses(log).size(), 70u);
}

// Each file of `dir` that names a run's identity, read whole.
std::map<std::string, std::string> identity(const fs::path& dir,
                                            const std::vector<std::string>& files) {
  std::map<std::string, std::string> out;
  for (const std::string& f : files) out[f] = fs::exists(dir / f) ? slurp(dir / f) : "(missing)";
  return out;
}

// Runs `args + --out out` twice into reference folders (two variants), then
// `trials` times into one folder that holds variant A, interrupting variant B
// at a random time: afterwards the folder holds all of A or all of B.
void expect_interrupts_leave_whole_sets(
    const fs::path& scratch, const std::vector<std::string>& a, const std::vector<std::string>& b,
    const std::vector<std::string>& files, int trials, std::mt19937_64& rng,
    const std::function<CliRun(const std::vector<std::string>&)>& run) {
  auto with_out = [](std::vector<std::string> args, const fs::path& out) {
    args.push_back("--out");
    args.push_back(out.string());
    return args;
  };
  const auto start = std::chrono::steady_clock::now();
  ASSERT_EQ(run(with_out(a, scratch / "ref_a")).code, 0);
  const auto mid = std::chrono::steady_clock::now();
  ASSERT_EQ(run(with_out(b, scratch / "ref_b")).code, 0);
  const double seconds_b =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - mid).count();
  (void)start;
  const auto ref_a = identity(scratch / "ref_a", files), ref_b = identity(scratch / "ref_b", files);
  ASSERT_NE(ref_a, ref_b);
  int old_kept = 0, new_complete = 0;
  for (int k = 0; k < trials; ++k) {
    const fs::path out = scratch / "out";
    fs::remove_all(out);
    fs::copy(scratch / "ref_a", out, fs::copy_options::recursive);
    Child child(with_out(b, out), scratch);
    const double delay = std::uniform_real_distribution<double>(0, 1.2 * seconds_b)(rng);
    std::this_thread::sleep_for(std::chrono::duration<double>(delay));
    ::kill(child.pid, SIGINT);
    const int code = child.wait();
    SCOPED_TRACE("trial " + std::to_string(k) + ", SIGINT after " + std::to_string(delay) +
                 " s, exit " + std::to_string(code));
    const auto now = identity(out, files);
    EXPECT_TRUE(now == ref_a || now == ref_b) << "a mixed or partial set";
    EXPECT_TRUE(code == 130 || code == 0) << child.err();
    (now == ref_a ? old_kept : new_complete)++;
    EXPECT_EQ(leftovers(scratch), std::vector<std::string>{});
  }
  std::cout << "interrupted runs: old set kept " << old_kept << ", new set complete "
            << new_complete << "\n";
  EXPECT_GT(old_kept, 0) << "no interrupt hit the run: the test proved nothing";
}

TEST_F(Trust, InterruptedCalibrationLeavesTheOldSetOrTheNewOne) {
  std::mt19937_64 rng(10);
  const std::vector<std::string> common{"calibrate", "--model", kMeca, "--log", kMecaLog};
  std::vector<std::string> a = common, b = common;
  a.insert(a.end(), {"--samples", "50", "--seed", "1"});
  b.insert(b.end(), {"--samples", "60", "--seed", "2"});
  expect_interrupts_leave_whole_sets(
      scratch_, a, b, {"calibrated.yaml", "results.json", ".hapticcal-output"}, 20, rng,
      [this](const std::vector<std::string>& args) { return run(args); });
}

TEST_F(Trust, InterruptedSimulationLeavesTheOldSetOrTheNewOne) {
  std::mt19937_64 rng(11);
  const std::vector<std::string> a{"simulate", "--trials", "1", "--threads", "1", "--seed", "1"};
  const std::vector<std::string> b{"simulate", "--trials", "1", "--threads", "1", "--seed", "2"};
  expect_interrupts_leave_whole_sets(
      scratch_, a, b,
      {"calibrated.yaml", "results.json", "identification.csv", "trajectory.csv", "actual.yaml"},
      20, rng, [this](const std::vector<std::string>& args) { return run(args); });
}

TEST_F(Trust, ConcurrentRunsIntoOneFolderNeverMix) {
  const std::vector<std::string> common{"calibrate", "--model", kMeca, "--log", kMecaLog};
  auto variant = [&](const char* samples, const fs::path& out) {
    std::vector<std::string> v = common;
    v.insert(v.end(), {"--samples", samples, "--out", out.string()});
    return v;
  };
  ASSERT_EQ(run(variant("50", scratch_ / "ref_a")).code, 0);
  ASSERT_EQ(run(variant("60", scratch_ / "ref_b")).code, 0);
  const std::vector<std::string> files{"calibrated.yaml", "results.json"};
  const auto ref_a = identity(scratch_ / "ref_a", files);
  const auto ref_b = identity(scratch_ / "ref_b", files);
  int refused = 0;
  for (int k = 0; k < 20; ++k) {
    const fs::path out = scratch_ / "out";
    Child one(variant("50", out), scratch_), two(variant("60", out), scratch_);
    const int c1 = one.wait(), c2 = two.wait();
    SCOPED_TRACE("pair " + std::to_string(k));
    EXPECT_TRUE(c1 == 0 || c1 == 1) << one.err();
    EXPECT_TRUE(c2 == 0 || c2 == 1) << two.err();
    EXPECT_TRUE(c1 == 0 || c2 == 0);
    for (Child* c : {&one, &two}) {
      const std::string err = c->err();
      if (!err.empty()) {
        EXPECT_NE(err.find("another hapticcal run is writing into this folder"), std::string::npos)
            << err;
        ++refused;
      }
    }
    const auto now = identity(out, files);
    EXPECT_TRUE(now == ref_a || now == ref_b) << "a mixed set";
    EXPECT_TRUE(leftovers(scratch_).empty());
  }
  std::cout << "concurrent pairs: " << refused << " of 20 second runs refused by the lock\n";
}

TEST_F(Trust, LongLogsGiveSmallReportsAndLinearMemory) {
  // 20,000 distinct poses (the Meca500 poses, readings jittered by < 1e-6 rad).
  const Log base = read_log(kMecaLog);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> jitter(-1e-6, 1e-6);
  std::string csv = "q1,q2,q3,q4,q5,q6,x,y,z\n";
  const int rows = 20000;
  for (int r = 0; r < rows; ++r) {
    const int s = r % base.rows;
    for (int j = 0; j < 6; ++j) csv += fmt_double(base.q(s, j) + jitter(rng)) + ",";
    csv += fmt_double(base.position(s, 0)) + "," + fmt_double(base.position(s, 1)) + "," +
           fmt_double(base.position(s, 2)) + "\n";
  }
  std::ofstream(scratch_ / "long.csv") << csv;
  Child child({"calibrate", "--model", kMeca, "--log", (scratch_ / "long.csv").string(), "--out",
               (scratch_ / "o").string()},
              scratch_);
  struct rusage usage {};
  ASSERT_EQ(child.wait(&usage), 0) << child.err();
  const double peak_mb = usage.ru_maxrss / 1024.0;
  std::cout << "20,000-row calibrate: peak " << peak_mb << " MB, report "
            << fs::file_size(scratch_ / "o/report.html") / 1024 << " KB\n";
  EXPECT_LT(fs::file_size(scratch_ / "o/report.html"), 1u << 20);
  // Figures are decimated to about 2000 points.
  std::ifstream fig(scratch_ / "o/figures/errors_per_sample.csv");
  int lines = 0;
  for (std::string l; std::getline(fig, l);) ++lines;
  EXPECT_GT(lines, 1000);
  EXPECT_LE(lines, 2001);
  EXPECT_LT(peak_mb, 200 + rows * 1e-3 * kPeakKbPerRow) << "the stated memory constant";
}

}  // namespace
}  // namespace hapticcal
