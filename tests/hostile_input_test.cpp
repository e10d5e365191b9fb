// Hostile and careless input (issue 23): each case of the audit reproduced -
// the large inputs generated here, never committed - and required to end in one
// line and an exit code, never a crash, a hang or a lost file. The commands run
// as child processes under a watchdog (a hang fails the test instead of
// stalling it) and with unusual standard streams (a full disk, a closed stderr).
#include <fcntl.h>
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/core/log.hpp"
#include "hapticcal/core/output_set.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/identification/stream.hpp"
#include "hapticcal/model_io/model_source.hpp"
#include "hapticcal/model_io/urdf.hpp"
#include "hapticcal/runtime.h"
#include "hapticcal/study/session.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

extern char** environ;

namespace hapticcal {
namespace {

namespace fs = std::filesystem;
using testing::source_path;

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define HAPTICCAL_ASAN 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__)
#define HAPTICCAL_ASAN 1
#endif

// A hang guard, not a speed target: far above the 2 s a refusal takes.
constexpr int kWatchdogSeconds = 60;

struct ChildRun {
  int exit_code = -1;
  bool killed = false;  // by the watchdog
  long peak_kib = 0;    // the child's largest resident set
  std::string out, err;
};

// Where a child's stream goes: a file of the test's, a path such as
// /dev/full, or closed.
struct Stream {
  enum Kind { kCapture, kPath, kClosed } kind = kCapture;
  std::string path;
};

ChildRun run(const std::vector<std::string>& args, Stream out = {}, Stream err = {}) {
  static int counter = 0;
  const std::string base =
      (fs::path(::testing::TempDir()) / fmt::format("hostile_{}_{}", ::getpid(), counter++))
          .string();
  std::vector<std::string> argv{HAPTICCAL_CLI};
  argv.insert(argv.end(), args.begin(), args.end());
  std::vector<char*> cargv;
  for (std::string& a : argv) cargv.push_back(a.data());
  cargv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  auto route = [&](int fd, const Stream& s, const std::string& capture) {
    if (s.kind == Stream::kClosed) {
      posix_spawn_file_actions_addclose(&actions, fd);
    } else {
      posix_spawn_file_actions_addopen(&actions, fd,
                                       s.kind == Stream::kPath ? s.path.c_str() : capture.c_str(),
                                       O_WRONLY | O_CREAT | O_TRUNC, 0600);
    }
  };
  route(STDOUT_FILENO, out, base + ".out");
  route(STDERR_FILENO, err, base + ".err");
  ChildRun r;
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, argv[0].c_str(), &actions, nullptr, cargv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) {
    r.err = "cannot run the command line";
    return r;
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(kWatchdogSeconds);
  int status = 0;
  struct rusage usage {};
  for (;;) {
    const pid_t done = ::wait4(pid, &status, WNOHANG, &usage);
    if (done == pid) break;
    if (std::chrono::steady_clock::now() > deadline) {
      ::kill(pid, SIGKILL);
      ::wait4(pid, &status, 0, &usage);
      r.killed = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  r.peak_kib = usage.ru_maxrss;
  if (out.kind == Stream::kCapture) r.out = testing::slurp(base + ".out");
  if (err.kind == Stream::kCapture) r.err = testing::slurp(base + ".err");
  fs::remove(base + ".out");
  fs::remove(base + ".err");
  return r;
}

// Exit 2 with one line on stderr holding `says`; no hang; within 200 MB
// (not measured under AddressSanitizer, whose shadow memory is most of it).
void expect_refused(const ChildRun& r, const std::string& says, const std::string& what) {
  EXPECT_FALSE(r.killed) << what << ": still running after " << kWatchdogSeconds << " s";
  EXPECT_EQ(r.exit_code, 2) << what << ": " << r.out << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << what << ": " << r.err;
  EXPECT_NE(r.err.find(says), std::string::npos) << what << ": " << r.err;
#ifndef HAPTICCAL_ASAN
  EXPECT_LT(r.peak_kib, 200 * 1024) << what;
#endif
}

std::string scratch(const std::string& name) { return testing::fresh_folder("hostile_" + name); }

std::string write(const std::string& path, const std::string& text) {
  write_file_atomically(path, text);
  return path;
}

// A valid 2-joint log beside the malformed-input cases.
std::string good_log() { return source_path("tests/malformed/good-2dof.csv"); }

// C1: a URDF nested 50,000 levels deep (350 KB) overflowed tinyxml's stack.
TEST(Hostile, DeeplyNestedUrdfIsRefusedBeforeTheXmlParser) {
  const std::string dir = scratch("deep");
  std::string text = "<robot name=\"r\"><link name=\"l0\">";
  for (int k = 0; k < 50000; ++k) text += "<a>";
  for (int k = 0; k < 50000; ++k) text += "</a>";
  text += "</link></robot>\n";
  const std::string urdf = write(dir + "/deep.urdf", text);
  expect_refused(run({"convert", urdf, dir + "/out.yaml"}), "nested more than 200 deep", "convert");
  expect_refused(run({"evaluate", "--model", urdf, "--log", good_log()}),
                 "nested more than 200 deep", "evaluate --model");
  EXPECT_FALSE(fs::exists(dir + "/out.yaml"));
  // The library and the C runtime (a controller must survive it too).
  EXPECT_THROW(load_model(urdf, "", ""), InputError);
  hapticcal_model* model = nullptr;
  char message[256];
  EXPECT_EQ(hapticcal_load(urdf.c_str(), "l0", nullptr, &model, message, sizeof message),
            HAPTICCAL_E_INPUT);
  EXPECT_EQ(model, nullptr);
  EXPECT_NE(std::string(message).find("nested"), std::string::npos) << message;
}

// C1 through markup the depth check must not skip further than tinyxml reads:
// tinyxml ends a declaration or processing instruction at its first '>', so a
// DOCTYPE "[>" (or an unclosed quote, or a "<?x" without "?>") followed by
// 50,000 nested elements reached its recursion when the check skipped to the
// DOCTYPE's closing bracket (a review of d0ac50d).
TEST(Hostile, DeepNestingAfterADeclarationIsRefusedToo) {
  const std::string dir = scratch("declaration");
  std::string nested;
  for (int k = 0; k < 50000; ++k) nested += "<a>";
  for (int k = 0; k < 50000; ++k) nested += "</a>";
  const std::vector<std::string> openings = {"<!DOCTYPE r [>", "<!x '>", "<?x >"};
  for (size_t k = 0; k < openings.size(); ++k) {
    const std::string urdf = write(
        dir + fmt::format("/d{}.urdf", k),
        openings[k] + "<robot name=\"r\"><link name=\"l0\">" + nested + "</link></robot>]>\n");
    expect_refused(run({"convert", urdf, dir + "/out.yaml"}), "nested more than 200 deep",
                   openings[k]);
  }
}

// H2: one element with 100,000 attributes took 41 s in tinyxml's duplicate check.
TEST(Hostile, AnElementWithManyAttributesIsRefused) {
  const std::string dir = scratch("attributes");
  std::string text = "<robot name=\"r\"><link name=\"l0\"";
  for (int k = 0; k < 100000; ++k) text += fmt::format(" a{}=\"1\"", k);
  text += "/></robot>\n";
  const std::string urdf = write(dir + "/many.urdf", text);
  expect_refused(run({"convert", urdf, dir + "/out.yaml"}), "attributes: at most 100", "convert");
}

// H1: 2 MB of '&' without ';' in an attribute: entity decoding was quadratic.
TEST(Hostile, AnAttributeOfAmpersandsIsDecodedInLinearTime) {
  const std::string dir = scratch("entities");
  const std::string text = "<robot name=\"" + std::string(2 << 20, '&') +
                           "\"><link name=\"a\"/><link name=\"b\"/><joint name=\"j\" "
                           "type=\"revolute\"><parent link=\"a\"/><child link=\"b\"/><axis "
                           "xyz=\"0 0 1\"/><limit lower=\"-1\" upper=\"1\" effort=\"1\" "
                           "velocity=\"1\"/></joint></robot>\n";
  const std::string urdf = write(dir + "/amp.urdf", text);
  const ChildRun r = run({"convert", urdf, dir + "/out.yaml"});
  EXPECT_FALSE(r.killed);
  // Either refused (a robot name that is no identifier) or converted: one line, no crash.
  EXPECT_TRUE(r.exit_code == 0 || r.exit_code == 2) << r.err;
  if (r.exit_code == 2) EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
}

// H3: /dev/zero (and a FIFO nobody writes) as an input file read until memory
// ran out (or waited for ever).
TEST(Hostile, DevicesAndFifosAreNotRead) {
  const std::string dir = scratch("devices");
  const std::string model = source_path("data/devices/baser-7dof.yaml");
  expect_refused(run({"evaluate", "--model", "/dev/zero", "--log", good_log()}),
                 "is not a regular file", "--model /dev/zero");
  expect_refused(run({"evaluate", "--model", model, "--log", "/dev/zero"}), "is not a regular file",
                 "--log /dev/zero");
  expect_refused(run({"calibrate", "--model", model, "--log", good_log(), "--fixture", "/dev/zero",
                      "--out", dir + "/out"}),
                 "is not a regular file", "--fixture /dev/zero");
  const std::string fifo = dir + "/fifo.csv";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  expect_refused(run({"evaluate", "--model", model, "--log", fifo}), "is not a regular file",
                 "--log FIFO");
  const std::string scenario =
      write(dir + "/scenario.yaml",
            "format: hapticcal-scenario/1\ndevice: /dev/zero\nmeasurement: position\n");
  expect_refused(run({"simulate", "--scenario", scenario, "--out", dir + "/sim"}),
                 "is not a regular file", "scenario device: /dev/zero");
}

// E4: a 16 MB device file peaked at 3.9 GB; E3: a polynomial of 10^6
// coefficients loaded and failed 42 s later without a file, line or key.
TEST(Hostile, LargeDeviceFilesAndPolynomialsAreBounded) {
  const std::string dir = scratch("large");
  std::string big = "format: hapticcal-device/1\nname: big\n# ";
  big += std::string(16 << 20, 'x');
  big += "\n";
  expect_refused(run({"convert", write(dir + "/big.yaml", big), dir + "/big.urdf"}),
                 "more than the 256 KiB a device file may have", "16 MB device file");
  std::string text = testing::slurp(source_path("data/devices/baser-7dof.yaml"));
  // j4's polynomial, with 100 coefficients.
  const size_t at = text.find("coefficients: [");
  ASSERT_NE(at, std::string::npos);
  const size_t end = text.find(']', at);
  std::string coefficients = "coefficients: [0";
  for (int k = 1; k < 100; ++k) coefficients += ", 0";
  text.replace(at, end - at, coefficients);
  const std::string path = write(dir + "/long.yaml", text);
  const ChildRun r = run({"convert", path, dir + "/long.urdf"});
  expect_refused(r, "100 coefficients: at most 31", "100 coefficients");
  EXPECT_NE(r.err.find(path + ":"), std::string::npos) << r.err;                   // the file,
  EXPECT_NE(r.err.find("transmission.coefficients"), std::string::npos) << r.err;  // the key
}

// Deliver 2: each parser at its file kind's limit, with the input that costs
// it the most memory - yaml-cpp: a dense flow list (a node every 2 bytes);
// tinyxml + urdfdom: tiny elements, or a chain of 27,000 fixed joints; the log
// reader: short rows - ends in a result or one line, never a crash (also under
// AddressSanitizer: the test is labelled sanitize) and, outside it, within the
// docs/development.md's figures: under 200 MB for every YAML file and URDF at its limit, and
// for a log 64 MB plus 8 bytes per byte through evaluate (measured: 5-6, the
// reader's values, the errors, the report's data).
TEST(Hostile, EachParserAtItsLimitStaysWithinItsStatedMemory) {
  const std::string dir = scratch("limit");
  const std::string model = source_path("tests/malformed/good-2dof.yaml");
  // `head`, then a key the format does not know holding a flow list of zeros,
  // to just under the kind's limit.
  auto dense = [&](const std::string& name, std::string head, FileKind kind) {
    head += "junk: [0";
    while (head.size() + 8 < max_file_bytes(kind)) head += ",0";
    head += "]\n";
    return write(dir + "/" + name, head);
  };
  struct Case {
    std::string what;
    std::vector<std::string> args;
    int exit_code;
    std::string says;  // on stderr
  };
  std::vector<Case> cases;
  cases.push_back({"device file, dense",
                   {"convert", dense("device.yaml", testing::slurp(model), FileKind::kDevice),
                    dir + "/device.urdf"},
                   2,
                   "junk: unknown key"});
  std::string padded = testing::slurp(model);
  while (padded.size() + 100 < max_file_bytes(FileKind::kDevice)) {
    padded += "# " + std::string(76, 'x') + "\n";
  }
  cases.push_back({"device file, comments",
                   {"convert", write(dir + "/padded.yaml", padded), dir + "/padded.urdf"},
                   0,
                   ""});
  cases.push_back(
      {"fixture file, dense",
       {"calibrate", "--model", model, "--log", source_path("tests/malformed/good-2dof-points.csv"),
        "--fixture", dense("fixture.yaml", "points:\n  a: [0, 0, 0]\n", FileKind::kFixture),
        "--out", dir + "/fixture-out"},
       2,
       "junk"});
  cases.push_back({"scenario, dense",
                   {"simulate", "--scenario",
                    dense("scenario.yaml", "format: hapticcal-scenario/1\n", FileKind::kScenario),
                    "--out", dir + "/sim"},
                   2,
                   "junk"});
  const std::string chain =
      "<link name=\"l1\"/><link name=\"tip\"/>"
      "<joint name=\"j1\" type=\"revolute\"><parent link=\"base\"/><child link=\"l1\"/>"
      "<origin xyz=\"0 0 0.1\"/><axis xyz=\"0 0 1\"/>"
      "<limit lower=\"-1\" upper=\"1\" effort=\"1\" velocity=\"1\"/></joint>"
      "<joint name=\"j2\" type=\"revolute\"><parent link=\"l1\"/><child link=\"tip\"/>"
      "<origin xyz=\"0.2 0 0\"/><axis xyz=\"0 1 0\"/>"
      "<limit lower=\"-1\" upper=\"1\" effort=\"1\" velocity=\"1\"/></joint>\n";
  std::string tiny = "<robot name=\"r\"><link name=\"base\">";
  while (tiny.size() + chain.size() + 64 < max_file_bytes(FileKind::kUrdf)) {
    tiny += "<a x=\"1\" y=\"2\"/>";
  }
  tiny += "</link>" + chain + "</robot>\n";
  cases.push_back({"URDF, tiny elements",
                   {"convert", write(dir + "/tiny.urdf", tiny), dir + "/tiny.yaml", "--tip", "tip"},
                   0,
                   ""});
  std::string deep = "<robot name=\"r\"><link name=\"base\"/>" + chain;
  std::string parent = "tip";
  for (int k = 0; deep.size() + 200 < max_file_bytes(FileKind::kUrdf); ++k) {
    deep += fmt::format(
        "<link name=\"c{0}\"/><joint name=\"g{0}\" type=\"fixed\"><parent link=\"{1}\"/>"
        "<child link=\"c{0}\"/></joint>\n",
        k, parent);
    parent = fmt::format("c{}", k);
  }
  deep += "</robot>\n";
  cases.push_back({"URDF, a chain of fixed joints below the tip",
                   {"convert", write(dir + "/deep.urdf", deep), dir + "/deep.yaml", "--tip", "tip"},
                   0,
                   ""});
  for (const Case& c : cases) {
    const ChildRun r = run(c.args);
    std::printf("%-45s exit %d, peak %.1f MB\n", c.what.c_str(), r.exit_code, r.peak_kib / 1024.0);
    EXPECT_FALSE(r.killed) << c.what;
    EXPECT_EQ(r.exit_code, c.exit_code) << c.what << ": " << r.err;
    if (c.exit_code == 2) {
      EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << c.what << ": " << r.err;
      EXPECT_NE(r.err.find(c.says), std::string::npos) << c.what << ": " << r.err;
    }
#ifndef HAPTICCAL_ASAN
    EXPECT_LT(r.peak_kib, 200 * 1024) << c.what;
#endif
  }
  // A log of 500,000 short rows (10.5 MB) through evaluate.
  const std::string log = dir + "/long.csv";
  {
    std::ofstream out(log);
    out << "q1,q2,x,y,z\n";
    for (int k = 0; k < 500000; ++k) out << "0.1,0.2,0.3,0.05,0.1\n";
  }
  const double bytes = static_cast<double>(fs::file_size(log));
  const ChildRun r = run({"evaluate", "--model", model, "--log", log, "--out", dir + "/ev"});
  std::printf("%-45s %8.0f bytes: exit %d, peak %.1f MB (%.1f bytes a byte)\n", "log, short rows",
              bytes, r.exit_code, r.peak_kib / 1024.0, r.peak_kib * 1024.0 / bytes);
  EXPECT_FALSE(r.killed);
  EXPECT_EQ(r.exit_code, 0) << r.err;
#ifndef HAPTICCAL_ASAN
  EXPECT_LT(r.peak_kib * 1024.0, 64e6 + 8 * bytes);
#endif
}

// C2, S3: an unwritable stderr or stdout ended in SIGABRT (an exception thrown
// from a catch block) or in exit 0 with the output lost.
TEST(Hostile, UnwritableStreamsEndInExitOneNotAbort) {
  const std::string dir = scratch("streams");
  const std::string model = source_path("data/devices/baser-7dof.yaml");
  const Stream full{Stream::kPath, "/dev/full"}, closed{Stream::kClosed, ""};
  for (const Stream& err : {full, closed}) {
    const std::string how = err.kind == Stream::kClosed ? "stderr closed" : "stderr /dev/full";
    // Bad input: the message cannot be written, the exit code still says it.
    const ChildRun bad =
        run({"evaluate", "--model", dir + "/missing.yaml", "--log", good_log()}, {}, err);
    EXPECT_EQ(bad.exit_code, 2) << how;
    // A success that prints a warning (convert of a model with transmissions).
    const ChildRun warned = run({"convert", model, dir + "/out.urdf"}, {}, err);
    EXPECT_EQ(warned.exit_code, 1) << how;
  }
  // stdout on a full disk: evaluate's JSON, its plain lines, and --help.
  const std::string log = source_path("examples/meca500/val-norm_dist_data_0deg_160cube.csv");
  const std::string meca = source_path("examples/meca500/meca500.yaml");
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"evaluate", "--model", meca, "--log", log, "--json"},
        std::vector<std::string>{"evaluate", "--model", meca, "--log", log, "--out",
                                 dir + "/evaluate"},
        std::vector<std::string>{"--help"}}) {
    const ChildRun r = run(args, full);
    EXPECT_EQ(r.exit_code, 1) << args[0] << " " << args.back() << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find("cannot write the standard output"), std::string::npos) << r.err;
  }
}

// S1: a file the user saves into --out while a run goes on is theirs: the run
// does not replace the folder, and says where its outputs are.
TEST(Hostile, AFileSavedIntoOutDuringARunSurvives) {
  const std::string dir = scratch("saved");
  const std::string out = dir + "/results";
  std::string staging;
  {
    OutputSet set(out, "evaluate");
    staging = set.dir();
    write_file_atomically(set.dir() + "/results.json", "{}\n");
    write(out + "/notes.txt", "mine\n");  // saved by the user meanwhile
    try {
      set.commit();
      ADD_FAILURE() << "commit replaced a folder holding the user's file";
    } catch (const IoError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("saved there while this run went on"), std::string::npos) << what;
      EXPECT_NE(what.find("it was not replaced"), std::string::npos) << what;
      EXPECT_NE(what.find(staging), std::string::npos) << what;  // where the outputs are
    }
  }
  EXPECT_EQ(testing::slurp(out + "/notes.txt"), "mine\n");
  EXPECT_TRUE(fs::exists(staging + "/results.json"));  // the new set, kept for the user
}

// S2: a user's folder named like a staging folder is not swept.
TEST(Hostile, AUserFolderNamedLikeStagingSurvives) {
  const std::string dir = scratch("sweep");
  const std::string mine = dir + "/.results.tmp-mybackup";
  write(mine + "/keep.txt", "mine\n");
  const std::string mine6 = dir + "/.results.tmp-abcdef";  // even with six characters
  write(mine6 + "/keep.txt", "mine\n");
  const ChildRun r =
      run({"evaluate", "--model", source_path("examples/meca500/meca500.yaml"), "--log",
           source_path("examples/meca500/val-norm_dist_data_0deg_160cube.csv"), "--out",
           dir + "/results"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(testing::slurp(mine + "/keep.txt"), "mine\n");
  EXPECT_EQ(testing::slurp(mine6 + "/keep.txt"), "mine\n");
}

// S4: a distance of 1e308 gave exit 0 with "rms_distance": null.
TEST(Hostile, AnOverflowingErrorIsBadInputNotNull) {
  const std::string dir = scratch("overflow");
  std::string csv = testing::slurp(good_log());
  // good-2dof.csv: q1,q2,x,y,z - a distance column instead.
  const std::string log = write(dir + "/d.csv", "q1,q2,distance\n0.1,0.2,0.3\n0.2,0.1,1e308\n");
  const ChildRun r = run({"evaluate", "--model", source_path("tests/malformed/good-2dof.yaml"),
                          "--log", log, "--json"});
  expect_refused(r, ":3:", "distance 1e308");
}

// E1: ext1 = 1e308 on line 7: glog dumped ~20 KB, then a message naming line 2.
TEST(Hostile, AnEncoderReadingOf1e308IsNamedByLineAndColumn) {
  const std::string dir = scratch("ext");
  std::string csv = "q1,q2,ext1,x,y,z\n";
  for (int k = 0; k < 12; ++k) {
    csv += fmt::format("{},{},{},{},{},{}\n", 0.1 * k - 0.5, 0.05 * k,
                       k == 5 ? 1e308 : 0.1 * k - 0.5, 0.3 + 0.01 * k, 0.02 * k, 0.1);
  }
  const std::string log = write(dir + "/ext.csv", csv);
  expect_refused(run({"calibrate", "--model", source_path("tests/malformed/good-2dof.yaml"),
                      "--log", log, "--out", dir + "/out"}),
                 "ext.csv:7: ext1: 1e+308 is not an encoder reading", "ext1 = 1e308");
}

// E5, E6, E8: messages stay one printable line.
TEST(Hostile, MessagesAreOnePrintableLine) {
  const std::string dir = scratch("messages");
  // A newline inside an argument (CLI11's own error).
  expect_refused(run({"evaluate", "--model", "a\nb.yaml", "--log", good_log(), "--bogus\nx"}),
                 "hapticcal: ", "newline in an argument");
  // A binary file read as YAML: no raw invalid UTF-8 byte in the message.
  std::string binary = "format: \xff\xfe\x80\x81\n\x01\x02\x03";
  const ChildRun bin = run({"convert", write(dir + "/binary.yaml", binary), dir + "/b.urdf"});
  EXPECT_EQ(bin.exit_code, 2) << bin.err;
  for (const char c : bin.err) {
    EXPECT_TRUE(static_cast<unsigned char>(c) < 0x80) << "a raw byte in: " << bin.err;
  }
  // force --posture nan named, not "singular".
  const std::string device = source_path("data/devices/baser-7dof.yaml");
  expect_refused(run({"force", "--actual", device, "--nominal", device, "--calibrated", device,
                      "--posture", "0,0,0,0,0,nan,0", "--out", dir + "/force"}),
                 "give a finite number", "--posture nan");
  // --fix X --free X.
  expect_refused(run({"calibrate", "--model", source_path("examples/meca500/meca500.yaml"), "--log",
                      source_path("examples/meca500/cal-norm_dist_data_0deg_160cube.csv"), "--fix",
                      "j2.a", "--free", "j2.a", "--out", dir + "/cal"}),
                 "given to both --fix and --free", "--fix X --free X");
  // A UTF-8 byte-order mark before a header: visible in the message.
  const ChildRun bom =
      run({"evaluate", "--model", source_path("tests/malformed/good-2dof.yaml"), "--log",
           write(dir + "/bom.csv", "\xef\xbb\xbfq1,q2,x,y,z\n0,0,0,0,0\n")});
  if (bom.exit_code == 2) EXPECT_NE(bom.err.find("\\xef\\xbb\\xbf"), std::string::npos) << bom.err;
}

// One simulate trial of a position scenario on the device file `text`, written
// as dir/name.
ChildRun simulate_device(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string path = write(dir + "/" + name, text);
  const std::string scenario =
      write(dir + "/scenario.yaml", "format: hapticcal-scenario/1\ndevice: " + path +
                                        "\nmeasurement: position\nposes: {identification: 40, "
                                        "validation: 10}\n");
  return run({"simulate", "--scenario", scenario, "--trials", "1", "--out", dir + "/sim"});
}

// The simulation study has no approach sides (its validation, trajectories and
// fixtures): a scenario's device with backlash is refused, naming the link.
TEST(Hostile, SimulateRefusesADeviceWithBacklash) {
  const std::string dir = scratch("simulate_backlash");
  std::string device = testing::slurp(source_path("data/devices/baser-7dof.yaml"));
  const size_t format = device.find("hapticcal-device/1");
  ASSERT_NE(format, std::string::npos);
  device.replace(format, 18, "hapticcal-device/2");
  const size_t at = device.find("limits: [");
  ASSERT_NE(at, std::string::npos);
  const size_t end = device.find(']', at) + 1;
  device.insert(end, "\n    backlash: 1e-3");
  const ChildRun r = simulate_device(dir, "play.yaml", device);
  expect_refused(r, "the simulation study does not model backlash", "backlash");
  EXPECT_NE(r.err.find("links[0].backlash"), std::string::npos) << r.err;
}

// E2: a scenario's device with limits of +-1e308 overflowed simulate's own log
// into inf, and the failure named a staging file that was gone.
TEST(Hostile, SimulateRefusesLimitsItCannotDrawFrom) {
  const std::string dir = scratch("simulate_limits");
  std::string device = testing::slurp(source_path("data/devices/baser-7dof.yaml"));
  const size_t at = device.find("limits: [");
  ASSERT_NE(at, std::string::npos);
  device.replace(at, device.find(']', at) + 1 - at, "limits: [-1e308, 1e308]");
  const ChildRun r = simulate_device(dir, "wide.yaml", device);
  expect_refused(r, "a simulation draws readings within the limits", "limits +-1e308");
  EXPECT_NE(r.err.find("wide.yaml"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find(".tmp-"), std::string::npos) << r.err;  // no staging file named
}

// C3 and the library's own checks: what the command line refuses, the library
// refuses for every caller (Python passed dependency_tolerance=1.0: a segfault).
TEST(Hostile, TheLibraryValidatesItsOptions) {
  const DeviceModel model = testing::meca500();
  const Log log = testing::meca500_log("cal", "norm_dist_data_0deg_160cube");
  for (double tolerance : {1.0, std::numeric_limits<double>::infinity(), 0.0,
                           std::numeric_limits<double>::quiet_NaN()}) {
    CalibrationOptions options;
    options.dependency_tolerance = tolerance;
    EXPECT_THROW(calibrate(model, log, options), InputError) << tolerance;
  }
  // A NUL in a file name named another file (c_str() cut it).
  const std::string name = source_path("examples/meca500/meca500.yaml") + std::string("\0junk", 5);
  EXPECT_THROW(load_model(name, "", ""), InputError);
}

// E7: a URDF whose joints form a loop is refused before urdfdom reads it (which
// leaked the loop's links: LeakSanitizer in the instrumented build, no
// suppression here).
TEST(Hostile, AJointLoopIsRefusedBeforeUrdfdom) {
  const std::string text =
      "<robot name=\"r\"><link name=\"w\"/><link name=\"a\"/><link name=\"b\"/>"
      "<joint name=\"j0\" type=\"fixed\"><parent link=\"w\"/><child link=\"a\"/></joint>"
      "<joint name=\"j1\" type=\"fixed\"><parent link=\"a\"/><child link=\"b\"/></joint>"
      "<joint name=\"j2\" type=\"fixed\"><parent link=\"b\"/><child link=\"a\"/></joint></robot>";
  for (int k = 0; k < 3; ++k) {
    try {
      parse_urdf(text, "loop.urdf", "b", "");
      ADD_FAILURE() << "a loop of joints was read";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("the joints form a loop"), std::string::npos)
          << e.what();
    }
  }
}

// Hostile values in a tracker's stream where the glitch screen, the time checks
// and the coarse search read them (also under the sanitizers): screened
// samples or a clear refusal, never a crash or an out-of-range conversion.
TEST(Hostile, TrackerStreamsWithExtremeValues) {
  const DeviceModel touch = testing::builtin("geomagic-touch");
  SessionOptions o;
  o.seconds = 20;
  o.dropout_share = 0.05;
  const Session s = simulate_session(touch, o, 3);
  const auto search = [&](const Log& device, const Log& tracker) {
    try {
      check_streams(device, tracker);
      coarse_clock_offset(touch, device, tracker, 10);
      return std::string();
    } catch (const InputError& e) {
      return std::string(e.what());
    }
  };
  for (const double v : {1e308, -1e308, 1e-308, 5e307}) {
    Log t = s.tracker;
    t.position(100, 1) = v;
    t.position(101, 2) = -v;
    const std::vector<int> glitches = tracker_glitches(t);
    const Log kept = without_rows(t, glitches);
    EXPECT_EQ(kept.rows + static_cast<int>(glitches.size()), t.rows);
    EXPECT_EQ(kept.line.size(), static_cast<size_t>(kept.rows));
    if (std::abs(v) > 1) {
      EXPECT_TRUE(std::find(glitches.begin(), glitches.end(), 100) != glitches.end()) << v;
      EXPECT_EQ(search(s.device, kept), "") << v;
    }
  }
  // A stream without noise: no sample flagged but a glitch.
  SessionOptions exact = o;
  exact.sigma_position = 0;
  Log clean = simulate_session(touch, exact, 4).tracker;
  EXPECT_TRUE(tracker_glitches(clean).empty());
  clean.position(200, 0) += 0.05;
  EXPECT_EQ(tracker_glitches(clean), std::vector<int>{200});
  // Every other sample far off (more than 1 % glitches): kept, the search refuses.
  Log flicker = s.tracker;
  for (int r = 0; r < flicker.rows; r += 2) flicker.position(r, 0) = 1e300;
  EXPECT_TRUE(tracker_glitches(flicker).empty());
  EXPECT_NE(search(s.device, flicker), "");
  // Times: a jump of 1e6 s (1e300 s: no longer increasing), milliseconds, three samples.
  Log jump = s.tracker;
  for (int r = jump.rows / 2; r < jump.rows; ++r) jump.t[r] += 1e6;
  EXPECT_NE(search(s.device, jump).find("span"), std::string::npos) << search(s.device, jump);
  for (int r = jump.rows / 2; r < jump.rows; ++r) jump.t[r] += 1e300;
  EXPECT_NE(search(s.device, jump).find("must increase"), std::string::npos);
  Log ms = s.device;
  ms.t *= 1e3;
  EXPECT_NE(search(ms, s.tracker).find("t [ms]"), std::string::npos);
  const Log three = without_rows(s.tracker, [&] {
    std::vector<int> all;
    for (int r = 3; r < s.tracker.rows; ++r) all.push_back(r);
    return all;
  }());
  EXPECT_TRUE(tracker_glitches(three).empty());
  EXPECT_NE(search(s.device, three).find("samples"), std::string::npos);
}

}  // namespace
}  // namespace hapticcal
