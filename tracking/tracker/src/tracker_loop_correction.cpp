#include "tracker_impl.h"

namespace stillmap {

void Tracker::Impl::RequestLoopCorrection(int keyframe_id, int candidate,
                                          const Eigen::Isometry3d& camera_from_world,
                                          const Association& association) {
  std::map<int, Eigen::Isometry3d> world_from_keyframe;
  std::map<int, int> weakest_inliers;
  for (const auto& [id, keyframe] : keyframes) {
    world_from_keyframe.emplace(id, keyframe.camera_from_world.inverse());
    weakest_inliers.emplace(id, keyframe.weakest_inliers);
  }
  LoopCorrection loop =
      loops.PrepareCorrection(world_from_keyframe, weakest_inliers, CovisibilityPairs(),
                              keyframe_id, candidate, camera_from_world.inverse());
  for (size_t f = 0; f < association.landmark.size(); ++f) {
    if (association.landmark[f] >= 0) loop.merges.emplace_back(f, association.landmark[f]);
  }
  loop.handover_serial = frame_serial + static_cast<size_t>(options.loops.loop_handover_frames);
  pending_loop = std::move(loop);
  if (worker.joinable()) {
    loop_requested = true;
    wake.notify_one();
  } else {
    loops.Solve(&*pending_loop);
    pending_loop->is_solved = true;
  }
}

void Tracker::Impl::TakeLoopCorrection(std::unique_lock<std::mutex>& lock) {
  if (!pending_loop) return;
  TakeAdjustment(lock);  // solved in the frame before the correction
  if (!pending_loop->is_solved) {
    const Clock::time_point start = Clock::now();
    ba_done.wait(lock, [this] { return pending_loop->is_solved; });
    ++stats.loop_waits;
    stats.loop_wait_ms += MillisecondsSince(start);
  }
  const LoopCorrection loop = std::move(*pending_loop);
  pending_loop.reset();
  if (loop.error) std::rethrow_exception(loop.error);
  stats.loop_solve_ms += loop.ms;
  ApplyLoopCorrection(loop);
  MergeLoopLandmarks(loop);
  ++stats.loops_accepted;
  if (options.loops.loop_global_bundle_adjustment) RequestAdjustment(true);
  UpdateFinal();
}

void Tracker::Impl::ApplyLoopCorrection(const LoopCorrection& loop) {
  // world' = correction * world for each keyframe; keyframes made since the request move with
  // the loop's keyframe, and each landmark with the keyframe that made it.
  const std::map<int, Eigen::Isometry3d> correction = LoopClosure::Corrections(loop);
  const Eigen::Isometry3d at_loop = correction.at(loop.keyframe_id);
  const int newest = loop.ids.back();
  auto correction_of = [&](int keyframe_id) -> const Eigen::Isometry3d* {
    if (keyframe_id > newest) return &at_loop;
    const auto it = correction.find(keyframe_id);
    return it == correction.end() ? nullptr : &it->second;
  };
  for (auto& [id, keyframe] : keyframes) {
    const Eigen::Isometry3d* moved = correction_of(id);
    if (moved != nullptr)
      keyframe.camera_from_world = keyframe.camera_from_world * moved->inverse();
  }
  for (auto& [id, landmark] : landmarks) {
    const Eigen::Isometry3d* moved = correction_of(landmark.created_keyframe);
    if (moved == nullptr && !landmark.observations.empty()) {
      moved = correction_of(landmark.observations.front().first);
    }
    if (moved != nullptr) landmark.position = *moved * landmark.position;
  }
  CorrectedLoop corrected;
  corrected.correction_m = at_loop.translation().norm();
  corrected.correction_deg = RotationAngleDeg(at_loop);
  const auto keyframe = keyframes.find(loop.keyframe_id);
  const auto earlier = keyframes.find(loop.candidate);
  if (keyframe != keyframes.end()) corrected.time = keyframe->second.time;
  if (earlier != keyframes.end()) corrected.earlier_time = earlier->second.time;
  stats.loops_corrected.push_back(corrected);
  stats.loop_correction_m = std::max(stats.loop_correction_m, corrected.correction_m);
  stats.loop_correction_deg = std::max(stats.loop_correction_deg, corrected.correction_deg);
  // The frames tracked since are posed through their keyframes; the motion model's poses move
  // with the newest keyframe (its velocity is relative and stays).
  last_camera_from_world = last_camera_from_world * at_loop.inverse();
  last_good_camera_from_world = last_good_camera_from_world * at_loop.inverse();
}

void Tracker::Impl::MergeLoopLandmarks(const LoopCorrection& loop) {
  // The keyframe's features found in the earlier place: its landmarks are merged into those.
  const auto found = keyframes.find(loop.keyframe_id);
  if (found == keyframes.end()) return;  // culled since
  Keyframe& keyframe = found->second;
  for (const auto& [f, earlier] : loop.merges) {
    if (landmarks.count(earlier) == 0) continue;
    const int own = keyframe.landmark_of_feature[f];
    if (own == earlier) continue;
    if (own >= 0 && landmarks.count(own) > 0) {
      MergeLandmark(std::min(own, earlier), std::max(own, earlier));
      continue;
    }
    Landmark& landmark = landmarks.at(earlier);
    const bool seen = std::any_of(landmark.observations.begin(), landmark.observations.end(),
                                  [&](const auto& o) { return o.first == loop.keyframe_id; });
    if (!seen) {
      landmark.observations.emplace_back(loop.keyframe_id, static_cast<int>(f));
      keyframe.landmark_of_feature[f] = earlier;
    }
  }
}

void Tracker::Impl::MoveKeyframes(const std::map<int, Eigen::Isometry3d>& world_from_keyframe) {
  // world' = correction * world per keyframe moved.
  std::map<int, Eigen::Isometry3d> correction;
  for (const auto& [id, world_from_camera] : world_from_keyframe) {
    const auto it = keyframes.find(id);
    if (it == keyframes.end()) continue;
    correction.emplace(id, world_from_camera * it->second.camera_from_world);
    it->second.camera_from_world = world_from_camera.inverse();
  }
  if (correction.empty()) return;
  ++stats.segment_moves;
  const auto& [newest, at_newest] = *correction.rbegin();
  const bool current_map =
      std::find(map_keyframes.begin(), map_keyframes.end(), newest) != map_keyframes.end();
  if (!current_map) return;  // older segments keep no landmarks
  // The rest of the current map moves with the keyframe moved nearest before it (the keyframes
  // made since the newest one moved, those culled meanwhile), each landmark with its maker.
  auto nearest = [&](int keyframe_id) -> const Eigen::Isometry3d& {
    auto it = correction.upper_bound(keyframe_id);
    if (it != correction.begin()) --it;
    return it->second;
  };
  for (int id : map_keyframes) {
    if (correction.count(id) > 0) continue;
    Keyframe& keyframe = keyframes.at(id);
    keyframe.camera_from_world = keyframe.camera_from_world * nearest(id).inverse();
  }
  for (auto& [id, landmark] : landmarks) {
    landmark.position = nearest(landmark.created_keyframe) * landmark.position;
  }
  last_camera_from_world = last_camera_from_world * at_newest.inverse();
  last_good_camera_from_world = last_good_camera_from_world * at_newest.inverse();
}

}  // namespace stillmap
