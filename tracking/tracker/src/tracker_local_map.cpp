#include <algorithm>
#include <cmath>
#include <unordered_set>

#include "tracker_impl.h"

namespace stillmap {

std::vector<int> Tracker::Impl::LocalKeyframes() const {
  std::vector<int> out;
  std::unordered_set<int> taken;
  auto take = [&](int id) {
    if (taken.insert(id).second) out.push_back(id);
  };
  // The most recent keyframes of the current map, newest first.
  const size_t count = map_keyframes.size();
  const size_t recent = std::min(count, static_cast<size_t>(options.local_map.local_map_keyframes));
  for (size_t k = count; k-- > count - recent;) take(map_keyframes[k]);
  // Map reuse: keyframes that observe what the last frame matched (covisible), most shared first.
  // Keyframes near the predicted pose that are not covisible are left to the loop detection: a
  // place reached again after drift is joined by a verified loop that corrects the path, not by
  // matching the drifted landmarks here.
  std::map<int, int> shared;  // ordered by id: the ranking below does not depend on addresses
  for (int id : last_frame_landmarks) {
    const auto it = landmarks.find(id);
    if (it == landmarks.end()) continue;
    for (const auto& observation : it->second.observations) ++shared[observation.first];
  }
  std::vector<std::pair<int, int>> ranked;  // (-shared, id)
  ranked.reserve(shared.size());
  for (const auto& [id, n] : shared) ranked.emplace_back(-n, id);
  std::sort(ranked.begin(), ranked.end());
  size_t extra = 0;
  const size_t max_extra = static_cast<size_t>(options.local_map.local_map_keyframes);
  for (const auto& entry : ranked) {
    if (extra >= max_extra) break;
    if (keyframes.at(entry.second).descriptors.empty() || taken.count(entry.second) > 0) continue;
    take(entry.second);
    ++extra;
  }
  return out;
}

std::vector<int> Tracker::Impl::NearbyKeyframes(const Eigen::Isometry3d& camera_from_world,
                                                double radius_m, double max_angle_deg) const {
  const Eigen::Isometry3d world_from_camera = camera_from_world.inverse();
  const Eigen::Vector3d centre = world_from_camera.translation();
  const Eigen::Vector3d axis = world_from_camera.linear().col(2);
  const double min_cosine = std::cos(max_angle_deg * M_PI / 180.0);
  std::vector<int> out;
  for (const auto& [id, keyframe] : keyframes) {  // std::map: in id order
    if (keyframe.descriptors.empty()) continue;   // an earlier local map's, features dropped
    const Eigen::Isometry3d world_from_keyframe = keyframe.camera_from_world.inverse();
    if ((world_from_keyframe.translation() - centre).norm() > radius_m) continue;
    if (world_from_keyframe.linear().col(2).dot(axis) < min_cosine) continue;
    out.push_back(id);
  }
  return out;
}

LocalSet Tracker::Impl::PlaceLandmarks(int keyframe_id) {
  std::vector<std::pair<int, int>> ranked;  // (-shared, id)
  for (const auto& [id, n] : SharedLandmarks(keyframe_id)) ranked.emplace_back(-n, id);
  std::sort(ranked.begin(), ranked.end());
  LocalSet local;
  const size_t stamp = ++collect_serial;
  for (size_t k = 0;
       k < ranked.size() && k < static_cast<size_t>(options.local_map.local_map_keyframes); ++k) {
    for (const int id : keyframes.at(ranked[k].second).landmark_of_feature) {
      const auto it = id >= 0 ? landmarks.find(id) : landmarks.end();
      if (it == landmarks.end() || it->second.local_stamp == stamp) continue;
      it->second.local_stamp = stamp;
      local.emplace_back(id, &it->second);
    }
  }
  return local;
}

LocalSet Tracker::Impl::CollectLocalLandmarks() {
  LocalSet local;
  const size_t stamp = ++collect_serial;
  auto add = [&](int id) {
    if (id < 0) return;
    const auto it = landmarks.find(id);
    if (it == landmarks.end() || it->second.local_stamp == stamp) return;
    it->second.local_stamp = stamp;
    local.emplace_back(id, &it->second);
  };
  for (int id : last_frame_landmarks) add(id);
  for (int keyframe : LocalKeyframes()) {
    for (int id : keyframes.at(keyframe).landmark_of_feature) add(id);
  }
  return local;
}

void Tracker::Impl::MergeDuplicates(const Eigen::Isometry3d& camera_from_world,
                                    const FrameData& frame, Association* association) {
  // As ORB-SLAM2's fusion of map points: the copy must match the feature closely (its
  // descriptor within TH_LOW, 50) and project onto it (chi-square 5.99 at the feature's scale).
  constexpr int kMaxDistance = 50;
  constexpr double kChi2 = 5.991;
  for (const Duplicate& duplicate : duplicates) {
    const int kept = association->landmark[duplicate.feature];
    const int other = duplicate.landmark;
    if (kept < 0 || kept == other || duplicate.distance > kMaxDistance) continue;
    const auto it = landmarks.find(other);
    if (it == landmarks.end() || it->second.matched_stamp == match_serial) continue;
    const Landmark& landmark = landmarks.at(kept);
    if ((landmark.position - it->second.position).norm() >
        options.local_map.landmark_merge_distance_m) {
      continue;
    }
    const Eigen::Vector3d p = camera_from_world * it->second.position;
    if (p.z() <= 0.0) continue;
    const Eigen::Vector2d& seen = frame.features().normalized[duplicate.feature];
    const double sigma =
        options.matching.sigma_px * OctaveScale(frame.octave(duplicate.feature)) / camera.fx;
    if ((p.head<2>() / p.z() - seen).squaredNorm() > kChi2 * sigma * sigma) continue;
    // The one observed by more keyframes stays (ORB-SLAM2), the older one on a tie.
    const size_t kept_seen = landmark.observations.size(),
                 other_seen = it->second.observations.size();
    const int keep =
        kept_seen != other_seen ? (kept_seen > other_seen ? kept : other) : std::min(kept, other);
    MergeLandmark(keep, keep == kept ? other : kept);
    association->landmark[duplicate.feature] = keep;
    landmarks.at(keep).matched_stamp = match_serial;
  }
  duplicates.clear();
}

void Tracker::Impl::MergeLandmark(int keep, int drop) {
  Landmark& kept = landmarks.at(keep);
  const Landmark& dropped = landmarks.at(drop);
  for (const auto& observation : dropped.observations) {
    const int keyframe_id = observation.first, feature = observation.second;
    const auto keyframe = keyframes.find(keyframe_id);
    if (keyframe == keyframes.end()) continue;
    std::vector<int>& slots = keyframe->second.landmark_of_feature;
    if (static_cast<size_t>(feature) >= slots.size() ||
        slots[static_cast<size_t>(feature)] != drop) {
      continue;
    }
    const bool seen = std::any_of(kept.observations.begin(), kept.observations.end(),
                                  [&](const auto& o) { return o.first == keyframe_id; });
    slots[static_cast<size_t>(feature)] = seen ? -1 : keep;
    if (!seen) kept.observations.emplace_back(keyframe_id, feature);
  }
  kept.visible += dropped.visible;
  kept.found += dropped.found;
  landmarks.erase(drop);
  ++stats.landmarks_merged;
}

void Tracker::Impl::CullRecentLandmarks(int current_keyframe) {
  std::deque<int> kept;
  for (int id : recent_landmarks) {
    const auto it = landmarks.find(id);
    if (it == landmarks.end()) continue;
    const Landmark& landmark = it->second;
    const int age = current_keyframe - landmark.created_keyframe;
    const bool rarely_found =
        landmark.visible >= options.local_map.cull_min_visible &&
        landmark.found < options.local_map.cull_found_ratio * static_cast<double>(landmark.visible);
    const bool seen_once =
        age >= options.local_map.cull_single_view_age && landmark.observations.size() < 2;
    if (rarely_found || seen_once) {
      EraseLandmark(id);
    } else if (age < options.local_map.cull_recent_age) {
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

size_t Tracker::Impl::ForgetLandmarksFoundMoving(int keyframe_id, const cv::Mat& moving) {
  const auto it = keyframes.find(keyframe_id);
  if (!options.local_map.forget_landmarks_found_moving || it == keyframes.end() ||
      moving.type() != CV_8UC1) {
    return 0;
  }
  const Keyframe& keyframe = it->second;
  std::vector<int> found;
  for (size_t i = 0; i < keyframe.landmark_of_feature.size(); ++i) {
    const int id = keyframe.landmark_of_feature[i];
    if (id < 0) continue;
    const cv::Point2f& pixel = keyframe.features.keypoints[i].pt;
    const auto u = static_cast<int>(std::lround(pixel.x)),
               v = static_cast<int>(std::lround(pixel.y));
    if (u < 0 || v < 0 || u >= moving.cols || v >= moving.rows) continue;
    const auto landmark = landmarks.find(id);
    if (moving.at<std::uint8_t>(v, u) == 0 || landmark == landmarks.end()) continue;
    // Only near points: far away the depth check's evidence is weak (a far wall's readings were
    // found "moving" on teddy's desk), and a person that pulls the camera along is near.
    const double depth_m = (keyframe.camera_from_world * landmark->second.position).z();
    if (depth_m < options.local_map.close_depth) found.push_back(id);
  }
  std::sort(found.begin(), found.end());
  found.erase(std::unique(found.begin(), found.end()), found.end());
  for (int id : found) EraseLandmark(id);
  stats.landmarks_found_moving += found.size();
  return found.size();
}

void Tracker::Impl::StartMap(const Eigen::Isometry3d& camera_from_world, FrameData& frame,
                             size_t frame_index, double time, std::unique_lock<std::mutex>& lock) {
  TakeLoopCorrection(lock);
  TakeAdjustment(lock);
  UpdateFinal(true);
  for (int id : map_keyframes) {  // the old map's features are no longer needed
    Keyframe& keyframe = keyframes.at(id);
    loops.RemovePlace(id);
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
