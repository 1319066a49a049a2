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
  if (!options.loop_closure) return;
  const Clock::time_point start = Clock::now();
  const Keyframe& keyframe = keyframes.at(keyframe_id);
  const std::map<int, int> shared = SharedLandmarks(keyframe_id);
  const std::vector<PlaceCandidate> voted = places.Query(
      keyframe.features.descriptors, std::numeric_limits<size_t>::max(), [](int) { return false; });
  // As ORB-SLAM2's loop detection: an earlier place must look at least as much like this view as
  // the least alike of the keyframes that share kWellConnected landmarks with it.
  constexpr int kWellConnected = 30;
  int min_votes = options.place_min_votes, least_alike = INT_MAX;
  for (const PlaceCandidate& candidate : voted) {
    const auto it = shared.find(candidate.keyframe_id);
    if (candidate.keyframe_id != keyframe_id && it != shared.end() &&
        it->second >= kWellConnected) {
      least_alike = std::min(least_alike, candidate.votes);
    }
  }
  if (least_alike != INT_MAX) min_votes = std::max(min_votes, least_alike);
  std::vector<int> candidates;
  for (const PlaceCandidate& candidate : voted) {
    if (candidate.votes < min_votes) break;  // ranked by votes
    const int id = candidate.keyframe_id;
    if (id > keyframe_id - options.loop_min_separation || shared.count(id) > 0) continue;
    const auto it = keyframes.find(id);
    if (it == keyframes.end() || it->second.descriptors.empty()) continue;
    candidates.push_back(id);
    if (candidates.size() >= static_cast<size_t>(options.place_candidates)) break;
  }
  int verified = -1;
  PoseEstimate estimate;
  Association association(keyframe.features.size());
  for (const int candidate : candidates) {
    ++stats.loop_candidates;
    const FrameData frame(keyframe.features, camera);
    ++match_serial;
    estimate = VerifyPlace(frame, candidate, options.loop_min_inliers, &association);
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
  if (verified < 0) {
    loop_streak = 0;
  } else {
    // The same place as the last keyframe's: that keyframe or one sharing landmarks with it.
    const bool same_place =
        loop_streak > 0 && (verified == loop_last_candidate ||
                            SharedLandmarks(verified).count(loop_last_candidate) > 0);
    loop_streak = same_place ? loop_streak + 1 : 1;
    loop_last_candidate = verified;
    if (loop_streak >= options.loop_consistency) {
      RequestLoopCorrection(keyframe_id, verified, estimate.camera_from_world, association);
      loop_streak = 0;
    }
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
      path_m += (it->second.camera_from_world.inverse().translation() -
                 previous->camera_from_world.inverse().translation())
                    .norm();
    }
    previous = &it->second;
  }
  const Eigen::Isometry3d correction =
      camera_from_world.inverse() * keyframes.at(keyframe_id).camera_from_world;
  const double angle_deg = Eigen::AngleAxisd(correction.linear()).angle() * 180.0 / M_PI;
  return correction.translation().norm() <=
             options.loop_max_drift_m + options.loop_max_drift_share * path_m &&
         angle_deg <= options.loop_max_drift_deg + options.loop_max_drift_deg_per_m * path_m;
}

void Tracker::Impl::AddCovisibilityEdges(const std::map<int, int>& node_of,
                                         PoseGraphProblem* problem) const {
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
  for (const auto& [pair, count] : shared) {
    if (count < options.pose_graph_min_shared) continue;
    const auto from = node_of.find(pair.first), to = node_of.find(pair.second);
    if (from == node_of.end() || to == node_of.end() || to->second == from->second + 1) continue;
    problem->edges.push_back(EdgeBetween(
        from->second, to->second, problem->world_from_node[static_cast<size_t>(from->second)],
        problem->world_from_node[static_cast<size_t>(to->second)]));
  }
}

}  // namespace stillmap
