// The command line's errors help: numeric ranges read as numbers, a log
// without a header (or a header beside --columns) says so and what to do, an
// unknown parameter name suggests the closest one, and a bare `hapticcal`
// points to --help. Each is exit code 2 and one line "hapticcal: <message>".
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "hapticcal/core/error.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/model_io/model_source.hpp"
#include "run_cli.hpp"
#include "test_models.hpp"

namespace hapticcal {
namespace {

std::string malformed(const std::string& file) {
  return testing::source_path("tests/malformed/" + file);
}

// --seed once printed "Value -1 not in range 0.000000 to 1797693...(309
// digits).000000": CLI11's NonNegativeNumber with the largest double.
TEST(CliErrors, NumericRangesReadAsNumbers) {
  const testing::CliResult trials = testing::run_cli("simulate --trials 0");
  testing::expect_input_error(trials, "");
  EXPECT_EQ(trials.err, "hapticcal: --trials: 0 is outside [1, 100000]\n");
  const testing::CliResult seed = testing::run_cli("simulate --seed -1");
  testing::expect_input_error(seed, "");
  EXPECT_EQ(seed.err, "hapticcal: --seed: -1 is less than 0\n");
  testing::expect_input_error(testing::run_cli("simulate --trials 1.5"),
                              "--trials: '1.5' is not a whole number");
  const std::string calibrate =
      "calibrate --model " + malformed("good-2dof.yaml") + " --log " + malformed("good-2dof.csv");
  testing::expect_input_error(testing::run_cli(calibrate + " --polynomial-order 0"),
                              "--polynomial-order: 0 is outside [1, 30]");
  testing::expect_input_error(testing::run_cli(calibrate + " --dependency-tolerance 1"),
                              "--dependency-tolerance: 1 is outside [1e-12, 0.5]");
  testing::expect_input_error(testing::run_cli(calibrate + " --seed -3"),
                              "--seed: -3 is less than 0");
  testing::expect_input_error(testing::run_cli("plan --model " + malformed("good-2dof.yaml") +
                                               " --measurement position --poses 0"),
                              "--poses: 0 is outside [1, 100000]");
  testing::expect_input_error(
      testing::run_cli("force --actual a --nominal b --calibrated c --seed -1"),
      "--seed: -1 is less than 0");
  // No range anywhere in the help prints a double's digits.
  for (const char* command : {"simulate", "calibrate", "evaluate", "force", "plan", "convert"}) {
    SCOPED_TRACE(command);
    const testing::CliResult help = testing::run_cli(std::string(command) + " --help");
    EXPECT_EQ(help.exit_code, 0);
    EXPECT_EQ(help.out.find("179769"), std::string::npos) << help.out;
    EXPECT_EQ(help.out.find(".000000"), std::string::npos) << help.out;
  }
}

TEST(CliErrors, LogWithoutHeaderAsksForColumns) {
  const std::string dir = testing::fresh_folder("cli_errors_no_header");
  std::ofstream(dir + "/log.csv") << "9.972280355,0.2,0.3,0.05,0.1\n0.1,0.2,0.3,0.05,0.1\n";
  const testing::CliResult r = testing::run_cli(std::vector<std::string>{
      "evaluate", "--model", malformed("good-2dof.yaml"), "--log", dir + "/log.csv"});
  testing::expect_input_error(r, "log.csv:1: the log has no header");
  EXPECT_NE(r.err.find("give its 5 column names with --columns q1,q2,...,x"), std::string::npos)
      << r.err;
  // With the names given, the same log is read.
  EXPECT_EQ(testing::run_cli(std::vector<std::string>{"evaluate", "--model",
                                                      malformed("good-2dof.yaml"), "--log",
                                                      dir + "/log.csv", "--columns", "q1,q2,x,y,z"})
                .exit_code,
            0);
  std::filesystem::remove_all(dir);
}

TEST(CliErrors, HeaderBesideColumnsSaysDropColumns) {
  const std::string dir = testing::fresh_folder("cli_errors_header_and_columns");
  std::ofstream(dir + "/log.csv") << "q1[deg],q2[deg],x,y,z\n0,0,0.35,0,0.1\n";
  testing::expect_input_error(
      testing::run_cli(std::vector<std::string>{"evaluate", "--model", malformed("good-2dof.yaml"),
                                                "--log", dir + "/log.csv", "--columns",
                                                "q1[deg],q2[deg],x,y,z"}),
      "log.csv:1: the log has a header line; drop --columns (or remove the header)");
  // A headerless log with labels (words in a data row) is no header.
  std::ofstream(dir + "/points.csv") << "0,0,a\n0.1,0.1,a\n0.2,0.2,b\n0.3,0.1,b\n";
  const testing::CliResult points = testing::run_cli(
      std::vector<std::string>{"evaluate", "--model", malformed("good-2dof.yaml"), "--log",
                               dir + "/points.csv", "--columns", "q1,q2,point"});
  EXPECT_EQ(points.err.find("header"), std::string::npos) << points.err;
  // A data row with a word where a number belongs stays "not a number".
  std::ofstream(dir + "/word.csv") << "abc,0,0.35,0,0.1\n";
  testing::expect_input_error(testing::run_cli(std::vector<std::string>{
                                  "evaluate", "--model", malformed("good-2dof.yaml"), "--log",
                                  dir + "/word.csv", "--columns", "q1,q2,x,y,z"}),
                              "word.csv:1: q1: 'abc' is not a number");
  std::filesystem::remove_all(dir);
}

TEST(CliErrors, UnknownParameterSuggestsTheClosest) {
  const std::string dir = testing::fresh_folder("cli_errors_fix");
  const std::vector<std::string> calibrate{
      "calibrate", "--model",   malformed("good-2dof.yaml"), "--log", malformed("good-2dof.csv"),
      "--out",     dir + "/out"};
  auto with = [&](const std::string& option, const std::string& value) {
    std::vector<std::string> args = calibrate;
    args.insert(args.end(), {option, value});
    return testing::run_cli(args);
  };
  testing::expect_input_error(
      with("--fix", "j1.alfa"),
      "--fix: 'j1.alfa' is not a kinematic parameter of model 'two-link' (did you "
      "mean 'j1.alpha'?)");
  testing::expect_input_error(with("--free", "j2.bta"),
                              "--free: 'j2.bta' is not a kinematic parameter of "
                              "model 'two-link' (did you mean 'j2.beta'?)");
  // Nothing close: no guess.
  const testing::CliResult far = with("--fix", "stiffness");
  testing::expect_input_error(far, "--fix: 'stiffness' is not a kinematic parameter");
  EXPECT_EQ(far.err.find("did you mean"), std::string::npos) << far.err;
  std::filesystem::remove_all(dir);
}

TEST(CliErrors, EditDistanceIsLevenshtein) {
  EXPECT_EQ(edit_distance("kitten", "sitting"), 3u);
  EXPECT_EQ(edit_distance("", "abc"), 3u);
  EXPECT_EQ(edit_distance("j1.alfa", "j1.alpha"), 2u);
  EXPECT_EQ(edit_distance("j1.a", "j1.a"), 0u);
  EXPECT_EQ(did_you_mean("j1.thta", {"j1.a", "j1.theta", "j2.theta"}),
            " (did you mean 'j1.theta'?)");
  EXPECT_EQ(did_you_mean("j1.theta", {"j1.theta"}), "");
  EXPECT_EQ(did_you_mean("abc", {"xyzuvw"}), "");
}

// Built-in devices by name (issue 26, item 1): `hapticcal devices` lists them,
// a name loads the device's file wherever a model file is taken (a file of
// that name in the folder wins), and convert writes one as URDF.
// An installed program (PREFIX/bin/hapticcal beside PREFIX/share/hapticcal/
// devices, as `cmake --install` lays them out) lists and reads its installed
// devices, not the source tree's; the build tree's program the source tree's.
TEST(CliErrors, AnInstalledProgramListsItsInstalledDevices) {
  namespace fs = std::filesystem;
  const std::string prefix = testing::fresh_folder("installed_prefix");
  fs::create_directories(prefix + "/bin");
  fs::copy_file(HAPTICCAL_CLI, prefix + "/bin/hapticcal");
  fs::create_directories(prefix + "/share/hapticcal");
  fs::copy(testing::source_path("data/devices"), prefix + "/share/hapticcal/devices");
  const testing::CliResult installed = testing::run_program(prefix + "/bin/hapticcal", "devices");
  EXPECT_EQ(installed.exit_code, 0) << installed.err;
  EXPECT_NE(installed.out.find(prefix + "/share/hapticcal/devices/geomagic-touch.yaml"),
            std::string::npos)
      << installed.out;
  EXPECT_EQ(installed.out.find(testing::source_path("data/devices")), std::string::npos)
      << installed.out;
  const testing::CliResult built = testing::run_cli("devices");
  EXPECT_NE(built.out.find(testing::source_path("data/devices/geomagic-touch.yaml")),
            std::string::npos)
      << built.out;
}

TEST(CliErrors, BuiltInDevicesAreListedAndUsableByName) {
  const testing::CliResult list = testing::run_cli("devices");
  EXPECT_EQ(list.exit_code, 0) << list.err;
  EXPECT_NE(list.out.find("baser-7dof             7 joints"), std::string::npos) << list.out;
  EXPECT_NE(list.out.find("phantom-premium-1.5    6 joints"), std::string::npos) << list.out;
  for (const BuiltinDevice& d : builtin_devices()) {
    const DeviceModel by_name = load_model(d.name);
    const DeviceModel by_file = load_device(d.path);
    EXPECT_EQ(by_name.kinematic_parameters(), by_file.kinematic_parameters()) << d.name;
  }
  EXPECT_EQ(resolve_model_path("baser-7dof"), builtin_device_path());
  EXPECT_THROW(load_model("no-such-device"), InputError);
  const std::string dir = testing::fresh_folder("builtin_by_name");
  EXPECT_NE(list.out.find("geomagic-touch         6 joints"), std::string::npos) << list.out;
  EXPECT_NE(list.out.find("dvrk-mtm               7 joints"), std::string::npos) << list.out;
  for (const BuiltinDevice& d : builtin_devices()) {
    const testing::CliResult converted =
        testing::run_cli_in(dir, {"convert", d.name, d.name + ".urdf"});
    EXPECT_EQ(converted.exit_code, 0) << converted.err;
    EXPECT_EQ(load_model(dir + "/" + d.name + ".urdf").dof(), load_model(d.name).dof()) << d.name;
  }
  // A file of a built-in's name is the user's: it is read, not the built-in.
  std::ofstream(dir + "/baser-7dof") << "not a device\n";
  const testing::CliResult own = testing::run_cli_in(dir, {"convert", "baser-7dof", "b.urdf"});
  EXPECT_EQ(own.exit_code, 2) << own.out;
  // A folder of a built-in's name (a run's --out geomagic-touch) is no model:
  // the name still loads the built-in.
  std::filesystem::create_directories(dir + "/geomagic-touch");
  const testing::CliResult shadowed =
      testing::run_cli_in(dir, {"convert", "geomagic-touch", "touch.urdf"});
  EXPECT_EQ(shadowed.exit_code, 0) << shadowed.err;
  EXPECT_EQ(load_model(dir + "/touch.urdf").dof(), 6);
  // A scenario names a built-in device by name, from any folder; a file
  // beside the scenario of that name is the scenario's.
  const std::string scenarios = dir + "/scenarios";
  std::filesystem::create_directories(scenarios);
  std::ofstream(scenarios + "/touch.yaml")
      << "format: hapticcal-scenario/1\ndevice: geomagic-touch\nmeasurement: position\n"
         "poses: {identification: 60, validation: 20}\n";
  const testing::CliResult scenario = testing::run_cli_in(
      dir, {"simulate", "--scenario", scenarios + "/touch.yaml", "--out", dir + "/sim"});
  EXPECT_EQ(scenario.exit_code, 0) << scenario.err;
  EXPECT_NE(scenario.out.find(builtin_device_file("geomagic-touch")), std::string::npos)
      << scenario.out;
  std::ofstream(scenarios + "/geomagic-touch") << "not a device\n";
  const testing::CliResult beside = testing::run_cli_in(
      dir, {"simulate", "--scenario", scenarios + "/touch.yaml", "--out", dir + "/sim"});
  EXPECT_EQ(beside.exit_code, 2) << beside.out;
  EXPECT_NE(beside.err.find(scenarios + "/geomagic-touch"), std::string::npos) << beside.err;
}

// A xacro file (named .urdf.xacro, or a .urdf still holding xacro macros) is one
// line saying to expand it, not urdfdom's "Unable to parse component [${d1}]"
// or "--tip: applies to URDF models".
TEST(CliErrors, AXacroFileSaysToExpandItFirst) {
  const std::string dir = testing::fresh_folder("cli_errors_xacro");
  const std::string xacro =
      "<?xml version=\"1.0\"?>\n<robot name=\"arm\" "
      "xmlns:xacro=\"http://www.ros.org/wiki/xacro\">\n"
      "  <xacro:property name=\"d1\" value=\"0.2\"/>\n  <link name=\"base\"/>\n  <link "
      "name=\"tool\"/>\n"
      "  <joint name=\"j1\" type=\"revolute\"><parent link=\"base\"/><child link=\"tool\"/>\n"
      "    <origin xyz=\"0 0 ${d1}\"/><axis xyz=\"0 0 1\"/><limit lower=\"-1\" upper=\"1\" "
      "effort=\"1\" "
      "velocity=\"1\"/></joint>\n</robot>\n";
  for (const std::string name : {"arm.urdf.xacro", "arm.urdf"}) {
    SCOPED_TRACE(name);
    std::ofstream(dir + "/" + name) << xacro;
    for (const std::vector<std::string>& args :
         {std::vector<std::string>{"calibrate", "--model", dir + "/" + name, "--tip", "tool",
                                   "--log", dir + "/none.csv"},
          {"evaluate", "--model", dir + "/" + name, "--tip", "tool", "--log", dir + "/none.csv"},
          {"convert", dir + "/" + name, dir + "/arm.yaml"}}) {
      const testing::CliResult r = testing::run_cli(args);
      testing::expect_input_error(r, "expand it with xacro first");
      EXPECT_NE(r.err.find(name), std::string::npos) << r.err;
    }
  }
}

// Every command's --help ends with two examples.
TEST(CliErrors, EachCommandsHelpEndsWithTwoExamples) {
  for (const char* command :
       {"calibrate", "evaluate", "simulate", "plan", "force", "convert", "import", "devices"}) {
    SCOPED_TRACE(command);
    const testing::CliResult r = testing::run_cli(std::vector<std::string>{command, "--help"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const std::size_t at = r.out.rfind("Examples:\n");
    ASSERT_NE(at, std::string::npos) << r.out;
    std::istringstream tail(r.out.substr(at + 10));
    std::vector<std::string> lines;
    for (std::string line; std::getline(tail, line);)
      if (!line.empty()) lines.push_back(line);
    ASSERT_EQ(lines.size(), 2u) << r.out.substr(at);
    for (const std::string& line : lines)
      EXPECT_EQ(line.rfind(std::string("  hapticcal "), 0), 0u) << line;
  }
}

TEST(CliErrors, BareCommandPointsToHelp) {
  const testing::CliResult r = testing::run_cli(std::vector<std::string>{});
  testing::expect_input_error(r, "");
  EXPECT_EQ(r.err,
            "hapticcal: give a command (calibrate, evaluate, simulate, plan, force, convert, "
            "import, compensate, devices); see "
            "hapticcal --help\n");
}

}  // namespace
}  // namespace hapticcal
