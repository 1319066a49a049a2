// A build's keyframes for its session record, their blocks parked in a spill file
// (spill_file.h) until the record is written: a long recording's keyframes are never all in
// memory at once.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "stillmap/io/session_record.h"
#include "stillmap/io/spill_file.h"

namespace stillmap {

class SessionKeyframeList {
 public:
  // Blocks are parked in a file of the list's own, or in `file`.
  SessionKeyframeList();
  explicit SessionKeyframeList(std::shared_ptr<SpillFile> file);

  // Parks `blocks`' features and images; the metadata stays in memory.
  void Add(const SessionKeyframeBlocks& blocks);
  // A keyframe whose blocks are in the list's file already (the features as
  // AppendSessionFeatures writes them).
  void AddParked(SessionKeyframe keyframe, size_t feature_count, SpillFile::Block features,
                 SpillFile::Block depth_png, SpillFile::Block color_jpeg);

  size_t size() const { return entries_.size(); }
  bool empty() const { return entries_.empty(); }
  // Keyframe `index`'s metadata; its features are in Load's blocks, not here.
  SessionKeyframe& keyframe(size_t index) { return entries_[index].keyframe; }
  const SessionKeyframe& keyframe(size_t index) const { return entries_[index].keyframe; }

  // Keyframe `index` whole, its features and images read back.
  SessionKeyframeBlocks Load(size_t index) const;
  // Writes the record (WriteSessionRecord) one keyframe at a time.
  void Write(const std::string& path, const SessionRecord& record) const;
  // Bytes held in memory (the metadata; the blocks are on disk).
  size_t MemoryBytes() const;

 private:
  struct Entry {
    SessionKeyframe keyframe;
    size_t feature_count = 0;
    SpillFile::Block features, depth_png, color_jpeg;
  };
  // An entry's blocks as the file holds them.
  SessionBlockBytes Read(const Entry& entry) const;

  std::shared_ptr<SpillFile> file_;
  std::vector<Entry> entries_;
};

}  // namespace stillmap
