#include <algorithm>
#include <cmath>

#include "stillmap/io/depth_cells.h"
#include "tracker_impl.h"

namespace stillmap {

bool Tracker::Impl::NeedKeyframe(const FrameData& frame, const Association& association,
                                 int inliers) const {
  if (inliers <= options.local_map.min_keyframe_inliers) return false;
  if (frames_since_keyframe >= options.local_map.max_keyframe_interval) return true;
  // Weak tracking asks for a keyframe at once; otherwise not within min_keyframe_interval.
  const bool weak = inliers < options.local_map.weak_tracking_inliers;
  if (!weak && frames_since_keyframe < options.local_map.min_keyframe_interval) return false;
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
    if (depth <= 0.0f || depth > options.local_map.close_depth) continue;
    (association.landmark[i] >= 0 ? tracked_close : untracked_close) += 1;
  }
  const bool need_close = tracked_close < options.local_map.close_tracked_max &&
                          untracked_close > options.local_map.close_untracked_min;
  return inliers < options.local_map.keyframe_ratio * reference_tracked || need_close;
}

cv::Mat Tracker::Impl::SeenDepth(const cv::Mat& depth_m, const cv::Mat& ignore_mask) const {
  const int rows = (camera.height + kDepthCell - 1) / kDepthCell;
  const int columns = (camera.width + kDepthCell - 1) / kDepthCell;
  cv::Mat seen(rows, columns, CV_32FC3, cv::Scalar::all(0.0));
  if (depth_m.empty()) return seen;
  const cv::Mat cells =
      DepthCells(depth_m, ignore_mask, kDepthCell, options.matching.min_landmark_depth,
                 options.matching.max_landmark_depth);
  for (int row = 0; row < std::min(rows, cells.rows); ++row) {
    for (int column = 0; column < std::min(columns, cells.cols); ++column) {
      const cv::Vec4f& cell = cells.at<cv::Vec4f>(row, column);
      if (cell[3] < 0.25f) continue;  // a quarter of the cell read, or it counts as unseen
      seen.at<cv::Vec3f>(row, column) = {cell[0], cell[1], cell[2]};
    }
  }
  return seen;
}

template <typename Use>
double Tracker::Impl::CoveredShare(const Keyframe& keyframe, Use&& use) const {
  const double max_ratio = options.local_map.redundant_scale_ratio;
  const double min_cosine = std::cos(options.local_map.redundant_view_angle_deg * M_PI / 180.0);
  std::vector<const Keyframe*> near;
  for (int id : NearbyKeyframes(keyframe.camera_from_world, options.local_map.redundant_radius_m,
                                options.local_map.redundant_axis_angle_deg)) {
    if (use(id)) near.push_back(&keyframes.at(id));
  }
  const Eigen::Isometry3d world_from_camera = keyframe.camera_from_world.inverse();
  const Eigen::Vector3d centre = world_from_camera.translation();
  int cells = 0, covered = 0;
  for (int row = 0; row < keyframe.seen_depth.rows; ++row) {
    for (int column = 0; column < keyframe.seen_depth.cols; ++column) {
      const cv::Vec3f& cell = keyframe.seen_depth.at<cv::Vec3f>(row, column);
      if (cell[2] <= 0.0f) continue;
      ++cells;
      const double u0 = (column + 0.5) * kDepthCell, v0 = (row + 0.5) * kDepthCell;
      const Eigen::Vector3d point =
          world_from_camera * (cell[2] * Eigen::Vector3d((u0 - camera.cx) / camera.fx,
                                                         (v0 - camera.cy) / camera.fy, 1.0));
      const Eigen::Vector3d ray = point - centre;
      const double range = ray.norm();
      for (const Keyframe* other : near) {
        const Eigen::Vector3d p = other->camera_from_world * point;
        if (!UsableDepth(static_cast<float>(p.z()))) continue;
        const double u = camera.fx * p.x() / p.z() + camera.cx;
        const double v = camera.fy * p.y() / p.z() + camera.cy;
        if (u < 0.0 || v < 0.0 || u >= camera.width || v >= camera.height) continue;
        // It read a surface at that depth there (5 % and 3 cm of slack).
        const cv::Vec3f& seen = other->seen_depth.at<cv::Vec3f>(static_cast<int>(v) / kDepthCell,
                                                                static_cast<int>(u) / kDepthCell);
        if (seen[2] <= 0.0f || p.z() < 0.95 * seen[0] - 0.03 || p.z() > 1.05 * seen[1] + 0.03) {
          continue;
        }
        // Seen from a similar direction at a similar scale: the view adds nothing there.
        const double other_range = p.norm();
        const double ratio = other_range / range;
        if (ratio > max_ratio || ratio < 1.0 / max_ratio) continue;
        const Eigen::Vector3d other_ray = other->camera_from_world.linear().transpose() * p;
        if (other_ray.dot(ray) < min_cosine * other_range * range) continue;
        ++covered;
        break;
      }
    }
  }
  return cells == 0 ? 1.0 : static_cast<double>(covered) / cells;
}

bool Tracker::Impl::CullIfRedundant(size_t position) {
  if (position == 0 || position + 1 >= map_keyframes.size()) return false;  // the map's ends
  const int id = map_keyframes[position];
  Keyframe& keyframe = keyframes.at(id);
  // Against the keyframes kept before it: a chain of keyframes each covered by the next would
  // otherwise all go.
  const auto kept_before = [this, id](int other) {
    return other < id && !keyframes.at(other).retiring;
  };
  if (CoveredShare(keyframe, kept_before) <= options.local_map.redundant_keyframe_share)
    return false;
  FinalKeyframe done{
      id, keyframe.frame_index, keyframe.time, keyframe.camera_from_world.inverse(), {}, true, {}};
  for (int landmark : keyframe.landmark_of_feature) {
    if (landmark >= 0) done.landmarks.push_back(landmark);
  }
  final_queue.push_back(std::move(done));
  loops.RemovePlace(id);
  keyframe.retiring = true;
  ++stats.keyframes_culled;
  return true;
}

void Tracker::Impl::EraseRetired(bool all) {
  const auto keep = static_cast<size_t>(options.local_map.redundant_retire_keyframes);
  for (size_t position = 0; position < next_final;) {
    const int id = map_keyframes[position];
    const bool old_enough = all || position + keep < map_keyframes.size();
    if (!old_enough) break;
    if (keyframes.at(id).retiring) {
      EraseCulled(position);
      --next_final;
    } else {
      ++position;
    }
  }
}

void Tracker::Impl::EraseCulled(size_t position) {
  const int id = map_keyframes[position];
  const Keyframe& keyframe = keyframes.at(id);
  // Its frames go to the kept keyframe sharing most landmarks with it (else the next kept one).
  std::map<int, int> shared;
  for (int landmark : keyframe.landmark_of_feature) {
    if (landmark < 0 || landmarks.count(landmark) == 0) continue;
    for (const auto& observation : landmarks.at(landmark).observations) {
      if (observation.first != id) ++shared[observation.first];
    }
  }
  int parent = -1, most = 0;
  for (size_t p = position + 1; p < map_keyframes.size() && parent < 0; ++p) {
    if (!keyframes.at(map_keyframes[p]).retiring) parent = map_keyframes[p];
  }
  if (parent < 0) parent = map_keyframes[position == 0 ? 1 : position - 1];
  for (const auto& [other, n] : shared) {
    const auto it = keyframes.find(other);
    if (n > most && it != keyframes.end() && !it->second.retiring) {
      most = n;
      parent = other;
    }
  }
  culled[id] = {parent,
                keyframe.camera_from_world * keyframes.at(parent).camera_from_world.inverse()};
  for (size_t f = 0; f < keyframe.landmark_of_feature.size(); ++f) {
    const auto it = landmarks.find(keyframe.landmark_of_feature[f]);
    if (it == landmarks.end()) continue;
    auto& observations = it->second.observations;
    observations.erase(std::remove(observations.begin(), observations.end(),
                                   std::make_pair(id, static_cast<int>(f))),
                       observations.end());
    if (observations.empty()) EraseLandmark(it->first);
  }
  // The odometry edge to the keyframe after it now spans its frames too.
  const auto next = keyframes.upper_bound(id);
  if (next != keyframes.end()) {
    next->second.weakest_inliers = std::min(next->second.weakest_inliers, keyframe.weakest_inliers);
  } else {
    weakest_inliers_since_keyframe =
        std::min(weakest_inliers_since_keyframe, keyframe.weakest_inliers);
  }
  keyframes.erase(id);
  map_keyframes.erase(map_keyframes.begin() + static_cast<std::ptrdiff_t>(position));
}

Eigen::Isometry3d Tracker::Impl::CameraFromWorld(int keyframe_id) const {
  const auto it = keyframes.find(keyframe_id);
  if (it != keyframes.end()) return it->second.camera_from_world;
  const Culled& handed = culled.at(keyframe_id);
  return handed.camera_from_parent * CameraFromWorld(handed.parent);
}

int Tracker::Impl::InsertKeyframe(const Eigen::Isometry3d& camera_from_world, FrameData& frame,
                                  const Association& association, size_t frame_index, double time,
                                  std::unique_lock<std::mutex>& lock) {
  // The last keyframe's adjustment first, whatever the frame count; a global one at its frame.
  if (!GlobalAdjustmentRunning()) TakeAdjustment(lock);
  Keyframe keyframe;
  keyframe.id = next_keyframe++;
  keyframe.frame_index = frame_index;
  keyframe.time = time;
  keyframe.camera_from_world = camera_from_world;
  keyframe.weakest_inliers = weakest_inliers_since_keyframe;
  weakest_inliers_since_keyframe = INT_MAX;
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
  keyframe.seen_depth = SeenDepth(frame.depth_m(), frame.ignore_mask());
  keyframe.features = std::move(frame.features());
  keyframe.descriptors = std::move(frame.descriptors());
  const int id = keyframe.id;
  keyframes.emplace(id, std::move(keyframe));
  map_keyframes.push_back(id);
  ++stats.keyframes;
  frames_since_keyframe = 0;
  CullRecentLandmarks(id);
  if (options.matching.depth_self_calibration &&
      !options.matching.depth_calibration_in_bundle_adjustment &&
      options.matching.depth_calibration_interval > 0 &&
      map_keyframes.size() % static_cast<size_t>(options.matching.depth_calibration_interval) ==
          0) {
    CalibrateDepth();
  }
  loops.AddPlace(id, keyframes.at(id).features.descriptors);
  if (!pending_loop) DetectLoop(id);
  if (!pending) RequestAdjustment();
  UpdateFinal();
  return id;
}

void Tracker::Impl::UpdateFinal(bool all) {
  const size_t count = map_keyframes.size();
  const size_t window_first = count > static_cast<size_t>(options.local_map.local_window)
                                  ? count - static_cast<size_t>(options.local_map.local_window)
                                  : 0;
  int boundary = all ? INT_MAX : (count > 0 ? map_keyframes[window_first] : INT_MAX);
  boundary = std::min(boundary, all ? INT_MAX : running_window_first);
  while (next_final < map_keyframes.size() && map_keyframes[next_final] < boundary) {
    if (options.local_map.redundant_keyframe_share < 1.0 && CullIfRedundant(next_final)) {
      ++next_final;
      continue;
    }
    Keyframe& keyframe = keyframes.at(map_keyframes[next_final]);
    if (!keyframe.final) {
      keyframe.final = true;
      FinalKeyframe done{keyframe.id,
                         keyframe.frame_index,
                         keyframe.time,
                         keyframe.camera_from_world.inverse(),
                         {},
                         false,
                         {}};
      for (int id : keyframe.landmark_of_feature) {
        if (id >= 0) done.landmarks.push_back(id);
      }
      done.features = keyframe.features;
      done.weakest_inliers = keyframe.weakest_inliers;
      final_queue.push_back(std::move(done));
    }
    ++next_final;
  }
  EraseRetired(all);
}

}  // namespace stillmap
