// Recorded robot data read as it is (issue 28): a bag's topics and messages, whatever wrote it.
// A reader streams the messages in file order with one block (a ROS 1 chunk) in memory at a
// time, and reads one message again from where the scan found it. Damage never throws past the
// part that reads: a bag cut short ends the scan with a warning that says "truncated" and the
// time where it ends; a block that cannot be decompressed is skipped with a warning.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace stillmap {

// How the messages are serialized: ROS 1's (little-endian, unaligned) or ROS 2's CDR.
enum class BagSerialization { kRos1, kCdr };

struct BagTopic {
  std::string name;
  std::string type;  // as the bag names it: "sensor_msgs/Image" (ROS 1), ".../msg/Image" (ROS 2)
};

// Where a message lies, to read it again.
struct BagPosition {
  std::uint64_t block = 0;   // ROS 1, MCAP: the file offset of its chunk; sqlite3: its row id
  std::uint32_t offset = 0;  // the offset of its record in the block's uncompressed data
  std::uint32_t part = 0;    // a split bag: which of its files
};

struct BagMessage {
  size_t topic = 0;   // index into topics()
  double time = 0.0;  // when it was recorded [s] (not its header stamp)
  BagPosition position;
  const std::uint8_t* data = nullptr;  // valid during the visit only
  size_t size = 0;
};

class BagReader {
 public:
  virtual ~BagReader() = default;
  virtual BagSerialization serialization() const = 0;
  // The topics known so far: all of them after Scan.
  virtual const std::vector<BagTopic>& topics() const = 0;
  // Calls visit for every message in file order.
  virtual void Scan(const std::function<void(const BagMessage&)>& visit) = 0;
  // The data of the message at `position` (as a scan gave it). Throws InputError naming the file
  // when it cannot be read. Safe to call from one thread while no scan runs.
  virtual std::vector<std::uint8_t> Read(const BagPosition& position) const = 0;
  // What the last scan met: "truncated ..." for a bag cut short, skipped blocks.
  const std::vector<std::string>& warnings() const { return warnings_; }
  bool truncated() const { return truncated_; }
  const std::string& path() const { return path_; }

 protected:
  explicit BagReader(std::string path) : path_(std::move(path)) {}
  // The file's size; throws InputError naming it when it cannot be opened, or when it does not
  // start with `magic` (`what` says what it should have been).
  std::uint64_t CheckMagic(const char* magic, size_t magic_size, const std::string& what) const;
  // Ends a scan at `offset` of `file_size`: a warning with "truncated" and the last time read.
  void WarnTruncated(std::uint64_t offset, std::uint64_t file_size, double last_time,
                     const std::string& damage = {});
  // The same where no byte offset is known: `where` says where the bag ends ("after row 7").
  void WarnTruncated(const std::string& where, double last_time);
  std::string path_;
  std::vector<std::string> warnings_;
  bool truncated_ = false;
};

// The index of the topic named `topic.name` of type `topic.type` in *topics, appended first when
// it is new: topics are one per name and type, however many connections or channels or files
// carry them (a name with two types is two topics, so that neither is decoded as the other).
size_t JoinTopic(std::vector<BagTopic>* topics, const BagTopic& topic);

// True when `path` is a file that starts like a bag stillmap reads (by its bytes, not its name:
// ROS 1, MCAP or SQLite), or a ROS 2 bag folder (metadata.yaml, or .db3/.mcap files and no
// TUM lists).
bool LooksLikeBag(const std::string& path);

// Opens a bag by its content: a ROS 1 .bag, an .mcap or .db3 file, or a ROS 2 bag folder (its
// files in metadata.yaml's order, as one bag). Throws InputError naming the file for one that is
// not a bag (or of a version stillmap does not read), cannot be opened, or whose first records
// are damaged.
std::unique_ptr<BagReader> OpenBag(const std::string& path);

}  // namespace stillmap
