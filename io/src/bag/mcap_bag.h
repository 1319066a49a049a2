// MCAP files (https://mcap.dev/spec), ROS 2's default bag format since Iron, read by stillmap's
// own code: Debian packages no MCAP library. The data section is read record by record, so a
// file without its summary (a recording cut short) reads the same; chunks are decompressed with
// libzstd or liblz4 and their CRC checked with zlib's crc32.
#pragma once

#include <fstream>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "bag/chunk_cache.h"
#include "stillmap/io/bag_reader.h"

namespace stillmap {

class McapBag : public BagReader {
 public:
  static constexpr char kMagic[] = "\x89MCAP0\r\n";
  static constexpr size_t kMagicSize = 8;

  // Throws InputError naming the file when it does not start with MCAP's magic.
  explicit McapBag(const std::string& path);

  BagSerialization serialization() const override { return BagSerialization::kCdr; }
  const std::vector<BagTopic>& topics() const override { return topics_; }
  void Scan(const std::function<void(const BagMessage&)>& visit) override;
  std::vector<std::uint8_t> Read(const BagPosition& position) const override;

 private:
  // Registers a schema or channel record's content; visits a message record's.
  void Record(std::uint8_t op, const std::uint8_t* content, size_t size, BagPosition position,
              const std::function<void(const BagMessage&)>& visit);
  // The chunk record whose content starts at `offset` (`size` bytes), decompressed and checked.
  bool LoadChunk(std::ifstream& file, std::uint64_t offset, std::uint64_t size,
                 std::vector<std::uint8_t>* out, std::string* error) const;
  const std::vector<std::uint8_t>& CachedChunkAt(std::uint64_t block) const;
  // The summary section's channels and chunk offsets, as far as its records parse (a recording
  // cut short has none): what a damaged data section is recovered from.
  void ReadSummary(std::ifstream& file);
  // The topic of channel `id`: the one its data-section record gave, else the summary's
  // (registered then); false when neither knows it.
  bool TopicOfChannel(std::uint16_t id, size_t* topic);
  // The first chunk record after `from` (the summary's next chunk bounds a byte-by-byte search),
  // or file_size_ when there is none.
  std::uint64_t NextChunkAfter(std::ifstream& file, std::uint64_t from) const;

  std::uint64_t file_size_ = 0;
  std::vector<BagTopic> topics_;
  std::map<std::uint16_t, std::string> schema_name_;
  std::map<std::uint16_t, size_t> topic_of_channel_;
  std::map<std::uint16_t, BagTopic> summary_channels_;
  std::vector<std::uint64_t> summary_chunks_;  // chunk offsets of the summary, ascending
  double last_time_ = 0.0;

  mutable std::mutex read_mutex_;  // guards the members below (Read)
  mutable std::ifstream read_file_;
  mutable ChunkCache cache_;
};

}  // namespace stillmap
