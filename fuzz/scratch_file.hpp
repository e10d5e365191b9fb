// Shared by the fuzz targets whose reader takes a path (fuzz_db3, fuzz_import):
// the input written to a scratch file of this process ($TMPDIR, else /tmp).
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <string>

// The scratch file `NAME_PID.EXT` holding `data`; its path, the same for the
// process's every input.
inline const std::string& write_scratch_file(const char* name, const char* ext,
                                             const std::uint8_t* data, std::size_t size) {
  static const std::string path = [&] {
    const char* dir = std::getenv("TMPDIR");
    return std::string(dir != nullptr ? dir : "/tmp") + "/" + name + "_" +
           std::to_string(::getpid()) + "." + ext;
  }();
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path;
}
