#include "stillmap/io/bag_reader.h"

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "bag/bag_folder.h"
#include "bag/mcap_bag.h"
#include "bag/ros1_bag.h"
#include "bag/sqlite_bag.h"
#include "stillmap/io/error.h"

namespace stillmap {

std::uint64_t BagReader::CheckMagic(const char* magic, size_t magic_size,
                                    const std::string& what) const {
  std::ifstream file(path_, std::ios::binary | std::ios::ate);
  if (!file) throw InputError(path_ + ": cannot open the bag");
  const auto size = static_cast<std::uint64_t>(file.tellg());
  std::vector<char> start(magic_size, '\0');
  file.seekg(0);
  file.read(start.data(), static_cast<std::streamsize>(magic_size));
  if (!file || std::memcmp(start.data(), magic, magic_size) != 0) {
    throw InputError(path_ + ": not " + what);
  }
  return size;
}

void BagReader::WarnTruncated(std::uint64_t offset, std::uint64_t file_size, double last_time,
                              const std::string& damage) {
  WarnTruncated("at byte " + std::to_string(offset) + " of " + std::to_string(file_size) +
                    (damage.empty() ? "" : " (" + damage + ")"),
                last_time);
}

void BagReader::WarnTruncated(const std::string& where, double last_time) {
  char seconds[32];
  std::snprintf(seconds, sizeof(seconds), "%.3f", last_time);
  truncated_ = true;
  warnings_.push_back(path_ + ": truncated " + where + ": the recording ends at t = " + seconds +
                      " s; what comes before is read");
}

size_t JoinTopic(std::vector<BagTopic>* topics, const BagTopic& topic) {
  for (size_t t = 0; t < topics->size(); ++t) {
    if ((*topics)[t].name == topic.name && (*topics)[t].type == topic.type) return t;
  }
  topics->push_back(topic);
  return topics->size() - 1;
}

namespace {

enum class BagKind { kNone, kRos1, kMcap, kSqlite };

BagKind KindByMagic(const std::string& path) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) return BagKind::kNone;
  std::ifstream file(path, std::ios::binary);
  char magic[SqliteBag::kMagicSize] = {};
  file.read(magic, sizeof(magic));
  const auto read = static_cast<size_t>(file.gcount());
  if (read >= 9 && std::memcmp(magic, "#ROSBAG V", 9) == 0) return BagKind::kRos1;
  if (read >= McapBag::kMagicSize &&
      std::memcmp(magic, McapBag::kMagic, McapBag::kMagicSize) == 0) {
    return BagKind::kMcap;
  }
  if (read >= SqliteBag::kMagicSize &&
      std::memcmp(magic, SqliteBag::kMagic, SqliteBag::kMagicSize) == 0) {
    return BagKind::kSqlite;
  }
  return BagKind::kNone;
}

}  // namespace

bool LooksLikeBag(const std::string& path) {
  return KindByMagic(path) != BagKind::kNone || IsBagFolder(path);
}

std::unique_ptr<BagReader> OpenBag(const std::string& path) {
  std::error_code error;
  if (std::filesystem::is_directory(path, error)) return std::make_unique<BagFolder>(path);
  if (!std::ifstream(path, std::ios::binary)) throw InputError(path + ": cannot open the bag");
  switch (KindByMagic(path)) {
    case BagKind::kRos1:
      return std::make_unique<Ros1Bag>(path);
    case BagKind::kMcap:
      return std::make_unique<McapBag>(path);
    case BagKind::kSqlite:
      return std::make_unique<SqliteBag>(path);
    case BagKind::kNone:
      break;
  }
  throw InputError(path +
                   ": not a bag stillmap reads (expected a ROS 1 .bag, an MCAP file, a ROS 2 "
                   "sqlite3 .db3 file or a ROS 2 bag folder)");
}

}  // namespace stillmap
