#include <cmath>
#include <limits>

#include "tracker_impl.h"

namespace stillmap {

std::map<int, int> Tracker::Impl::SharedLandmarks(int keyframe_id) const {
  std::map<int, int> shared;
  for (const int id : keyframes.at(keyframe_id).landmark_of_feature) {
    const auto it = id >= 0 ? landmarks.find(id) : landmarks.end();
    if (it == landmarks.end()) continue;
    for (const auto& observation : it->second.observations) ++shared[observation.first];
  }
  return shared;
}

void Tracker::Impl::DetectLoop(int keyframe_id) {
  if (!options.loops.loop_closure) return;
  const Clock::time_point start = Clock::now();
  const Keyframe& keyframe = keyframes.at(keyframe_id);
  const std::map<int, int> shared = SharedLandmarks(keyframe_id);
  const std::vector<int> candidates =
      loops.LoopCandidates(keyframe_id, keyframe.features.descriptors, shared, [this](int id) {
        const auto it = keyframes.find(id);
        return it != keyframes.end() && !it->second.descriptors.empty();
      });
  int verified = -1;
  PoseEstimate estimate;
  Association association(keyframe.features.size());
  for (const int candidate : candidates) {
    ++stats.loop_candidates;
    const FrameData frame(keyframe.features, camera);
    ++match_serial;
    estimate = VerifyPlace(frame, candidate, options.loops.loop_min_inliers, &association);
    if (estimate.ok && !PlausibleDrift(candidate, keyframe_id, estimate.camera_from_world)) {
      ++stats.loops_implausible;
      ClearMatches(association);
      estimate = {};
    }
    if (estimate.ok) {
      verified = candidate;
      ++stats.loops_verified;
      break;
    }
    ++stats.loops_rejected;
  }
  // The same place as the last keyframe's: that keyframe or one sharing landmarks with it.
  const bool same_place = verified >= 0 && loops.in_streak() &&
                          (verified == loops.last_candidate() ||
                           SharedLandmarks(verified).count(loops.last_candidate()) > 0);
  if (loops.AcceptVerified(verified, same_place)) {
    RequestLoopCorrection(keyframe_id, verified, estimate.camera_from_world, association);
  }
  stats.loop_ms += MillisecondsSince(start);
}

bool Tracker::Impl::PlausibleDrift(int candidate, int keyframe_id,
                                   const Eigen::Isometry3d& camera_from_world) const {
  // The path between the two, keyframe to keyframe.
  double path_m = 0.0;
  const Keyframe* previous = nullptr;
  for (auto it = keyframes.find(candidate); it != keyframes.end() && it->first <= keyframe_id;
       ++it) {
    if (previous != nullptr) {
      path_m += CameraDistance(it->second.camera_from_world, previous->camera_from_world);
    }
    previous = &it->second;
  }
  return loops.PlausibleDrift(
      path_m, camera_from_world.inverse() * keyframes.at(keyframe_id).camera_from_world);
}

std::map<std::pair<int, int>, int> Tracker::Impl::CovisibilityPairs() const {
  std::map<std::pair<int, int>, int> shared;  // (older, newer) keyframe ids -> landmarks shared
  for (const auto& entry : landmarks) {
    const auto& observations = entry.second.observations;
    for (size_t a = 0; a < observations.size(); ++a) {
      for (size_t b = a + 1; b < observations.size(); ++b) {
        const int i = observations[a].first, j = observations[b].first;
        if (i != j) ++shared[{std::min(i, j), std::max(i, j)}];
      }
    }
  }
  return shared;
}

}  // namespace stillmap
