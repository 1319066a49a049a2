// Tracker::memory: what the keyframes, landmarks, place index and frame records hold.
#include "tracker_impl.h"

namespace stillmap {
namespace {

template <typename T>
size_t CapacityBytes(const std::vector<T>& values) {
  return values.capacity() * sizeof(T);
}

size_t MatBytes(const cv::Mat& image) { return image.total() * image.elemSize(); }

// What a keyframe holds beyond its own struct.
size_t KeyframeDataBytes(const Keyframe& keyframe) {
  const FrameFeatures& features = keyframe.features;
  return CapacityBytes(features.keypoints) + MatBytes(features.descriptors) +
         CapacityBytes(features.normalized) + CapacityBytes(features.depth_m) +
         CapacityBytes(keyframe.descriptors) + CapacityBytes(keyframe.landmark_of_feature) +
         MatBytes(keyframe.seen_depth);
}

// A node of std::unordered_map or std::map: the value, the links and the key's hash.
template <typename Value>
constexpr size_t kNodeBytes = sizeof(Value) + 4 * sizeof(void*);

}  // namespace

TrackerMemory Tracker::memory() const {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  TrackerMemory memory;
  for (const auto& [id, keyframe] : impl_->keyframes) {
    memory.keyframes += kNodeBytes<std::pair<const int, Keyframe>> + KeyframeDataBytes(keyframe);
  }
  memory.landmarks = impl_->landmarks.bucket_count() * sizeof(void*);
  for (const auto& [id, landmark] : impl_->landmarks) {
    memory.landmarks +=
        kNodeBytes<std::pair<const int, Landmark>> + CapacityBytes(landmark.observations);
  }
  memory.place_index = impl_->loops.MemoryBytes();
  memory.frames = CapacityBytes(impl_->records);
  return memory;
}

}  // namespace stillmap
