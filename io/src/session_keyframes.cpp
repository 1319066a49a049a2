#include "stillmap/io/session_keyframes.h"

namespace stillmap {

SessionKeyframeList::SessionKeyframeList()
    : file_(std::make_shared<SpillFile>("the session's keyframes")) {}

SessionKeyframeList::SessionKeyframeList(std::shared_ptr<SpillFile> file)
    : file_(std::move(file)) {}

void SessionKeyframeList::Add(const SessionKeyframeBlocks& blocks) {
  std::vector<unsigned char> features;
  AppendSessionFeatures(blocks.keyframe.features, &features);
  SessionKeyframe keyframe = blocks.keyframe;
  keyframe.features.clear();
  keyframe.features.shrink_to_fit();
  AddParked(std::move(keyframe), blocks.keyframe.features.size(), file_->Append(features),
            file_->Append(blocks.depth_png), file_->Append(blocks.color_jpeg));
}

void SessionKeyframeList::AddParked(SessionKeyframe keyframe, size_t feature_count,
                                    SpillFile::Block features, SpillFile::Block depth_png,
                                    SpillFile::Block color_jpeg) {
  entries_.push_back({std::move(keyframe), feature_count, features, depth_png, color_jpeg});
}

SessionBlockBytes SessionKeyframeList::Read(const Entry& entry) const {
  return {file_->Read(entry.features), file_->Read(entry.depth_png), file_->Read(entry.color_jpeg)};
}

SessionKeyframeBlocks SessionKeyframeList::Load(size_t index) const {
  SessionBlockBytes bytes = Read(entries_[index]);
  SessionKeyframeBlocks blocks;
  blocks.keyframe = entries_[index].keyframe;
  blocks.keyframe.features = ParseSessionFeatures(bytes.features);
  blocks.depth_png = std::move(bytes.depth_png);
  blocks.color_jpeg = std::move(bytes.color_jpeg);
  return blocks;
}

void SessionKeyframeList::Write(const std::string& path, const SessionRecord& record) const {
  std::vector<SessionBlockSizes> rows;
  rows.reserve(entries_.size());
  for (const Entry& entry : entries_) {
    rows.push_back(
        {&entry.keyframe, entry.feature_count, entry.depth_png.size, entry.color_jpeg.size});
  }
  WriteSessionRecord(path, record, rows, [this](size_t index) { return Read(entries_[index]); });
}

size_t SessionKeyframeList::MemoryBytes() const { return entries_.capacity() * sizeof(Entry); }

}  // namespace stillmap
