// A ROS 2 bag folder: metadata.yaml naming one or more storage files (`ros2 bag record` splits a
// long recording into NAME_0.db3, NAME_1.db3, ... or .mcap files), read as one bag: the files
// in the metadata's order, topics joined by name. A folder without metadata.yaml (a recording
// that was never closed: rosbag2 writes it last) reads its storage files in name order, with a
// warning.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "stillmap/io/bag_reader.h"

namespace stillmap {

class BagFolder : public BagReader {
 public:
  // Throws InputError naming the folder or file: a metadata.yaml that does not parse, names no
  // file or a missing one, a storage or compression rosbag2 has but stillmap does not read; or a
  // folder with no storage file.
  explicit BagFolder(const std::string& folder);

  BagSerialization serialization() const override { return BagSerialization::kCdr; }
  const std::vector<BagTopic>& topics() const override { return topics_; }
  void Scan(const std::function<void(const BagMessage&)>& visit) override;
  std::vector<std::uint8_t> Read(const BagPosition& position) const override;

 private:
  std::vector<std::string> FilesFromMetadata(const std::string& metadata);
  std::vector<std::string> FilesByName();
  // Joins part `part`'s topics into topics_ (by name).
  void JoinTopics(size_t part);

  std::vector<std::unique_ptr<BagReader>> parts_;
  std::vector<std::vector<size_t>> topic_of_part_topic_;  // per part
  std::vector<BagTopic> topics_;
  std::vector<std::string> notes_;  // warnings that every scan repeats
};

// True when `folder` is a directory that holds a ROS 2 bag: a metadata.yaml, or storage files
// (.db3, .mcap) and no TUM lists.
bool IsBagFolder(const std::string& folder);

}  // namespace stillmap
