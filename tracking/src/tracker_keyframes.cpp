#include "tracker_impl.h"

namespace stillmap {

bool Tracker::Impl::NeedKeyframe(const FrameData& frame, const Association& association,
                                 int inliers) const {
  if (inliers <= options.min_keyframe_inliers) return false;
  if (frames_since_keyframe >= options.max_keyframe_interval) return true;
  // Weak tracking asks for a keyframe at once; otherwise not within min_keyframe_interval.
  const bool weak = inliers < options.weak_tracking_inliers;
  if (!weak && frames_since_keyframe < options.min_keyframe_interval) return false;
  if (weak) return true;
  const Keyframe& reference = keyframes.at(map_keyframes.back());
  const size_t min_observations = map_keyframes.size() <= 2 ? 1 : 2;
  int reference_tracked = 0;
  for (int id : reference.landmark_of_feature) {
    if (id < 0) continue;
    const auto it = landmarks.find(id);
    if (it != landmarks.end() && it->second.observations.size() >= min_observations) {
      ++reference_tracked;
    }
  }
  int tracked_close = 0, untracked_close = 0;
  for (size_t i = 0; i < frame.size(); ++i) {
    const float depth = frame.features().depth_m[i];
    if (depth <= 0.0f || depth > options.close_depth) continue;
    (association.landmark[i] >= 0 ? tracked_close : untracked_close) += 1;
  }
  const bool need_close =
      tracked_close < options.close_tracked_max && untracked_close > options.close_untracked_min;
  return inliers < options.keyframe_ratio * reference_tracked || need_close;
}

int Tracker::Impl::InsertKeyframe(const Eigen::Isometry3d& camera_from_world, FrameData& frame,
                                  const Association& association, size_t frame_index, double time,
                                  std::unique_lock<std::mutex>& lock) {
  TakeAdjustment(lock);  // the last keyframe's adjustment first, whatever the frame count
  Keyframe keyframe;
  keyframe.id = next_keyframe++;
  keyframe.frame_index = frame_index;
  keyframe.time = time;
  keyframe.camera_from_world = camera_from_world;
  keyframe.landmark_of_feature.assign(frame.size(), -1);
  const Eigen::Isometry3d world_from_camera = camera_from_world.inverse();
  for (size_t i = 0; i < frame.size(); ++i) {
    const int matched = association.landmark[i];
    if (matched >= 0) {
      keyframe.landmark_of_feature[i] = matched;
      landmarks.at(matched).observations.emplace_back(keyframe.id, static_cast<int>(i));
      continue;
    }
    if (!UsableDepth(frame.features().depth_m[i])) continue;
    const int id = next_landmark++;
    Landmark& landmark = landmarks[id];
    landmark.position = world_from_camera * (frame.features().PointInCamera(i) *
                                             DepthFactor(frame.features().normalized[i]));
    landmark.descriptor = frame.descriptors()[i];
    landmark.octave = frame.octave(i);
    landmark.created_keyframe = keyframe.id;
    landmark.observations.emplace_back(keyframe.id, static_cast<int>(i));
    landmark.visible = 1;
    landmark.found = 1;
    keyframe.landmark_of_feature[i] = id;
    recent_landmarks.push_back(id);
    ++stats.landmarks_created;
  }
  keyframe.features = std::move(frame.features());
  keyframe.descriptors = std::move(frame.descriptors());
  const int id = keyframe.id;
  keyframes.emplace(id, std::move(keyframe));
  map_keyframes.push_back(id);
  ++stats.keyframes;
  frames_since_keyframe = 0;
  CullRecentLandmarks(id);
  if (options.depth_self_calibration && !options.depth_calibration_in_bundle_adjustment &&
      options.depth_calibration_interval > 0 &&
      map_keyframes.size() % static_cast<size_t>(options.depth_calibration_interval) == 0) {
    CalibrateDepth();
  }
  RequestAdjustment();
  UpdateFinal();
  return id;
}

void Tracker::Impl::UpdateFinal(bool all) {
  const size_t count = map_keyframes.size();
  const size_t window_first = count > static_cast<size_t>(options.local_window)
                                  ? count - static_cast<size_t>(options.local_window)
                                  : 0;
  int boundary = all ? INT_MAX : (count > 0 ? map_keyframes[window_first] : INT_MAX);
  boundary = std::min(boundary, all ? INT_MAX : running_window_first);
  while (next_final < count && map_keyframes[next_final] < boundary) {
    Keyframe& keyframe = keyframes.at(map_keyframes[next_final]);
    if (!keyframe.final) {
      keyframe.final = true;
      FinalKeyframe done{keyframe.id,
                         keyframe.frame_index,
                         keyframe.time,
                         keyframe.camera_from_world.inverse(),
                         {}};
      for (int id : keyframe.landmark_of_feature) {
        if (id >= 0) done.landmarks.push_back(id);
      }
      final_queue.push_back(std::move(done));
    }
    ++next_final;
  }
}

}  // namespace stillmap
