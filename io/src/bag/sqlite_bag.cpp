#include "bag/sqlite_bag.h"

#include <sqlite3.h>

#include <fstream>
#include <memory>

#include "stillmap/io/error.h"

namespace stillmap {
namespace {

struct Finalize {
  void operator()(sqlite3_stmt* statement) const { sqlite3_finalize(statement); }
};
using Statement = std::unique_ptr<sqlite3_stmt, Finalize>;

// A URI for the file: read-only and immutable (no locks, journal or -shm file).
std::string ImmutableUri(const std::string& path) {
  std::string uri = "file:";
  static const char* const kHex = "0123456789ABCDEF";
  for (const char c : path) {
    const auto byte = static_cast<unsigned char>(c);
    if (c == '%' || c == '?' || c == '#' || byte < 0x20 || byte >= 0x80) {
      uri += '%';
      uri += kHex[byte >> 4U];
      uri += kHex[byte & 0xFU];
    } else {
      uri += c;
    }
  }
  return uri + "?immutable=1";
}

std::string Text(sqlite3_stmt* statement, int column) {
  const unsigned char* text = sqlite3_column_text(statement, column);
  return text == nullptr ? std::string() : reinterpret_cast<const char*>(text);
}

}  // namespace

SqliteBag::SqliteBag(const std::string& path) : BagReader(path) {
  file_size_ = CheckMagic(kMagic, kMagicSize, "an SQLite database (no SQLite header)");
  // The header's page size (bytes 16-17, big-endian, 1 for 65536) and page count (28-31).
  std::uint8_t header[32] = {};
  std::ifstream(path, std::ios::binary).read(reinterpret_cast<char*>(header), sizeof(header));
  const std::uint32_t page =
      header[16] == 0 && header[17] == 1 ? 65536U : (header[16] << 8U) | header[17];
  stated_size_ =
      static_cast<std::uint64_t>(page) * ((static_cast<std::uint32_t>(header[28]) << 24U) |
                                          (header[29] << 16U) | (header[30] << 8U) | header[31]);
  if (sqlite3_open_v2(ImmutableUri(path).c_str(), &db_, SQLITE_OPEN_READONLY | SQLITE_OPEN_URI,
                      nullptr) != SQLITE_OK) {
    const std::string reason = db_ == nullptr ? "out of memory" : Reason();
    sqlite3_close(db_);
    db_ = nullptr;
    throw InputError(path + ": cannot open the sqlite3 bag (" + reason + ")");
  }
  // A file cut short holds fewer pages than its header says, which SQLite calls corrupt unless
  // the schema is "writable" (a flag only: the connection stays read-only). Its pages that are
  // there read, and the scan stops with a warning where the first missing one is needed.
  sqlite3_exec(db_, "PRAGMA writable_schema=ON", nullptr, nullptr, nullptr);
  try {
    ReadTopics();
    read_ = Prepare("SELECT data FROM messages WHERE id = ?");
  } catch (...) {
    sqlite3_close(db_);
    db_ = nullptr;
    throw;
  }
}

SqliteBag::~SqliteBag() {
  sqlite3_finalize(read_);
  sqlite3_close(db_);
}

std::string SqliteBag::Reason() const {
  if (stated_size_ > file_size_) {
    return "the file is cut short: it holds " + std::to_string(file_size_) + " of the " +
           std::to_string(stated_size_) + " bytes its header states";
  }
  switch (sqlite3_extended_errcode(db_) & 0xFF) {
    case SQLITE_CORRUPT:
      return "the database is damaged";
    case SQLITE_NOTADB:
      return "its header is not an SQLite database's";
    case SQLITE_IOERR:
      return "the file could not be read";
    case SQLITE_NOMEM:
      return "out of memory";
    default:
      return "SQLite error " + std::to_string(sqlite3_extended_errcode(db_));
  }
}

sqlite3_stmt* SqliteBag::Prepare(const char* sql) const {
  sqlite3_stmt* statement = nullptr;
  if (sqlite3_prepare_v2(db_, sql, -1, &statement, nullptr) != SQLITE_OK) {
    const bool foreign = std::string(sqlite3_errmsg(db_)).find("no such") == 0;
    sqlite3_finalize(statement);
    if (foreign && stated_size_ <= file_size_) {
      throw InputError(path_ +
                       ": an SQLite database but not a ROS 2 bag (it lacks a table or column "
                       "rosbag2 writes: tables topics and messages)");
    }
    throw InputError(path_ + ": the sqlite3 bag cannot be read (" + Reason() + ")");
  }
  return statement;
}

void SqliteBag::ReadTopics() {
  const Statement statement(Prepare("SELECT id, name, type, serialization_format FROM topics"));
  int step = SQLITE_ROW;
  while ((step = sqlite3_step(statement.get())) == SQLITE_ROW) {
    const std::int64_t id = sqlite3_column_int64(statement.get(), 0);
    const std::string name = Text(statement.get(), 1), type = Text(statement.get(), 2);
    const std::string format = Text(statement.get(), 3);
    if (format != "cdr") {
      topic_warnings_.push_back(path_ + ": topic " + name + " is serialized as " + Quoted(format) +
                                ", not cdr: its messages are left out");
      continue;
    }
    topic_of_id_[id] = JoinTopic(&topics_, {name, type});
  }
  if (step != SQLITE_DONE) {
    throw InputError(path_ + ": the sqlite3 bag's topics table cannot be read (" + Reason() + ")");
  }
  // A message table that cannot be prepared names the bag as not rosbag2's.
  Statement(Prepare("SELECT id, topic_id, timestamp, data FROM messages LIMIT 0"));
}

void SqliteBag::Scan(const std::function<void(const BagMessage&)>& visit) {
  warnings_ = topic_warnings_;
  truncated_ = false;
  const Statement statement(Prepare("SELECT id, topic_id, timestamp, data FROM messages"));
  double last_time = 0.0;
  std::int64_t last_id = 0;
  int step = SQLITE_ROW;
  while ((step = sqlite3_step(statement.get())) == SQLITE_ROW) {
    const auto topic = topic_of_id_.find(sqlite3_column_int64(statement.get(), 1));
    last_id = sqlite3_column_int64(statement.get(), 0);
    if (topic == topic_of_id_.end()) continue;
    BagMessage message;
    message.topic = topic->second;
    message.time = 1e-9 * static_cast<double>(sqlite3_column_int64(statement.get(), 2));
    message.position.block = static_cast<std::uint64_t>(last_id);
    message.data = static_cast<const std::uint8_t*>(sqlite3_column_blob(statement.get(), 3));
    message.size = static_cast<size_t>(sqlite3_column_bytes(statement.get(), 3));
    last_time = message.time;
    visit(message);
  }
  if (step != SQLITE_DONE) {
    WarnTruncated("after message row " + std::to_string(last_id) + " (" + Reason() + ")",
                  last_time);
  }
}

std::vector<std::uint8_t> SqliteBag::Read(const BagPosition& position) const {
  const std::lock_guard<std::mutex> lock(read_mutex_);
  sqlite3_reset(read_);
  sqlite3_bind_int64(read_, 1, static_cast<sqlite3_int64>(position.block));
  if (sqlite3_step(read_) != SQLITE_ROW) {
    throw InputError(path_ + ": message row " + std::to_string(position.block) +
                     " cannot be read again (" + Reason() + ")");
  }
  const auto* data = static_cast<const std::uint8_t*>(sqlite3_column_blob(read_, 0));
  const auto size = static_cast<size_t>(sqlite3_column_bytes(read_, 0));
  std::vector<std::uint8_t> bytes(data, data + size);
  sqlite3_reset(read_);
  return bytes;
}

}  // namespace stillmap
