// ROS 2 sqlite3 bags (rosbag2's storage layout: a `topics` table and a `messages` table of CDR
// blobs), ROS 2 Humble's default format, read through Debian's libsqlite3. The file is opened
// read-only and immutable: a bag on a read-only medium reads, and no journal or -shm file is
// ever written beside it. Messages are visited in row order, which is the order rosbag2 wrote
// them in.
#pragma once

#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "stillmap/io/bag_reader.h"

struct sqlite3;
struct sqlite3_stmt;

namespace stillmap {

class SqliteBag : public BagReader {
 public:
  static constexpr char kMagic[] = "SQLite format 3";  // 16 bytes with its terminating zero
  static constexpr size_t kMagicSize = 16;

  // Throws InputError naming the file when it is not an SQLite database, or one without
  // rosbag2's tables.
  explicit SqliteBag(const std::string& path);
  ~SqliteBag() override;
  SqliteBag(const SqliteBag&) = delete;
  SqliteBag& operator=(const SqliteBag&) = delete;

  BagSerialization serialization() const override { return BagSerialization::kCdr; }
  const std::vector<BagTopic>& topics() const override { return topics_; }
  // Damage (a file cut short, a page that does not parse) ends the scan with a "truncated"
  // warning at the last message read.
  void Scan(const std::function<void(const BagMessage&)>& visit) override;
  // BagPosition::block is the message's row id.
  std::vector<std::uint8_t> Read(const BagPosition& position) const override;

 private:
  // Prepares `sql`; throws InputError naming the bag with SQLite's reason.
  sqlite3_stmt* Prepare(const char* sql) const;
  // SQLite's last error in the bag's words (a file cut short, damage, not a database), never
  // SQLite's own text.
  std::string Reason() const;
  void ReadTopics();

  sqlite3* db_ = nullptr;
  std::uint64_t file_size_ = 0, stated_size_ = 0;  // [bytes]; stated: the header's page count
  std::vector<BagTopic> topics_;
  std::map<std::int64_t, size_t> topic_of_id_;
  std::vector<std::string> topic_warnings_;  // topics left out, said again by every scan

  mutable std::mutex read_mutex_;  // guards read_ (Read)
  sqlite3_stmt* read_ = nullptr;
};

}  // namespace stillmap
