// Reading and writing whole files, bounded and atomic.
#pragma once

#include <cstddef>
#include <string>

namespace hapticcal {

// Writes text to path atomically (temporary file in the same directory, then
// rename); creates missing parent directories.
void write_file_atomically(const std::string& path, const std::string& text);
// What an input file is, for its size limit (docs/development.md, "Bounded input"). Each
// bound is far above any real file of the kind and keeps the parsers' memory
// (a few tens of bytes per input byte) within a few hundred megabytes.
enum class FileKind {
  kDevice,    // device file (YAML): 256 KiB (a 32-joint device is about 10 KiB)
  kUrdf,      // URDF: 3 MiB (meshes are referenced, not inlined)
  kLog,       // measurement log (CSV): 2 GiB (a one-hour 1 kHz stream is ~0.4 GiB)
  kFixture,   // fixture file (YAML): 256 KiB
  kScenario,  // simulate scenario (YAML): 256 KiB
  kOwn,       // hapticcal's own files (results, figures): 256 MiB
};
std::size_t max_file_bytes(FileKind kind);
// The whole of a regular file, at most max_file_bytes(kind): InputError naming
// the file for a directory, a device, FIFO or socket (never read: /dev/zero
// would not end), or a larger file (checked before and while reading).
std::string read_file(const std::string& path, FileKind kind = FileKind::kOwn);

}  // namespace hapticcal
