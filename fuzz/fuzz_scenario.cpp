// libFuzzer target: scenario files (hapticcal::load_scenario). load_scenario
// reads a path, so each input is written to scenario.yaml in a scratch
// directory ($TMPDIR) made once per process; the device files of data/devices
// are copied beside it so that a relative `device:` can name them (or
// scenario.yaml itself). The default device is the built-in 7-DOF.
// (A device of fewer than 4 joints is left out until paper_actual_device stops
// writing past its links: fuzz/findings/README.md.) Bad input must end in hapticcal::InputError;
// any other exception, a crash, a sanitizer report or a hang is a finding.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "hapticcal/core/error.hpp"
#include "hapticcal/study/study.hpp"

namespace {

namespace fs = std::filesystem;

struct ScratchDir {
  fs::path dir;
  ScratchDir() {
    std::string tmpl = (fs::temp_directory_path() / "hapticcal-fuzz-scenario-XXXXXX").string();
    if (!mkdtemp(tmpl.data())) std::abort();
    dir = tmpl;
    const fs::path source(HAPTICCAL_SOURCE_DIR);
    for (const auto& e : fs::directory_iterator(source / "data/devices"))
      fs::copy_file(e.path(), dir / e.path().filename());
    // A device too small for the paper's study (once a heap overflow, fuzz/findings).
    fs::copy_file(source / "tests/malformed/good-2dof.yaml", dir / "good-2dof.yaml");
  }
  ~ScratchDir() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const ScratchDir scratch;
  static const std::string path = (scratch.dir / "scenario.yaml").string();
  static const std::string builtin =
      std::string(HAPTICCAL_SOURCE_DIR) + "/data/devices/baser-7dof.yaml";
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
    if (!out) std::abort();
  }
  try {
    (void)hapticcal::load_scenario(path, builtin);
  } catch (const hapticcal::InputError&) {
    // The expected outcome of bad input.
  }
  return 0;
}
