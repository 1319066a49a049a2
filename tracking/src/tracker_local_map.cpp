#include "tracker_impl.h"

namespace stillmap {

LocalSet Tracker::Impl::CollectLocalLandmarks() {
  LocalSet local;
  const size_t stamp = ++collect_serial;
  const size_t count = map_keyframes.size();
  const size_t first = count > static_cast<size_t>(options.local_map_keyframes)
                           ? count - static_cast<size_t>(options.local_map_keyframes)
                           : 0;
  auto add = [&](int id) {
    if (id < 0) return;
    const auto it = landmarks.find(id);
    if (it == landmarks.end() || it->second.local_stamp == stamp) return;
    it->second.local_stamp = stamp;
    local.emplace_back(id, &it->second);
  };
  for (int id : last_frame_landmarks) add(id);
  for (size_t k = count; k-- > first;) {
    for (int id : keyframes.at(map_keyframes[k]).landmark_of_feature) add(id);
  }
  return local;
}

void Tracker::Impl::CullRecentLandmarks(int current_keyframe) {
  std::deque<int> kept;
  for (int id : recent_landmarks) {
    const auto it = landmarks.find(id);
    if (it == landmarks.end()) continue;
    const Landmark& landmark = it->second;
    const int age = current_keyframe - landmark.created_keyframe;
    const bool rarely_found =
        landmark.visible >= options.cull_min_visible &&
        landmark.found < options.cull_found_ratio * static_cast<double>(landmark.visible);
    const bool seen_once = age >= options.cull_single_view_age && landmark.observations.size() < 2;
    if (rarely_found || seen_once) {
      EraseLandmark(id);
    } else if (age < options.cull_recent_age) {
      kept.push_back(id);
    }
  }
  recent_landmarks = std::move(kept);
}

void Tracker::Impl::EraseLandmark(int id) {
  const auto it = landmarks.find(id);
  if (it == landmarks.end()) return;
  for (const auto& [keyframe_id, feature] : it->second.observations) {
    const auto keyframe = keyframes.find(keyframe_id);
    if (keyframe == keyframes.end()) continue;
    int& slot = keyframe->second.landmark_of_feature[static_cast<size_t>(feature)];
    if (slot == id) slot = -1;
  }
  landmarks.erase(it);
  ++stats.landmarks_culled;
}

void Tracker::Impl::StartMap(const Eigen::Isometry3d& camera_from_world, FrameData& frame,
                             size_t frame_index, double time, std::unique_lock<std::mutex>& lock) {
  TakeAdjustment(lock);
  UpdateFinal(true);
  for (int id : map_keyframes) {  // the old map's features are no longer needed
    Keyframe& keyframe = keyframes.at(id);
    keyframe.features = FrameFeatures();
    keyframe.descriptors.clear();
    keyframe.landmark_of_feature.clear();
  }
  landmarks.clear();
  recent_landmarks.clear();
  last_frame_landmarks.clear();
  map_keyframes.clear();
  next_final = 0;
  const Association none(frame.size());
  InsertKeyframe(camera_from_world, frame, none, frame_index, time, lock);
  have_map = true;
}

}  // namespace stillmap
