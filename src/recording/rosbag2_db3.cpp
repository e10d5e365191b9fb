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
// The tables must be tables of stored columns (a view, a virtual table or a
// generated column is refused: sqlite would compute what is read); a first
// pass reads each message's size without its data and the reader orders the
// rows itself, so sqlite sorts nothing, writes no temporary file, and no more
// text and data are read than the file holds.
// The file is opened read-only and immutable (sqlite touches no journal, -wal
// or -shm file); a file header is checked first (https://www.sqlite.org/fileformat.html)
// so that a truncated file is named so. A .db3 has no byte offsets worth
// naming: errors name the table and row ("messages row 1234"), and a message's
// offset handed to the visitor is 0.
#include <fmt/format.h>
#include <sqlite3.h>
#include <sys/stat.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <climits>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <tuple>
#include <unordered_set>
#include <vector>

#include "hapticcal/core/cancel.hpp"
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
std::uint64_t check_file(const std::string& path, const RecordingLimits& limits) {
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
  return file_bytes;
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
  std::int64_t id = 0;
  Channel channel;
};

// A message row as the first pass finds it: the order rosbag2 plays it in
// (timestamp, then id), where to fetch its data and how much there is.
struct MessageRow {
  std::int64_t timestamp = 0, id = 0, rowid = 0;
  std::uint32_t topic = 0;
  std::int64_t bytes = 0;
  auto order() const { return std::tie(timestamp, id, rowid); }
};

// sqlite's progress handler: a host's Ctrl-C (core/cancel.hpp) interrupts a
// statement that runs long within one step.
int interrupt_if_cancelled(void*) { return cancel_requested() ? 1 : 0; }

class Db3Reader {
 public:
  Db3Reader(const std::string& path, RecordingVisitor& visitor, const RecordingLimits& limits,
            std::uint64_t file_bytes)
      : path_(path),
        visitor_(visitor),
        limits_(limits),
        file_bytes_(file_bytes),
        budget_(file_bytes) {}
  ~Db3Reader() { sqlite3_close(db_); }

  void read();

 private:
  [[noreturn]] void fail(const std::string& where, const std::string& what) const {
    throw InputError(path_, 0, "", where + ": " + what);
  }
  [[noreturn]] void fail_sqlite(const std::string& where) const {
    if (cancel_requested()) throw Cancelled();  // the progress handler interrupted sqlite
    fail(where, fmt::format("sqlite: {} (a corrupt or truncated .db3)", sqlite3_errmsg(db_)));
  }
  void open();
  Statement prepare(const std::string& sql, const std::string& where) const;
  bool step(const Statement& s, const std::string& where) const;
  void check_table(const char* table, std::initializer_list<const char*> columns) const;
  void charge(const Statement& s, int column, const std::string& where);
  std::string text(const Statement& s, int column, const std::string& where, const char* field);
  std::int64_t integer(const Statement& s, int column, const std::string& where,
                       const char* field) const;
  std::map<std::string, std::pair<std::string, std::string>> definitions();
  void topics();
  std::vector<MessageRow> message_rows();
  void messages();

  const std::string& path_;
  RecordingVisitor& visitor_;
  const RecordingLimits& limits_;
  sqlite3* db_ = nullptr;
  std::unordered_set<std::int64_t> topic_ids_;
  // Bytes of text and data still to be handed out: at most the file's. In a
  // sound file every byte read is stored once; a value computed on reading (a
  // column's default) or pages shared by many rows would hand out more.
  std::uint64_t file_bytes_;
  std::uint64_t budget_;
  std::uint64_t definition_bytes_ = 0;  // the definitions handed out with the topics
};

void Db3Reader::open() {
  const int rc = sqlite3_open_v2(immutable_uri(path_).c_str(), &db_,
                                 SQLITE_OPEN_READONLY | SQLITE_OPEN_URI, nullptr);
  if (rc != SQLITE_OK)
    fail("open",
         fmt::format("sqlite: {}", db_ != nullptr ? sqlite3_errmsg(db_) : sqlite3_errstr(rc)));
  // No string or blob longer than a message's bound (or 16 MiB, for the
  // definitions) is made by sqlite itself.
  const std::uint64_t longest = std::min<std::uint64_t>(
      std::max<std::uint64_t>(limits_.max_message_bytes, std::uint64_t{16} << 20), INT_MAX);
  sqlite3_limit(db_, SQLITE_LIMIT_LENGTH, static_cast<int>(longest));
  // The file's schema is not trusted: no function of it (a view's, a
  // trigger's) runs with side effects, and the file is checked as it is read.
  sqlite3_db_config(db_, SQLITE_DBCONFIG_TRUSTED_SCHEMA, 0, nullptr);
  sqlite3_db_config(db_, SQLITE_DBCONFIG_DEFENSIVE, 1, nullptr);
  sqlite3_exec(db_, "PRAGMA cell_size_check = ON", nullptr, nullptr, nullptr);
  sqlite3_progress_handler(db_, 10000, interrupt_if_cancelled, nullptr);
}

Statement Db3Reader::prepare(const std::string& sql, const std::string& where) const {
  sqlite3_stmt* s = nullptr;
  if (sqlite3_prepare_v2(db_, sql.c_str(), -1, &s, nullptr) != SQLITE_OK) {
    sqlite3_finalize(s);
    if (cancel_requested()) throw Cancelled();
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

// A table as rosbag2 creates it: a table of stored columns with a rowid. A
// view, a virtual table or a generated column would compute what is read
// (a blob of any size, rows in any number) from a file of a few kilobytes.
void Db3Reader::check_table(const char* table, std::initializer_list<const char*> columns) const {
  const std::string where = fmt::format("table {}", table);
  const Statement s =
      prepare("SELECT type, sql FROM sqlite_master WHERE name = ?1 COLLATE NOCASE", "the schema");
  sqlite3_bind_text(s.get(), 1, table, -1, SQLITE_STATIC);
  if (!step(s, "the schema"))
    fail("the schema", fmt::format("no table '{}': not a rosbag2 .db3", table));
  const auto* type = reinterpret_cast<const char*>(sqlite3_column_text(s.get(), 0));
  const auto* sql = reinterpret_cast<const char*>(sqlite3_column_text(s.get(), 1));
  const std::string kind = type == nullptr ? "" : type;
  if (kind != "table")
    fail(where, fmt::format("a {}, not a table (rosbag2 writes a table)", printable(kind)));
  if (sql != nullptr && sqlite3_strnicmp(sql, "CREATE VIRTUAL", 14) == 0)
    fail(where,
         "a virtual table (computed on reading), not a table of stored rows as rosbag2 "
         "writes");
  const Statement info = prepare("SELECT name, hidden FROM pragma_table_xinfo(?1)", where);
  sqlite3_bind_text(info.get(), 1, table, -1, SQLITE_STATIC);
  std::unordered_set<std::string> names;
  while (step(info, where)) {
    const auto* p = reinterpret_cast<const char*>(sqlite3_column_text(info.get(), 0));
    std::string name = p == nullptr ? "" : p;
    for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (sqlite3_column_int64(info.get(), 1) != 0)
      fail(where, fmt::format("column {} is generated (computed on reading): rosbag2 stores "
                              "every column",
                              printable(name)));
    if (name == "rowid" || name == "_rowid_" || name == "oid")
      fail(where, fmt::format("a column named {}: rosbag2's rows are found by their rowid",
                              printable(name)));
    names.insert(std::move(name));
  }
  for (const char* column : columns)
    if (names.count(column) == 0)
      fail(where, fmt::format("no column '{}': not a rosbag2 .db3", column));
  prepare(fmt::format("SELECT rowid FROM \"{}\" LIMIT 0", table), where + " (without rowid)");
}

// Takes a text or blob's bytes from the budget before they are copied.
void Db3Reader::charge(const Statement& s, int column, const std::string& where) {
  const auto bytes = static_cast<std::uint64_t>(sqlite3_column_bytes(s.get(), column));
  if (bytes > budget_)
    fail(where,
         "more text and data than the file's bytes hold (values computed on reading, or "
         "pages shared by rows: a corrupt .db3)");
  budget_ -= bytes;
}

std::string Db3Reader::text(const Statement& s, int column, const std::string& where,
                            const char* field) {
  if (sqlite3_column_type(s.get(), column) != SQLITE_TEXT)
    fail(where, fmt::format("{} is not text", field));
  charge(s, column, where);
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
// file has that table (Iron and later); the first row by id of a type wins.
// Every query here and below is one pass over one table, without ORDER BY: the
// reader orders what it kept, so sqlite sorts nothing and writes no temporary
// file, and each bound is checked row by row.
std::map<std::string, std::pair<std::string, std::string>> Db3Reader::definitions() {
  std::map<std::string, std::pair<std::string, std::string>> out;
  const Statement exists =
      prepare("SELECT 1 FROM sqlite_master WHERE name = 'message_definitions' COLLATE NOCASE",
              "the schema");
  if (!step(exists, "the schema")) return out;
  check_table("message_definitions",
              {"id", "topic_type", "encoding", "encoded_message_definition"});
  const Statement s = prepare(
      "SELECT id, topic_type, encoding, encoded_message_definition FROM message_definitions",
      "message_definitions");
  std::vector<std::pair<std::int64_t, std::array<std::string, 3>>> rows;
  while (step(s, "message_definitions")) {
    const std::int64_t id = integer(s, 0, "message_definitions", "id");
    const std::string where = fmt::format("message_definitions row {}", id);
    if (rows.size() >= limits_.max_channels)
      fail(where, fmt::format("more than the bound of {} definitions", limits_.max_channels));
    std::string type = text(s, 1, where, "topic_type");
    std::string encoding = text(s, 2, where, "encoding");
    rows.push_back(
        {id,
         {std::move(type), std::move(encoding), text(s, 3, where, "encoded_message_definition")}});
  }
  std::stable_sort(rows.begin(), rows.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  for (auto& [id, row] : rows)
    out.emplace(std::move(row[0]), std::make_pair(std::move(row[1]), std::move(row[2])));
  return out;
}

void Db3Reader::topics() {
  const auto defined = definitions();
  const Statement s = prepare("SELECT id, name, type, serialization_format FROM topics", "topics");
  std::vector<Topic> found;
  while (step(s, "topics")) {
    const std::int64_t id = integer(s, 0, "topics", "id");
    const std::string where = fmt::format("topics row {}", id);
    if (id < 0 || id > std::int64_t{UINT32_MAX}) fail(where, "an id beyond 0 to 4294967295");
    if (found.size() >= limits_.max_channels)
      fail(where, fmt::format("more than the bound of {} topics", limits_.max_channels));
    if (!topic_ids_.insert(id).second) fail(where, "a second topic of this id");
    Topic t;
    t.id = id;
    Channel& c = t.channel;
    c.topic = text(s, 1, where, "name");
    const std::string type = text(s, 2, where, "type");
    c.type = normalised_type(type);
    c.message_encoding = text(s, 3, where, "serialization_format");
    const auto d = defined.find(type);
    const std::string definition_encoding = d == defined.end() ? "" : d->second.first;
    if (definition_encoding == "ros2msg") c.definition = d->second.second;
    definition_bytes_ += c.definition.size();
    if (definition_bytes_ > file_bytes_ + limits_.max_definition_bytes)
      fail(where, fmt::format("the topics' definitions add up to {} bytes, more than the file's "
                              "{} bytes and {} more (max_definition_bytes): many topics of a "
                              "type with a large definition",
                              definition_bytes_, file_bytes_, limits_.max_definition_bytes));
    if (c.message_encoding == "cdr" &&
        (definition_encoding == "ros2msg" || d == defined.end() || d->second.second.empty())) {
      c.encoding =
          Encoding::kCdr;  // no definition stored ("unknown", or before Iron): the type's own
    } else if (c.message_encoding == "cdr") {
      c.message_encoding = fmt::format("cdr with a {} definition", printable(definition_encoding));
    }
    found.push_back(std::move(t));
  }
  std::sort(found.begin(), found.end(), [](const Topic& a, const Topic& b) { return a.id < b.id; });
  for (const Topic& t : found) visitor_.channel(static_cast<std::uint32_t>(t.id), t.channel);
}

// The first pass: every row's place and size, its data's length read without
// the data (length() and typeof() of a stored blob read neither it nor its
// overflow pages); each bound checked before a byte of data is fetched.
std::vector<MessageRow> Db3Reader::message_rows() {
  const Statement s =
      prepare("SELECT rowid, id, topic_id, timestamp, typeof(data), length(data) FROM messages",
              "messages");
  const auto most =
      static_cast<std::int64_t>(std::min<std::uint64_t>(limits_.max_message_bytes, INT64_MAX));
  std::vector<MessageRow> rows;
  while (step(s, rows.empty() ? std::string("messages")
                              : fmt::format("messages, after row {}", rows.back().id))) {
    if ((rows.size() & 4095) == 0) throw_if_cancelled();
    MessageRow m;
    m.rowid = sqlite3_column_int64(s.get(), 0);
    m.id = integer(s, 1, "messages", "id");
    const std::string where = fmt::format("messages row {}", m.id);
    const std::int64_t topic_id = integer(s, 2, where, "topic_id");
    if (topic_ids_.find(topic_id) == topic_ids_.end())
      fail(where, fmt::format("topic_id {} is not in the topics table", topic_id));
    m.topic = static_cast<std::uint32_t>(topic_id);
    m.timestamp = integer(s, 3, where, "timestamp");
    const auto* type = reinterpret_cast<const char*>(sqlite3_column_text(s.get(), 4));
    if (type == nullptr || std::strcmp(type, "blob") != 0) fail(where, "data is not a blob");
    m.bytes = integer(s, 5, where, "length(data)");
    if (m.bytes > most)
      fail(where, fmt::format("{} bytes of data: more than the bound of {} bytes for a message",
                              m.bytes, limits_.max_message_bytes));
    if (static_cast<std::uint64_t>(m.bytes) > budget_)
      fail(where,
           "more data than the file's bytes hold (values computed on reading, or pages "
           "shared by rows: a corrupt .db3)");
    budget_ -= static_cast<std::uint64_t>(m.bytes);
    if (rows.size() >= limits_.max_messages)
      fail(where, fmt::format("more than the bound of {} messages", limits_.max_messages));
    rows.push_back(m);
  }
  return rows;
}

// Messages as rosbag2 plays them: by timestamp, then id; each one's data
// fetched by its rowid (only for a channel whose data the visitor wants).
void Db3Reader::messages() {
  std::vector<MessageRow> rows = message_rows();
  std::sort(rows.begin(), rows.end(),
            [](const MessageRow& a, const MessageRow& b) { return a.order() < b.order(); });
  const Statement s = prepare("SELECT data FROM messages WHERE rowid = ?1", "messages");
  for (const MessageRow& m : rows) {
    throw_if_cancelled();
    if (!visitor_.wants_data(m.topic)) {
      visitor_.message(m.topic, m.timestamp, {}, 0);
      continue;
    }
    const std::string where = fmt::format("messages row {}", m.id);
    sqlite3_reset(s.get());
    sqlite3_bind_int64(s.get(), 1, m.rowid);
    if (!step(s, where)) fail(where, "the row is gone (a corrupt .db3)");
    const void* blob = sqlite3_column_blob(s.get(), 0);
    const int got = sqlite3_column_bytes(s.get(), 0);
    if (got != m.bytes) fail_sqlite(where);  // the blob could not be read whole
    const std::string_view data(static_cast<const char*>(blob),
                                blob == nullptr ? 0 : static_cast<std::size_t>(got));
    visitor_.message(m.topic, m.timestamp, data, 0);
  }
}

void Db3Reader::read() {
  open();
  check_table("topics", {"id", "name", "type", "serialization_format"});
  check_table("messages", {"id", "topic_id", "timestamp", "data"});
  topics();
  messages();
}

}  // namespace

void read_rosbag2_db3(const std::string& path, RecordingVisitor& visitor,
                      const RecordingLimits& limits) {
  const std::uint64_t file_bytes = check_file(path, limits);
  Db3Reader(path, visitor, limits, file_bytes).read();
}

}  // namespace hapticcal::recording
