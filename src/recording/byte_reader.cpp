#include "recording/byte_reader.hpp"

#include <bzlib.h>
#include <fcntl.h>
#include <fmt/format.h>
#include <lz4frame.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zstd.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cstring>
#include <limits>

#include "hapticcal/core/cancel.hpp"
#include "hapticcal/core/error.hpp"

namespace hapticcal::recording {

static_assert(std::endian::native == std::endian::little,
              "the recording readers read little-endian");

void fail_at(const std::string& name, std::uint64_t offset, const std::string& record,
             const std::string& what) {
  std::string message = fmt::format("byte {}", offset);
  if (!record.empty()) message += ": " + record;
  throw InputError(name, 0, "", message + ": " + what);
}

void ByteReader::need(std::uint64_t n, const char* what) const {
  if (n > left())
    fail(fmt::format("{} of {} bytes, {} left (a truncated or corrupt file)", what, n, left()));
}

// ROS 2's "package/msg/Type" as "package/Type"; any other name as it is.
std::string normalised_type(std::string_view name) {
  const std::size_t slash = name.find('/');
  if (slash == std::string_view::npos) return std::string(name);
  const std::string_view rest = name.substr(slash + 1);
  if (rest.starts_with("msg/") && rest.find('/', 4) == std::string_view::npos && rest.size() > 4)
    return fmt::format("{}/{}", name.substr(0, slash), rest.substr(4));
  return std::string(name);
}

MappedFile::MappedFile(const std::string& path, std::uint64_t max_bytes) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw InputError(path, 0, "", fmt::format("cannot open: {}", std::strerror(errno)));
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    throw InputError(path, 0, "", "not a regular file");
  }
  if (static_cast<std::uint64_t>(st.st_size) > max_bytes) {
    ::close(fd);
    throw InputError(
        path, 0, "",
        fmt::format("{} bytes: more than the bound of {} bytes", st.st_size, max_bytes));
  }
  size_ = static_cast<std::size_t>(st.st_size);
  if (size_ > 0) {
    void* map = ::mmap(nullptr, size_, PROT_READ, MAP_PRIVATE, fd, 0);
    if (map == MAP_FAILED) {
      ::close(fd);
      throw InputError(path, 0, "", fmt::format("cannot map: {}", std::strerror(errno)));
    }
    data_ = static_cast<const char*>(map);
  }
  ::close(fd);
}

MappedFile::~MappedFile() {
  if (data_ != nullptr) ::munmap(const_cast<char*>(data_), size_);
}

namespace {

// A decompressor writes at most this much a call, and a host's Ctrl-C
// (core/cancel.hpp) is looked for between calls: a chunk of 1 GiB of bz2 takes
// seconds.
constexpr std::size_t kStepBytes = std::size_t{4} << 20;

// The output buffer of a decompressor: exactly `expected` bytes, or an error.
void check_size(std::size_t got, std::uint64_t expected, const std::string& name,
                std::uint64_t offset, const std::string& record, const char* codec) {
  if (got != expected)
    fail_at(name, offset, record,
            fmt::format("{} data hold {} bytes, the record states {}", codec, got, expected));
}

}  // namespace

std::string decompress_lz4_frame(std::string_view in, std::uint64_t expected,
                                 const std::string& name, std::uint64_t offset,
                                 const std::string& record) {
  // One context a thread, reset for each chunk: a fresh one allocates its
  // block buffer (1 MB as roslz4 writes) again for every chunk, 30 times the
  // time of reading small chunks.
  struct Context {
    LZ4F_dctx* ctx = nullptr;
    ~Context() {
      if (ctx != nullptr) LZ4F_freeDecompressionContext(ctx);
    }
  };
  thread_local Context context;
  if (context.ctx == nullptr &&
      LZ4F_isError(LZ4F_createDecompressionContext(&context.ctx, LZ4F_VERSION))) {
    context.ctx = nullptr;
    fail_at(name, offset, record, "lz4: cannot create a decompression context");
  }
  LZ4F_dctx* ctx = context.ctx;
  LZ4F_resetDecompressionContext(ctx);
  std::string out(static_cast<std::size_t>(expected), '\0');
  std::size_t in_pos = 0, out_pos = 0;
  std::size_t status = 1;
  while (in_pos < in.size() && status != 0) {
    throw_if_cancelled();
    std::size_t in_size = in.size() - in_pos;
    std::size_t out_size = std::min(out.size() - out_pos, kStepBytes);
    char spare;  // a full buffer still lets lz4 report data beyond it
    char* dst = out_size > 0 ? out.data() + out_pos : &spare;
    if (out_size == 0) out_size = 1;
    status = LZ4F_decompress(ctx, dst, &out_size, in.data() + in_pos, &in_size, nullptr);
    if (LZ4F_isError(status)) {
      fail_at(name, offset, record, std::string("lz4: ") + LZ4F_getErrorName(status));
    }
    if (dst == &spare && out_size > 0) {
      fail_at(name, offset, record,
              fmt::format("lz4 data hold more than the {} bytes the record states", expected));
    }
    if (in_size == 0 && out_size == 0) break;  // no progress: truncated
    in_pos += in_size;
    out_pos += dst == &spare ? 0 : out_size;
  }
  if (status != 0)
    fail_at(name, offset, record, "lz4 data end before their frame does (a truncated chunk)");
  if (in_pos < in.size())
    fail_at(name, offset, record,
            fmt::format("{} bytes after the lz4 frame's end", in.size() - in_pos));
  check_size(out_pos, expected, name, offset, record, "lz4");
  return out;
}

std::string decompress_zstd(std::string_view in, std::uint64_t expected, const std::string& name,
                            std::uint64_t offset, const std::string& record) {
  std::string out(static_cast<std::size_t>(expected), '\0');
  ZSTD_DCtx* ctx = ZSTD_createDCtx();
  if (ctx == nullptr) fail_at(name, offset, record, "zstd: cannot create a decompression context");
  ZSTD_inBuffer src{in.data(), in.size(), 0};
  ZSTD_outBuffer dst{out.data(), 0, 0};
  std::size_t status = 1;
  while (src.pos < src.size) {
    if (cancel_requested()) {
      ZSTD_freeDCtx(ctx);
      throw Cancelled();
    }
    dst.size = std::min(out.size(), dst.pos + kStepBytes);  // a step's room at a time
    const std::size_t before_in = src.pos, before_out = dst.pos;
    status = ZSTD_decompressStream(ctx, &dst, &src);
    if (ZSTD_isError(status)) {
      const std::string reason = ZSTD_getErrorName(status);
      ZSTD_freeDCtx(ctx);
      fail_at(name, offset, record, "zstd: " + reason);
    }
    if (src.pos == before_in && dst.pos == before_out && dst.size == out.size())
      break;  // output full
  }
  ZSTD_freeDCtx(ctx);
  if (src.pos < src.size)
    fail_at(name, offset, record,
            fmt::format("zstd data hold more than the {} bytes the record states", expected));
  if (status != 0)
    fail_at(name, offset, record, "zstd data end before their frame does (a truncated chunk)");
  check_size(dst.pos, expected, name, offset, record, "zstd");
  return out;
}

std::string decompress_bz2(std::string_view in, std::uint64_t expected, const std::string& name,
                           std::uint64_t offset, const std::string& record) {
  if (in.size() > std::numeric_limits<unsigned>::max() ||
      expected > std::numeric_limits<unsigned>::max() - 1)
    fail_at(name, offset, record, "bz2: a chunk over 4 GiB");
  // One spare byte: more data is an error.
  std::string out(static_cast<std::size_t>(expected) + 1, '\0');
  bz_stream stream{};
  if (BZ2_bzDecompressInit(&stream, 0, 0) != BZ_OK)
    fail_at(name, offset, record, "bz2: cannot create a decompression context");
  stream.next_in = const_cast<char*>(in.data());
  stream.avail_in = static_cast<unsigned>(in.size());
  std::size_t done = 0;
  int status = BZ_OK;
  while (status == BZ_OK) {
    if (cancel_requested()) {
      BZ2_bzDecompressEnd(&stream);
      throw Cancelled();
    }
    const std::size_t room = std::min(out.size() - done, kStepBytes);
    stream.next_out = out.data() + done;
    stream.avail_out = static_cast<unsigned>(room);
    const unsigned in_before = stream.avail_in;
    status = BZ2_bzDecompress(&stream);
    const std::size_t made = room - stream.avail_out;
    done += made;
    if (status != BZ_OK) break;
    if (done == out.size())
      status = BZ_OUTBUFF_FULL;
    else if (in_before == 0 && made == 0)  // every byte read, nothing more made: cut short
      status = BZ_UNEXPECTED_EOF;
  }
  BZ2_bzDecompressEnd(&stream);
  if (status == BZ_OUTBUFF_FULL)
    fail_at(name, offset, record,
            fmt::format("bz2 data hold more than the {} bytes the record states", expected));
  if (status == BZ_UNEXPECTED_EOF)
    fail_at(name, offset, record, "bz2 data end early (a truncated chunk)");
  if (status != BZ_STREAM_END)
    fail_at(name, offset, record, fmt::format("bz2: corrupt data (error {})", status));
  check_size(done, expected, name, offset, record, "bz2");
  out.resize(done);
  return out;
}

}  // namespace hapticcal::recording
