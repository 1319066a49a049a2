// ROS 1 bags, format 2.0 (http://wiki.ros.org/Bags/Format/2.0), read by stillmap's own code:
// Debian's librosbag-dev would bring roscpp's serialization, boost and console bridge into every
// build for what is a few record types; the reader below is the whole of what stillmap needs. The
// records are read in file order whether or not the bag has its index (a recording cut short has
// none), so the index section is never required.
#pragma once

#include <fstream>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "bag/chunk_cache.h"
#include "stillmap/io/bag_reader.h"

namespace stillmap {

class Ros1Bag : public BagReader {
 public:
  static constexpr char kMagic[] = "#ROSBAG V2.0\n";
  static constexpr size_t kMagicSize = 13;

  // Throws InputError naming the file when it is not a ROS 1 bag of format 2.0 or its bag header
  // record is damaged.
  explicit Ros1Bag(const std::string& path);

  BagSerialization serialization() const override { return BagSerialization::kRos1; }
  const std::vector<BagTopic>& topics() const override { return topics_; }
  void Scan(const std::function<void(const BagMessage&)>& visit) override;
  std::vector<std::uint8_t> Read(const BagPosition& position) const override;

 private:
  // A record's header fields (name -> value) and where its data lies in the file.
  struct Record {
    std::map<std::string, std::string> fields;
    std::uint64_t data_offset = 0;
    std::uint32_t data_size = 0;
    std::uint64_t end = 0;  // the next record's offset
  };
  // The record at `offset`; false when the file ends inside it or its header is damaged
  // (*damage then says which).
  bool ReadRecord(std::ifstream& file, std::uint64_t offset, Record* record,
                  std::string* damage) const;
  // The chunk record at `offset`, decompressed into *out; false with *error when it cannot be.
  bool LoadChunk(std::ifstream& file, const Record& record, std::vector<std::uint8_t>* out,
                 std::string* error) const;
  // Registers a connection (its topic and type) from its record's fields and data.
  void AddConnection(const std::map<std::string, std::string>& fields, const std::uint8_t* data,
                     size_t size);
  // Visits the messages of one decompressed chunk; false when a record in it is damaged.
  bool ScanChunk(std::uint64_t chunk_offset, const std::vector<std::uint8_t>& chunk,
                 const std::function<void(const BagMessage&)>& visit, double* last_time);
  // The index section's connections and chunk positions, as far as its records parse (a bag cut
  // short has none): what a damaged data section is recovered from.
  void ReadIndex(std::ifstream& file);
  // The topic of connection `id`: the one its data-section record gave, else the index's
  // (registered then); false when neither knows it.
  bool TopicOfConnection(std::uint32_t id, size_t* topic);
  // True when a record of the data or index section starts at `offset` and the record after it
  // (or the file's end) follows: what a resynchronisation may resume at.
  bool IsRecordStart(std::ifstream& file, std::uint64_t offset) const;
  // The first record start after `from` (the index's next chunk, else found byte by byte), or
  // file_size_ when there is none.
  std::uint64_t NextRecordAfter(std::ifstream& file, std::uint64_t from) const;

  std::uint64_t file_size_ = 0;
  std::uint64_t data_start_ = 0;  // the first record after the bag header
  std::uint64_t index_pos_ = 0;   // the bag header's index_pos: where the index section starts
  std::vector<BagTopic> topics_;
  std::map<std::uint32_t, size_t> topic_of_connection_;
  std::map<std::uint32_t, BagTopic> index_connections_;
  std::vector<std::uint64_t> index_chunks_;  // chunk positions of the index, ascending

  // The chunk at `block`, decompressed (from the cache when there).
  const std::vector<std::uint8_t>& CachedChunkAt(std::uint64_t block) const;

  mutable std::mutex read_mutex_;  // guards the members below (Read)
  mutable std::ifstream read_file_;
  mutable ChunkCache cache_;
};

}  // namespace stillmap
