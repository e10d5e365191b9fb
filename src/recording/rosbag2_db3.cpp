// rosbag2's sqlite3 storage (.db3), read with Debian's libsqlite3. The tables
// are those rosbag2_storage_sqlite3 creates (SqliteStorage::initialize in
// https://github.com/ros2/rosbag2/blob/rolling/rosbag2_storage_sqlite3/src/rosbag2_storage_sqlite3/sqlite_storage.cpp):
//   topics(id, name, type, serialization_format, offered_qos_profiles[, type_description_hash])
//   messages(id, topic_id, timestamp, data)
//   message_definitions(id, topic_type, encoding, encoded_message_definition,
//   type_description_hash)
// the last only from Iron on (definitions encoded as in
// https://github.com/ros2/rosbag2/blob/rolling/docs/message_definition_encoding.md).
// Messages are handed out as rosbag2 plays them: by timestamp, then row id.
// The file is opened read-only and immutable (sqlite touches no journal, -wal
// or -shm file); a file header is checked first (https://www.sqlite.org/fileformat.html)
// so that a truncated file is named so. A .db3 has no byte offsets worth
// naming: errors name the table and row ("messages row 1234"), and a message's
// offset handed to the visitor is 0.
#include <fmt/format.h>
#include <sqlite3.h>
#include <sys/stat.h>

#include <cctype>
#include <cerrno>
#include <climits>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <unordered_set>

#include "hapticcal/core/error.hpp"
#include "hapticcal/recording/recording.hpp"
#include "recording/byte_reader.hpp"

namespace hapticcal::recording {
namespace {

std::uint32_t big_endian(const unsigned char* p, int n) {
  std::uint32_t v = 0;
  for (int i = 0; i < n; ++i) v = (v << 8) | p[i];
  return v;
}

// The checks before sqlite opens the file: a regular file within the bound,
// an SQLite 3 header, all the pages the header states (a truncated copy or
// download is named so, not left to sqlite's "malformed"), and no journal or
// write-ahead log beside it (changes not in the file: reading it immutable
// would miss them).
void check_file(const std::string& path, const RecordingLimits& limits) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0)
    throw InputError(path, 0, "", "cannot open: " + std::string(std::strerror(errno)));
  if (!S_ISREG(st.st_mode)) throw InputError(path, 0, "", "not a regular file");
  const auto file_bytes = static_cast<std::uint64_t>(st.st_size);
  if (file_bytes > limits.max_file_bytes)
    throw InputError(path, 0, "",
                     fmt::format("{} bytes: more than the bound of {} bytes", file_bytes,
                                 limits.max_file_bytes));
  unsigned char header[100] = {};
  std::ifstream in(path, std::ios::binary);
  in.read(reinterpret_cast<char*>(header), sizeof header);
  if (in.gcount() < 16 || std::memcmp(header, "SQLite format 3\0", 16) != 0)
    throw InputError(path, 0, "", "not an SQLite 3 database (a rosbag2 .db3 is one)");
  if (in.gcount() < static_cast<std::streamsize>(sizeof header))
    throw InputError(
        path, 0, "",
        fmt::format("{} bytes: shorter than SQLite's 100-byte header (a truncated file)",
                    in.gcount()));
  const std::uint32_t page_field = big_endian(header + 16, 2);
  const std::uint64_t page_bytes = page_field == 1 ? 65536 : page_field;
  if (page_bytes < 512 || page_bytes > 65536 || (page_bytes & (page_bytes - 1)) != 0)
    throw InputError(path, 0, "",
                     fmt::format("page size {} in the header (a corrupt file)", page_bytes));
  // The header's page count is valid when its change counter matches the
  // version-valid-for number (the file format's rule).
  const std::uint64_t pages = big_endian(header + 28, 4);
  if (pages != 0 && big_endian(header + 24, 4) == big_endian(header + 92, 4) &&
      pages * page_bytes > file_bytes)
    throw InputError(
        path, 0, "",
        fmt::format(
            "{} bytes, but its header states {} pages of {} bytes ({} bytes): a truncated file",
            file_bytes, pages, page_bytes, pages * page_bytes));
  for (const char* suffix : {"-wal", "-journal"}) {
    std::error_code ec;
    if (std::filesystem::file_size(path + suffix, ec) > 0 && !ec)
      throw InputError(
          path, 0, "",
          fmt::format(
              "{}{} beside it holds changes not yet in the file (the recording was not closed "
              "cleanly, or is still being written)",
              printable(std::filesystem::path(path).filename().string(), 200), suffix));
  }
}

// sqlite's URI of `path`, read-only and immutable (https://www.sqlite.org/uri.html).
std::string immutable_uri(const std::string& path) {
  std::string uri = "file:";
  for (const char c : std::filesystem::absolute(path).string()) {
    const auto u = static_cast<unsigned char>(c);
    if (std::isalnum(u) || c == '/' || c == '.' || c == '_' || c == '-' || c == '~')
      uri += c;
    else
      uri += fmt::format("%{:02X}", u);
  }
  return uri + "?mode=ro&immutable=1";
}

class Statement {
 public:
  explicit Statement(sqlite3_stmt* s) : s_(s) {}
  ~Statement() { sqlite3_finalize(s_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  sqlite3_stmt* get() const { return s_; }

 private:
  sqlite3_stmt* s_;
};

struct Topic {
  std::string name, type, serialization_format;
};

class Db3Reader {
 public:
  Db3Reader(const std::string& path, RecordingVisitor& visitor, const RecordingLimits& limits)
      : path_(path), visitor_(visitor), limits_(limits) {}
  ~Db3Reader() { sqlite3_close(db_); }

  void read();

 private:
  [[noreturn]] void fail(const std::string& where, const std::string& what) const {
    throw InputError(path_, 0, "", where + ": " + what);
  }
  [[noreturn]] void fail_sqlite(const std::string& where) const {
    fail(where, fmt::format("sqlite: {} (a corrupt or truncated .db3)", sqlite3_errmsg(db_)));
  }
  Statement prepare(const char* sql, const std::string& where) const;
  bool step(const Statement& s, const std::string& where) const;
  bool has_table(const char* table) const;
  std::string text(const Statement& s, int column, const std::string& where,
                   const char* field) const;
  std::int64_t integer(const Statement& s, int column, const std::string& where,
                       const char* field) const;
  std::map<std::string, std::pair<std::string, std::string>> definitions() const;
  void topics();
  void messages();

  const std::string& path_;
  RecordingVisitor& visitor_;
  const RecordingLimits& limits_;
  sqlite3* db_ = nullptr;
  std::unordered_set<std::int64_t> topic_ids_;
};

Statement Db3Reader::prepare(const char* sql, const std::string& where) const {
  sqlite3_stmt* s = nullptr;
  if (sqlite3_prepare_v2(db_, sql, -1, &s, nullptr) != SQLITE_OK) {
    sqlite3_finalize(s);
    fail(where,
         fmt::format("sqlite: {} (not a rosbag2 .db3, or a corrupt one)", sqlite3_errmsg(db_)));
  }
  return Statement(s);
}

bool Db3Reader::step(const Statement& s, const std::string& where) const {
  const int rc = sqlite3_step(s.get());
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  fail_sqlite(where);
}

bool Db3Reader::has_table(const char* table) const {
  const Statement s =
      prepare("SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = ?1", "the schema");
  sqlite3_bind_text(s.get(), 1, table, -1, SQLITE_STATIC);
  return step(s, "the schema");
}

std::string Db3Reader::text(const Statement& s, int column, const std::string& where,
                            const char* field) const {
  if (sqlite3_column_type(s.get(), column) != SQLITE_TEXT)
    fail(where, fmt::format("{} is not text", field));
  const auto* p = reinterpret_cast<const char*>(sqlite3_column_text(s.get(), column));
  return std::string(p, static_cast<std::size_t>(sqlite3_column_bytes(s.get(), column)));
}

std::int64_t Db3Reader::integer(const Statement& s, int column, const std::string& where,
                                const char* field) const {
  if (sqlite3_column_type(s.get(), column) != SQLITE_INTEGER)
    fail(where, fmt::format("{} is not an integer", field));
  return sqlite3_column_int64(s.get(), column);
}

// topic_type -> (encoding, definition), from message_definitions when the
// file has that table (Iron and later).
std::map<std::string, std::pair<std::string, std::string>> Db3Reader::definitions() const {
  std::map<std::string, std::pair<std::string, std::string>> out;
  if (!has_table("message_definitions")) return out;
  const Statement s = prepare(
      "SELECT id, topic_type, encoding, encoded_message_definition FROM message_definitions ORDER "
      "BY id",
      "message_definitions");
  while (step(s, "message_definitions")) {
    const std::string where =
        fmt::format("message_definitions row {}", sqlite3_column_int64(s.get(), 0));
    std::string type = text(s, 1, where, "topic_type");
    std::string encoding = text(s, 2, where, "encoding");
    out.emplace(std::move(type), std::make_pair(std::move(encoding),
                                                text(s, 3, where, "encoded_message_definition")));
  }
  return out;
}

void Db3Reader::topics() {
  const auto defined = definitions();
  const Statement s =
      prepare("SELECT id, name, type, serialization_format FROM topics ORDER BY id", "topics");
  while (step(s, "topics")) {
    const std::int64_t id = integer(s, 0, "topics", "id");
    const std::string where = fmt::format("topics row {}", id);
    if (id < 0 || id > std::int64_t{UINT32_MAX}) fail(where, "an id beyond 0 to 4294967295");
    if (topic_ids_.size() >= limits_.max_channels)
      fail(where, fmt::format("more than the bound of {} topics", limits_.max_channels));
    Channel c;
    c.topic = text(s, 1, where, "name");
    const std::string type = text(s, 2, where, "type");
    c.type = normalised_type(type);
    c.message_encoding = text(s, 3, where, "serialization_format");
    const auto d = defined.find(type);
    const std::string definition_encoding = d == defined.end() ? "" : d->second.first;
    if (definition_encoding == "ros2msg") c.definition = d->second.second;
    if (c.message_encoding == "cdr" &&
        (definition_encoding == "ros2msg" || d == defined.end() || d->second.second.empty())) {
      c.encoding =
          Encoding::kCdr;  // no definition stored ("unknown", or before Iron): the type's own
    } else if (c.message_encoding == "cdr") {
      c.message_encoding = fmt::format("cdr with a {} definition", printable(definition_encoding));
    }
    topic_ids_.insert(id);
    visitor_.channel(static_cast<std::uint32_t>(id), c);
  }
}

void Db3Reader::messages() {
  // The data is fetched only within the bound (length() and typeof() read
  // neither the blob nor its overflow pages): an over-long message is named,
  // never copied.
  const Statement s = prepare(
      "SELECT id, topic_id, timestamp, typeof(data), length(data), "
      "CASE WHEN length(data) <= ?1 THEN data END FROM messages ORDER BY timestamp, id",
      "messages");
  sqlite3_bind_int64(
      s.get(), 1,
      static_cast<sqlite3_int64>(std::min<std::uint64_t>(limits_.max_message_bytes, INT64_MAX)));
  std::uint64_t count = 0;
  std::int64_t last_id = 0;
  while (step(
      s, count == 0 ? std::string("messages") : fmt::format("messages, after row {}", last_id))) {
    last_id = integer(s, 0, "messages", "id");
    const std::string where = fmt::format("messages row {}", last_id);
    const std::int64_t topic_id = integer(s, 1, where, "topic_id");
    if (topic_ids_.find(topic_id) == topic_ids_.end())
      fail(where, fmt::format("topic_id {} is not in the topics table", topic_id));
    const std::int64_t timestamp_ns = integer(s, 2, where, "timestamp");
    if (text(s, 3, where, "typeof(data)") != "blob") fail(where, "data is not a blob");
    const std::int64_t data_bytes = integer(s, 4, where, "length(data)");
    if (sqlite3_column_type(s.get(), 5) == SQLITE_NULL && data_bytes > 0)
      fail(where, fmt::format("{} bytes of data: more than the bound of {} bytes for a message",
                              data_bytes, limits_.max_message_bytes));
    if (++count > limits_.max_messages)
      fail(where, fmt::format("more than the bound of {} messages", limits_.max_messages));
    const void* blob = sqlite3_column_blob(s.get(), 5);
    const int got = sqlite3_column_bytes(s.get(), 5);
    if (got != data_bytes) fail_sqlite(where);  // the blob could not be read whole
    const std::string_view data(static_cast<const char*>(blob),
                                blob == nullptr ? 0 : static_cast<std::size_t>(got));
    visitor_.message(static_cast<std::uint32_t>(topic_id), timestamp_ns, data, 0);
  }
}

void Db3Reader::read() {
  const int rc = sqlite3_open_v2(immutable_uri(path_).c_str(), &db_,
                                 SQLITE_OPEN_READONLY | SQLITE_OPEN_URI, nullptr);
  if (rc != SQLITE_OK)
    fail("open",
         fmt::format("sqlite: {}", db_ != nullptr ? sqlite3_errmsg(db_) : sqlite3_errstr(rc)));
  // A string or blob over the record bound is refused by sqlite itself (its
  // default is a bound of 10^9 bytes).
  const std::uint64_t longest = std::min<std::uint64_t>(limits_.max_record_bytes, INT_MAX);
  sqlite3_limit(db_, SQLITE_LIMIT_LENGTH, static_cast<int>(longest));
  for (const char* table : {"topics", "messages"})
    if (!has_table(table))
      fail("the schema", fmt::format("no table '{}': not a rosbag2 .db3", table));
  topics();
  messages();
}

}  // namespace

void read_rosbag2_db3(const std::string& path, RecordingVisitor& visitor,
                      const RecordingLimits& limits) {
  check_file(path, limits);
  Db3Reader(path, visitor, limits).read();
}

}  // namespace hapticcal::recording
