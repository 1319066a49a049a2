#include "stillmap/io/bag_reader.h"

#include <cstdio>
#include <cstring>
#include <fstream>

#include "bag/mcap_bag.h"
#include "bag/ros1_bag.h"
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
  char seconds[32];
  std::snprintf(seconds, sizeof(seconds), "%.3f", last_time);
  truncated_ = true;
  warnings_.push_back(path_ + ": truncated at byte " + std::to_string(offset) + " of " +
                      std::to_string(file_size) + (damage.empty() ? "" : " (" + damage + ")") +
                      ": the recording ends at t = " + seconds + " s; what comes before is read");
}

bool LooksLikeBag(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  char magic[Ros1Bag::kMagicSize] = {};
  file.read(magic, Ros1Bag::kMagicSize);
  return file && (std::memcmp(magic, "#ROSBAG V", 9) == 0 ||
                  std::memcmp(magic, McapBag::kMagic, McapBag::kMagicSize) == 0);
}

std::unique_ptr<BagReader> OpenBag(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) throw InputError(path + ": cannot open the bag");
  char magic[Ros1Bag::kMagicSize] = {};
  file.read(magic, Ros1Bag::kMagicSize);
  if (std::memcmp(magic, "#ROSBAG V", 9) == 0) return std::make_unique<Ros1Bag>(path);
  if (std::memcmp(magic, McapBag::kMagic, McapBag::kMagicSize) == 0) {
    return std::make_unique<McapBag>(path);
  }
  throw InputError(path +
                   ": not a bag stillmap reads (expected a ROS 1 .bag or an MCAP file; ROS 2 "
                   "sqlite3 bags are not read yet)");
}

}  // namespace stillmap
